#include "terrain/material.hpp"

#include <algorithm>
#include <cmath>

namespace terrain {

Rgb mix(Rgb a, Rgb b, float t) {
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}

Rgb material_albedo(const MaterialInput& input) {
  if (input.water) return {0.12f, 0.30f, 0.45f};
  const float height = input.height;
  const float slope = input.slope;
  Rgb ground =
      mix({0.32f, 0.45f, 0.20f}, {0.55f, 0.50f, 0.38f}, std::clamp(height * 1.4f, 0.0f, 1.0f));
  ground = mix(ground, {0.45f, 0.42f, 0.40f}, std::clamp((slope - 0.45f) * 4.0f, 0.0f, 1.0f));
  if (height > 0.8f && slope < 0.6f) {
    ground = mix(ground, {0.95f, 0.96f, 0.98f}, std::min((height - 0.8f) * 5.0f, 1.0f));
  }
  return ground;
}

float sun_light(Vec3 normal, Vec3 sun) {
  const float diffuse = std::max(0.0f, normal.x * sun.x + normal.y * sun.y + normal.z * sun.z);
  return 0.30f + 0.75f * diffuse;
}

std::uint8_t colour_byte(float v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

}  // namespace terrain
