// The material model's per-point arithmetic, inline and branch-free (selects on bit patterns,
// simd.hpp), so that loops over many points (colour tiles) vectorise. material.cpp's
// material_albedo and northness are these; gpu/glsl/material.glsl computes the same floats in the
// same order. A select returns one of its operands bit for bit, so the results are those of the
// branching form: the same bytes on every path.
#pragma once

#include <algorithm>
#include <cmath>

#include "terrain/material.hpp"
#include "terrain/simd.hpp"

namespace terrain::material_model {

// Offsets into the packed form, checked while compiling.
inline constexpr std::size_t kGrass = material_offset("grass");
inline constexpr std::size_t kForest = material_offset("forest");
inline constexpr std::size_t kMeadow = material_offset("meadow");
inline constexpr std::size_t kBareGround = material_offset("bare_ground");
inline constexpr std::size_t kScree = material_offset("scree");
inline constexpr std::size_t kRock = material_offset("rock");
inline constexpr std::size_t kSnow = material_offset("snow");
inline constexpr std::size_t kSand = material_offset("sand");
inline constexpr std::size_t kWater = material_offset("water");
inline constexpr std::size_t kForestHeight = material_offset("forest_height");
inline constexpr std::size_t kTreeLine = material_offset("tree_line");
inline constexpr std::size_t kBareGroundHeight = material_offset("bare_ground_height");
inline constexpr std::size_t kScreeHeight = material_offset("scree_height");
inline constexpr std::size_t kScreeSlope = material_offset("scree_slope");
inline constexpr std::size_t kRockSlope = material_offset("rock_slope");
inline constexpr std::size_t kSnowSlope = material_offset("snow_slope");
inline constexpr std::size_t kSandSlope = material_offset("sand_slope");
inline constexpr std::size_t kSnowLine = material_offset("snow_line");
inline constexpr std::size_t kSnowBlend = material_offset("snow_blend");
inline constexpr std::size_t kSnowAspect = material_offset("snow_aspect");
inline constexpr std::size_t kSnowPolar = material_offset("snow_polar");

/// clamp((x − lo) / (hi − lo), 0, 1): the linear ramp the model blends with (NaN stays NaN, as
/// with std::clamp). Selects on the bits: a ?: here is threaded into nested branches, which keep
/// a loop over points scalar under -ftrapping-math.
TERRAIN_SIMD_INLINE float ramp(float x, float lo, float hi) {
  const float t = (x - lo) / (hi - lo);
  const float above_zero = simd::select(simd::mask_of(t < 0.0f), 0.0f, t);
  return simd::select(simd::mask_of(1.0f < above_zero), 1.0f, above_zero);
}

/// min(x, 1) as std::min(1.0f, x) gives it, on the bits.
TERRAIN_SIMD_INLINE float at_most_one(float x) {
  return simd::select(simd::mask_of(x < 1.0f), x, 1.0f);
}

/// round(clamp(v, 0, 1)·255), halves away from zero: std::lround without the library call
/// (x − ⌊x⌋ is exact in floating point, so comparing it with one half rounds as lround does).
TERRAIN_SIMD_INLINE std::uint8_t colour_byte(float v) {
  const float x = ramp(v, 0.0f, 1.0f) * 255.0f;
  const int whole = static_cast<int>(x);
  return static_cast<std::uint8_t>(whole + (x - static_cast<float>(whole) >= 0.5f ? 1 : 0));
}

/// The light a surface with unit normal `normal` receives from a sun in unit direction `sun`:
/// 0.30 of ambient light plus 0.75 of the cosine of the angle between them (none from behind).
TERRAIN_SIMD_INLINE float sun_light(Vec3 normal, Vec3 sun) {
  const float cosine = normal.x * sun.x + normal.y * sun.y + normal.z * sun.z;
  const float diffuse = simd::select(simd::mask_of(0.0f < cosine), cosine, 0.0f);
  return 0.30f + 0.75f * diffuse;
}

TERRAIN_SIMD_INLINE Rgb mix_rgb(Rgb a, Rgb b, float t) {
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}

/// terrain::northness: 0 where the ground is flat (or the gradient NaN).
TERRAIN_SIMD_INLINE float northness(float east, float north) {
  const float steepness = std::sqrt(east * east + north * north);
  // Downhill is −gradient; its north component over its length, faded in up to a gradient of
  // 0.5 (27°), so that the bumps of gentle ground do not speckle the snow line.
  const float faced = -north / steepness * at_most_one(steepness * 2.0f);
  return simd::select(simd::mask_of(steepness > 0.0f), faced, 0.0f);
}

/// terrain::material_albedo.
TERRAIN_SIMD_INLINE Rgb albedo(const MaterialInput& input, const float* m) {
  const auto colour = [m](std::size_t at) { return Rgb{m[at], m[at + 1], m[at + 2]}; };
  const auto band = [m](float x, std::size_t at) { return ramp(x, m[at], m[at + 1]); };
  const float h = input.height;
  const float s = input.slope;
  Rgb ground = mix_rgb(colour(kGrass), colour(kForest), band(h, kForestHeight));
  ground = mix_rgb(ground, colour(kMeadow), band(h, kTreeLine));
  ground = mix_rgb(ground, colour(kBareGround), band(h, kBareGroundHeight));
  ground = mix_rgb(ground, colour(kScree), band(s, kScreeSlope) * band(h, kScreeHeight));
  ground = mix_rgb(ground, colour(kRock), band(s, kRockSlope));
  const float line = m[kSnowLine] - m[kSnowAspect] * input.northness - m[kSnowPolar] * input.polar;
  const float snow = ramp(h, line, line + m[kSnowBlend]) * (1.0f - band(s, kSnowSlope));
  ground = mix_rgb(ground, colour(kSnow), snow);
  ground = mix_rgb(ground, colour(kSand), input.shore * (1.0f - band(s, kSandSlope)));
  const std::uint32_t water = simd::mask_of(input.water);
  return {simd::select(water, m[kWater], ground.r), simd::select(water, m[kWater + 1], ground.g),
          simd::select(water, m[kWater + 2], ground.b)};
}

}  // namespace terrain::material_model
