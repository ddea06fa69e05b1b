#include "terrain/material.hpp"

#include <algorithm>
#include <cmath>

namespace terrain {

namespace {

constexpr Rgb kGrass{0.36f, 0.49f, 0.22f};
constexpr Rgb kForest{0.17f, 0.31f, 0.13f};
constexpr Rgb kMeadow{0.48f, 0.52f, 0.31f};
constexpr Rgb kBareGround{0.55f, 0.50f, 0.40f};
constexpr Rgb kScree{0.60f, 0.58f, 0.54f};
constexpr Rgb kRock{0.42f, 0.40f, 0.38f};
constexpr Rgb kSnow{0.95f, 0.96f, 0.98f};
constexpr Rgb kSand{0.80f, 0.74f, 0.56f};
constexpr Rgb kWater{0.12f, 0.30f, 0.45f};

}  // namespace

Rgb mix(Rgb a, Rgb b, float t) {
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}

float ramp(float x, float lo, float hi) {
  return std::clamp((x - lo) / (hi - lo), 0.0f, 1.0f);
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

Rgb material_albedo(const MaterialInput& input) {
  if (input.water) return kWater;
  const float h = input.height;
  const float s = input.slope;
  Rgb ground = mix(kGrass, kForest, ramp(h, 0.12f, 0.30f));
  ground = mix(ground, kMeadow, ramp(h, 0.48f, 0.60f));  // the tree line
  ground = mix(ground, kBareGround, ramp(h, 0.68f, 0.85f));
  ground = mix(ground, kScree, ramp(s, 0.45f, 0.60f) * ramp(h, 0.45f, 0.65f));
  ground = mix(ground, kRock, ramp(s, 0.62f, 0.82f));
  const float line = 0.80f - 0.10f * input.northness;
  const float snow = ramp(h, line, line + 0.08f) * (1.0f - ramp(s, 0.50f, 0.70f));
  ground = mix(ground, kSnow, snow);
  ground = mix(ground, kSand, input.shore * (1.0f - ramp(s, 0.25f, 0.45f)));
  return ground;
}

Vec3 normalise(Vec3 v) {
  const float l = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  return {v.x / l, v.y / l, v.z / l};
}

float sun_light(Vec3 normal, Vec3 sun) {
  const float diffuse = std::max(0.0f, normal.x * sun.x + normal.y * sun.y + normal.z * sun.z);
  return 0.30f + 0.75f * diffuse;
}

std::uint8_t colour_byte(float v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

}  // namespace terrain
