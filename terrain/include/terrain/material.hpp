// The material model: what colour the ground is at a point, from where it lies in the relief,
// how steep it is and whether water covers it, and how much of the sun's light it receives. One
// model for every picture of the terrain: render.png and the CPU tracer, colour imagery tiles,
// and (through gpu/glsl/material.glsl, its twin, which must compute the same floats in the same
// order) the GPU tracer and the browser viewer.
#pragma once

#include <cstdint>

#include "terrain/math.hpp"

namespace terrain {

/// A colour, 0..1 per channel, written to 8-bit images as round(255·v) without a transfer curve.
struct Rgb {
  float r = 0.0f, g = 0.0f, b = 0.0f;
};

/// a + (b − a)·t per channel, in that order (what the GLSL twin writes out too).
Rgb mix(Rgb a, Rgb b, float t);

/// Where a point is and what covers it.
struct MaterialInput {
  float height = 0.5f;  ///< elevation within the relief: 0 its lowest, 1 its highest
  float slope = 0.0f;   ///< sine of the slope angle: 0 flat, 1 vertical
  bool water = false;   ///< under water
};

/// The ground's colour: grass in the lowlands turning to bare earth with height, rock on slopes
/// steeper than about 27°, snow on the top fifth of the relief where it is not steep, and water.
Rgb material_albedo(const MaterialInput& input);

/// The light a surface with unit normal `normal` receives from a sun in unit direction `sun`:
/// 0.30 of ambient light plus 0.75 of the cosine of the angle between them (none from behind).
float sun_light(Vec3 normal, Vec3 sun);

/// round(clamp(v, 0, 1)·255), halves away from zero.
std::uint8_t colour_byte(float v);

}  // namespace terrain
