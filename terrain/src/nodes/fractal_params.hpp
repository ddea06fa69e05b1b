// The "noise" object shared by nodes that carry fractal noise (disc, warp): parsing, canonical
// form and a fixed-size packing into the parameter pool.
#pragma once

#include <vector>

#include "field_reader.hpp"
#include "terrain/fractal_layout.hpp"
#include "terrain/noise.hpp"
#include "terrain/scene.hpp"

namespace terrain {

inline constexpr int kFractalFloats = static_cast<int>(fractal_layout::kFloats);

/// Reads {"kind", "basis", "amplitude", "wavelength", "octaves", "lacunarity", "hurst", "seed",
/// "ridge_offset", "ridge_gain", "warp": [c1, c2, c3x, c3y]}. kind "none" yields amplitude 0.
noise::FractalParams read_fractal(FieldReader& reader, ParseContext& context,
                                  std::string_view default_kind);
void pack_fractal(const noise::FractalParams& params, std::vector<float>& pool);
noise::FractalParams unpack_fractal(const float* pool);

/// Helpers for packing seeds and flags as float bits (GLSL reads them with floatBitsToUint).
float bits_to_float(std::uint32_t bits);
std::uint32_t float_to_bits(float value);

}  // namespace terrain
