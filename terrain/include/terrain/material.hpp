// The material model: what colour the ground is at a point, from where it lies in the relief,
// how steep it is and which way it faces, whether water covers it or lies just below it, and how
// much of the sun's light it receives. One model for every picture of the terrain: render.png
// and the CPU tracer, colour imagery tiles, and (through gpu/glsl/material.glsl, its twin, which
// computes the same floats in the same order) the GPU tracer and the browser viewer.
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

/// clamp((x − lo) / (hi − lo), 0, 1): the linear ramp the model blends with.
float ramp(float x, float lo, float hi);

/// Where a point is, how it lies and what covers it.
struct MaterialInput {
  float height = 0.5f;     ///< elevation within the relief: 0 its lowest, 1 its highest
  float slope = 0.0f;      ///< sine of the slope angle: 0 flat, 1 vertical
  float northness = 0.0f;  ///< which way the slope faces: 1 north, −1 south, 0 east, west or flat
  float shore = 0.0f;      ///< 1 at a water's edge, falling to 0 a shore band above it
  bool water = false;      ///< under water
};

/// Northness of a slope from its gradient (∂h/∂east, ∂h/∂north): the north component of the
/// horizontal direction it faces (downhill), fading in up to a gradient of 0.5 (27°) so that
/// flat ground faces nowhere.
float northness(float east, float north);

/// The shore band of a scene whose heights lie in `relief`: 2 % of its height, at least 1 m
/// (render.png's water level and colour tiles' water layer measure shores with it).
float shore_band_for(Interval relief);

/// The ground's colour (docs/tile-encodings.md#colour-imagery): lowland grass, forest up to a
/// tree line at 55 % of the relief, alpine meadow, then bare ground; scree on steep slopes above
/// the tree line and rock on cliffs (from 38°, wholly from 55°); snow above a line at 80 % of the
/// relief, 10 % lower on slopes facing north and none on cliffs; sand on shores; water.
Rgb material_albedo(const MaterialInput& input);

/// v scaled to unit length (v must not be zero): the normals the model and the tracer light.
Vec3 normalise(Vec3 v);

/// The light a surface with unit normal `normal` receives from a sun in unit direction `sun`:
/// 0.30 of ambient light plus 0.75 of the cosine of the angle between them (none from behind).
float sun_light(Vec3 normal, Vec3 sun);

/// round(clamp(v, 0, 1)·255), halves away from zero.
std::uint8_t colour_byte(float v);

}  // namespace terrain
