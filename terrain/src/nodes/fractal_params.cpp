#include "nodes/fractal_params.hpp"

#include <array>
#include <bit>

namespace terrain {

float bits_to_float(std::uint32_t bits) {
  return std::bit_cast<float>(bits);
}
std::uint32_t float_to_bits(float value) {
  return std::bit_cast<std::uint32_t>(value);
}

noise::FractalParams read_fractal(FieldReader& reader, ParseContext& context,
                                  std::string_view default_kind) {
  static constexpr std::array<std::string_view, 5> kKinds{"none", "fbm", "ridged", "hybrid",
                                                          "warped"};
  static constexpr std::array<std::string_view, 2> kBases{"gradient", "simplex"};
  noise::FractalParams p;
  const std::string kind = reader.choice("kind", default_kind, kKinds);
  const std::string basis = reader.choice("basis", "gradient", kBases);
  const double amplitude = reader.number("amplitude", 100.0, {0.0, 1e5});
  const double wavelength = reader.number("wavelength", 1000.0, {0.01, 1e7});
  p.octaves = static_cast<int>(reader.integer("octaves", 8, 1, 24));
  p.lacunarity = static_cast<float>(reader.number("lacunarity", 2.0, {1.1, 8.0}));
  p.hurst = static_cast<float>(reader.number("hurst", 1.0, {0.05, 2.0}));
  p.seed = context.noise_seed(reader.integer("seed", 0, 0, 0xffffffffLL));
  p.ridge_offset = static_cast<float>(reader.number("ridge_offset", 1.0, {0.0, 2.0}));
  p.ridge_gain = static_cast<float>(reader.number("ridge_gain", 2.0, {0.0, 8.0}));
  p.kind = kind == "ridged"   ? noise::Fractal::ridged
           : kind == "hybrid" ? noise::Fractal::hybrid
           : kind == "warped" ? noise::Fractal::warped
                              : noise::Fractal::fbm;
  p.basis = basis == "simplex" ? noise::Basis::simplex : noise::Basis::gradient;
  p.amplitude = kind == "none" ? 0.0f : static_cast<float>(amplitude);
  p.frequency = static_cast<float>(1.0 / wavelength);
  // Schneider's warp constants (c1, c2, c3) as [c1, c2, c3x, c3y].
  std::array<double, 4> warp{0.35, 0.0, 0.11, 0.17};
  if (const nlohmann::json* w = reader.raw("warp")) {
    bool valid = w->is_array() && w->size() == 4;
    for (std::size_t i = 0; valid && i < 4; ++i) {
      valid = (*w)[i].is_number() && std::abs((*w)[i].get<double>()) <= 10.0;
      if (valid) warp[i] = (*w)[i].get<double>();
    }
    if (!valid)
      reader.fail("must be an array of four numbers [c1, c2, c3x, c3y] within ±10", "warp");
  }
  reader.canonical()["warp"] = nlohmann::json::array({warp[0], warp[1], warp[2], warp[3]});
  // Schneider's roughness is dimensionless: c₁ and c₃ act on the height sum in units of the
  // amplitude, so a scene warps alike at any amplitude and the warp's slope stays bounded by the
  // noise's own (in metres, a 100 m amplitude turned 0.35 into 35 rad per unit of roughness).
  // FractalParams carries them per metre, which every evaluator reads from the pool.
  const double per_metre = amplitude > 0.0 ? 1.0 / amplitude : 0.0;
  p.warp_c1 = static_cast<float>(warp[0] * per_metre);
  p.warp_c2 = static_cast<float>(warp[1]);
  p.warp_c3 = {static_cast<float>(warp[2] * per_metre), static_cast<float>(warp[3] * per_metre)};
  return p;
}

void pack_fractal(const noise::FractalParams& p, std::vector<float>& pool) {
  namespace at = fractal_layout;
  std::array<float, kFractalFloats> packed{};
  packed[at::kKind] = bits_to_float(static_cast<std::uint32_t>(p.kind));
  packed[at::kBasis] = bits_to_float(static_cast<std::uint32_t>(p.basis));
  packed[at::kSeed] = bits_to_float(p.seed);
  packed[at::kOctaves] = bits_to_float(static_cast<std::uint32_t>(p.octaves));
  packed[at::kFrequency] = p.frequency;
  packed[at::kAmplitude] = p.amplitude;
  packed[at::kLacunarity] = p.lacunarity;
  packed[at::kHurst] = p.hurst;
  packed[at::kRidgeOffset] = p.ridge_offset;
  packed[at::kRidgeGain] = p.ridge_gain;
  packed[at::kWarpC1] = p.warp_c1;
  packed[at::kWarpC2] = p.warp_c2;
  packed[at::kWarpC3X] = p.warp_c3.x;
  packed[at::kWarpC3Y] = p.warp_c3.y;
  pool.insert(pool.end(), packed.begin(), packed.end());
}

noise::FractalParams unpack_fractal(const float* pool) {
  namespace at = fractal_layout;
  noise::FractalParams p;
  p.kind = static_cast<noise::Fractal>(float_to_bits(pool[at::kKind]));
  p.basis = static_cast<noise::Basis>(float_to_bits(pool[at::kBasis]));
  p.seed = float_to_bits(pool[at::kSeed]);
  p.octaves = static_cast<int>(float_to_bits(pool[at::kOctaves]));
  p.frequency = pool[at::kFrequency];
  p.amplitude = pool[at::kAmplitude];
  p.lacunarity = pool[at::kLacunarity];
  p.hurst = pool[at::kHurst];
  p.ridge_offset = pool[at::kRidgeOffset];
  p.ridge_gain = pool[at::kRidgeGain];
  p.warp_c1 = pool[at::kWarpC1];
  p.warp_c2 = pool[at::kWarpC2];
  p.warp_c3 = {pool[at::kWarpC3X], pool[at::kWarpC3Y]};
  return p;
}

}  // namespace terrain
