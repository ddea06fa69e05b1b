#include "terrain/material.hpp"

#include <algorithm>
#include <cmath>

#include "material_model.hpp"

namespace terrain {

Rgb mix(Rgb a, Rgb b, float t) {
  return material_model::mix_rgb(a, b, t);
}

float northness(float east, float north) {
  return material_model::northness(east, north);
}

float shore_band_for(Interval relief) {
  return std::max(0.02f * relief.width(), 1.0f);
}

Rgb material_albedo(const MaterialInput& input, const PackedMaterial& m) {
  return material_model::albedo(input, m.data());
}

}  // namespace terrain
