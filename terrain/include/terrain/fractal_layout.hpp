// Where a fractal's fields lie in the parameter pool (pack_fractal writes them, the CPU and GPU
// evaluators read them): declared once, here. The GLSL gets the same offsets as constants
// (kFractal<Field>, gpu::node_table_glsl).
#pragma once

#include <array>
#include <cstdint>
#include <string_view>
#include <utility>

namespace terrain::fractal_layout {

inline constexpr std::uint32_t kKind = 0;     ///< noise::Fractal, as uint bits
inline constexpr std::uint32_t kBasis = 1;    ///< noise::Basis, as uint bits
inline constexpr std::uint32_t kSeed = 2;     ///< uint bits
inline constexpr std::uint32_t kOctaves = 3;  ///< uint bits
inline constexpr std::uint32_t kFrequency = 4;
inline constexpr std::uint32_t kAmplitude = 5;
inline constexpr std::uint32_t kLacunarity = 6;
inline constexpr std::uint32_t kHurst = 7;
inline constexpr std::uint32_t kRidgeOffset = 8;
inline constexpr std::uint32_t kRidgeGain = 9;
inline constexpr std::uint32_t kWarpC1 = 10;
inline constexpr std::uint32_t kWarpC2 = 11;
inline constexpr std::uint32_t kWarpC3X = 12;
inline constexpr std::uint32_t kWarpC3Y = 13;
/// r^−H, which the GPU loader fills in (correctly rounded from double); 0 as packed.
inline constexpr std::uint32_t kGain = 14;
/// Floats per fractal (one spare).
inline constexpr std::uint32_t kFloats = 16;

/// Every field by name (snake case), for generated tables.
inline constexpr auto kFields = std::to_array<std::pair<std::string_view, std::uint32_t>>({
    {"kind", kKind},
    {"basis", kBasis},
    {"seed", kSeed},
    {"octaves", kOctaves},
    {"frequency", kFrequency},
    {"amplitude", kAmplitude},
    {"lacunarity", kLacunarity},
    {"hurst", kHurst},
    {"ridge_offset", kRidgeOffset},
    {"ridge_gain", kRidgeGain},
    {"warp_c1", kWarpC1},
    {"warp_c2", kWarpC2},
    {"warp_c3x", kWarpC3X},
    {"warp_c3y", kWarpC3Y},
    {"gain", kGain},
});

}  // namespace terrain::fractal_layout
