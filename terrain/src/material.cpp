#include "terrain/material.hpp"

#include <algorithm>
#include <cmath>

namespace terrain {

Rgb mix(Rgb a, Rgb b, float t) {
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}

float northness(float east, float north) {
  const float steepness = std::sqrt(east * east + north * north);
  if (!(steepness > 0.0f)) return 0.0f;
  // Downhill is −gradient; its north component over its length, faded in up to a gradient of
  // 0.5 (27°), so that the bumps of gentle ground do not speckle the snow line.
  return -north / steepness * std::min(steepness * 2.0f, 1.0f);
}

float shore_band_for(Interval relief) {
  return std::max(0.02f * relief.width(), 1.0f);
}

namespace {

// Offsets into the packed form, checked while compiling.
constexpr std::size_t kGrass = material_offset("grass");
constexpr std::size_t kForest = material_offset("forest");
constexpr std::size_t kMeadow = material_offset("meadow");
constexpr std::size_t kBareGround = material_offset("bare_ground");
constexpr std::size_t kScree = material_offset("scree");
constexpr std::size_t kRock = material_offset("rock");
constexpr std::size_t kSnow = material_offset("snow");
constexpr std::size_t kSand = material_offset("sand");
constexpr std::size_t kWater = material_offset("water");
constexpr std::size_t kForestHeight = material_offset("forest_height");
constexpr std::size_t kTreeLine = material_offset("tree_line");
constexpr std::size_t kBareGroundHeight = material_offset("bare_ground_height");
constexpr std::size_t kScreeHeight = material_offset("scree_height");
constexpr std::size_t kScreeSlope = material_offset("scree_slope");
constexpr std::size_t kRockSlope = material_offset("rock_slope");
constexpr std::size_t kSnowSlope = material_offset("snow_slope");
constexpr std::size_t kSandSlope = material_offset("sand_slope");
constexpr std::size_t kSnowLine = material_offset("snow_line");
constexpr std::size_t kSnowBlend = material_offset("snow_blend");
constexpr std::size_t kSnowAspect = material_offset("snow_aspect");
constexpr std::size_t kSnowPolar = material_offset("snow_polar");

}  // namespace

Rgb material_albedo(const MaterialInput& input, const PackedMaterial& m) {
  auto colour = [&](std::size_t at) { return Rgb{m[at], m[at + 1], m[at + 2]}; };
  auto band = [&](float x, std::size_t at) { return ramp(x, m[at], m[at + 1]); };
  if (input.water) return colour(kWater);
  const float h = input.height;
  const float s = input.slope;
  Rgb ground = mix(colour(kGrass), colour(kForest), band(h, kForestHeight));
  ground = mix(ground, colour(kMeadow), band(h, kTreeLine));
  ground = mix(ground, colour(kBareGround), band(h, kBareGroundHeight));
  ground = mix(ground, colour(kScree), band(s, kScreeSlope) * band(h, kScreeHeight));
  ground = mix(ground, colour(kRock), band(s, kRockSlope));
  const float line = m[kSnowLine] - m[kSnowAspect] * input.northness - m[kSnowPolar] * input.polar;
  const float snow = ramp(h, line, line + m[kSnowBlend]) * (1.0f - band(s, kSnowSlope));
  ground = mix(ground, colour(kSnow), snow);
  ground = mix(ground, colour(kSand), input.shore * (1.0f - band(s, kSandSlope)));
  return ground;
}

}  // namespace terrain
