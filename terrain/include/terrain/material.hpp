// The material model: what colour the ground is at a point, from where it lies in the relief,
// how steep it is and which way it faces, whether water covers it or lies just below it, and how
// much of the sun's light it receives. One model for every picture of the terrain: render.png
// and the CPU tracer, colour imagery tiles, and (through gpu/glsl/material.glsl, its twin, which
// computes the same floats in the same order) the GPU tracer and the browser viewer.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <variant>

#include <nlohmann/json.hpp>

#include "terrain/math.hpp"
#include "terrain/result.hpp"

namespace terrain {

/// A colour, 0..1 per channel, written to 8-bit images as round(255·v) without a transfer curve.
struct Rgb {
  float r = 0.0f, g = 0.0f, b = 0.0f;
};

/// a + (b − a)·t per channel, in that order (what the GLSL twin writes out too).
Rgb mix(Rgb a, Rgb b, float t);

/// The parameters of the material model (docs/material.md): the colours of its covers and
/// where each takes over. A scene or planet may set any of them ("material" in its JSON); the
/// defaults are these. Heights are fractions of the relief (0 its lowest, 1 its highest), slopes
/// degrees from the horizontal, and each band [lo, hi] blends from none at lo to all at hi.
struct Material {
  Rgb grass{0.36f, 0.49f, 0.22f};
  Rgb forest{0.17f, 0.31f, 0.13f};
  Rgb meadow{0.48f, 0.52f, 0.31f};
  Rgb bare_ground{0.55f, 0.50f, 0.40f};
  Rgb scree{0.60f, 0.58f, 0.54f};
  Rgb rock{0.42f, 0.40f, 0.38f};
  Rgb snow{0.95f, 0.96f, 0.98f};
  Rgb sand{0.80f, 0.74f, 0.56f};
  Rgb water{0.12f, 0.30f, 0.45f};
  Interval forest_height{0.12f, 0.30f};       ///< grass gives way to forest
  Interval tree_line{0.48f, 0.60f};           ///< forest gives way to alpine meadow
  Interval bare_ground_height{0.68f, 0.85f};  ///< meadow gives way to bare ground
  Interval scree_height{0.45f, 0.65f};        ///< scree on steep ground starts here…
  Interval scree_slope{27.0f, 37.0f};         ///< …on slopes this steep
  Interval rock_slope{38.0f, 55.0f};          ///< cliffs are bare rock
  Interval snow_slope{30.0f, 45.0f};          ///< snow slides off slopes this steep
  Interval sand_slope{15.0f, 27.0f};          ///< shores this steep are not sand
  float snow_line = 0.80f;    ///< where snow starts on level ground facing east or west
  float snow_blend = 0.08f;   ///< the height over which snow covers the ground fully
  float snow_aspect = 0.10f;  ///< how much lower the line lies on slopes facing the pole
  float snow_polar = 0.70f;   ///< how much lower it lies at a pole than at the equator (planets)
};

enum class MaterialFieldKind { colour, heights, slopes, number };

/// One parameter of the material: its JSON name, its kind and where the struct keeps it. This
/// table is the one list of parameters: parsing, the canonical JSON, the packed form, the GLSL
/// offsets and the docs check all walk it.
struct MaterialField {
  std::string_view name;
  MaterialFieldKind kind;
  std::variant<Rgb Material::*, Interval Material::*, float Material::*> member;
  float min = 0.0f;  ///< the range every number of the parameter must lie in
  float max = 1.0f;
};

inline constexpr std::array<MaterialField, 21> kMaterialFields{{
    {"grass", MaterialFieldKind::colour, &Material::grass},
    {"forest", MaterialFieldKind::colour, &Material::forest},
    {"meadow", MaterialFieldKind::colour, &Material::meadow},
    {"bare_ground", MaterialFieldKind::colour, &Material::bare_ground},
    {"scree", MaterialFieldKind::colour, &Material::scree},
    {"rock", MaterialFieldKind::colour, &Material::rock},
    {"snow", MaterialFieldKind::colour, &Material::snow},
    {"sand", MaterialFieldKind::colour, &Material::sand},
    {"water", MaterialFieldKind::colour, &Material::water},
    {"forest_height", MaterialFieldKind::heights, &Material::forest_height, 0.0f, 2.0f},
    {"tree_line", MaterialFieldKind::heights, &Material::tree_line, 0.0f, 2.0f},
    {"bare_ground_height", MaterialFieldKind::heights, &Material::bare_ground_height, 0.0f, 2.0f},
    {"scree_height", MaterialFieldKind::heights, &Material::scree_height, 0.0f, 2.0f},
    {"scree_slope", MaterialFieldKind::slopes, &Material::scree_slope, 0.0f, 90.0f},
    {"rock_slope", MaterialFieldKind::slopes, &Material::rock_slope, 0.0f, 90.0f},
    {"snow_slope", MaterialFieldKind::slopes, &Material::snow_slope, 0.0f, 90.0f},
    {"sand_slope", MaterialFieldKind::slopes, &Material::sand_slope, 0.0f, 90.0f},
    {"snow_line", MaterialFieldKind::number, &Material::snow_line, 0.0f, 2.0f},
    {"snow_blend", MaterialFieldKind::number, &Material::snow_blend, 0.001f, 1.0f},
    {"snow_aspect", MaterialFieldKind::number, &Material::snow_aspect},
    {"snow_polar", MaterialFieldKind::number, &Material::snow_polar, 0.0f, 2.0f},
}};

/// Floats a parameter of this kind takes in the packed form.
constexpr std::size_t material_field_width(MaterialFieldKind kind) {
  return kind == MaterialFieldKind::colour ? 3 : kind == MaterialFieldKind::number ? 1 : 2;
}

/// Where the parameter `name` starts in the packed form (not constant-evaluable for an unknown
/// name, so a misspelt offset does not compile).
constexpr std::size_t material_offset(std::string_view name) {
  std::size_t at = 0;
  for (const MaterialField& field : kMaterialFields) {
    if (field.name == name) return at;
    at += material_field_width(field.kind);
  }
  throw "no such material parameter";
}

inline constexpr std::size_t kMaterialFloats = [] {
  std::size_t n = 0;
  for (const MaterialField& field : kMaterialFields) n += material_field_width(field.kind);
  return n;
}();

/// The parameters as every evaluator of the model reads them, C++ and GLSL alike (uniform
/// u_material): colours as r, g, b; bands as lo, hi, slopes as the sines of their angles;
/// numbers as themselves; at the offsets of kMaterialFields' order.
using PackedMaterial = std::array<float, kMaterialFloats>;

PackedMaterial pack_material(const Material& material);

/// `#define MATERIAL_<FIELD> <offset>` for every parameter, MATERIAL_FLOATS and the uniform
/// array that material.glsl reads: what the GPU tracer and the browser put before it.
std::string material_glsl_declarations();

/// Whether every evaluator draws two materials the same (their packed forms are equal).
bool same_material(const Material& a, const Material& b);

/// Parses a "material" object (docs/material.md): absent fields take the defaults; colours are
/// [r, g, b] in 0..1 or "#rrggbb"; errors name the field under `pointer`
/// ("/material/rock_slope/1").
Result<Material> parse_material(const nlohmann::json& object, std::string_view pointer);

/// The canonical JSON of a material: every field explicit, colours as arrays.
nlohmann::json material_json(const Material& material);

/// Where a point is, how it lies and what covers it.
struct MaterialInput {
  float height = 0.5f;  ///< elevation within the relief: 0 its lowest, 1 its highest
  float slope = 0.0f;   ///< sine of the slope angle: 0 flat, 1 vertical
  /// Which way the slope faces: 1 towards the pole (north on scenes), −1 towards the equator,
  /// 0 east, west or flat.
  float northness = 0.0f;
  float shore = 0.0f;  ///< 1 at a water's edge, falling to 0 a shore band above it
  bool water = false;  ///< under water
  float polar = 0.0f;  ///< |sine of the latitude| on planets; 0 on scenes
};

/// Northness of a slope from its gradient (∂h/∂east, ∂h/∂north): the north component of the
/// horizontal direction it faces (downhill), fading in up to a gradient of 0.5 (27°) so that
/// flat ground faces nowhere.
float northness(float east, float north);

/// The shore band of a scene whose heights lie in `relief`: 2 % of its height, at least 1 m
/// (render.png's water level and colour tiles' water layer measure shores with it).
float shore_band_for(Interval relief);

/// The ground's colour (docs/material.md): lowland grass, forest up to a tree line, alpine
/// meadow, then bare ground; scree on steep slopes above the tree line and rock on cliffs; snow
/// above a line that falls on slopes facing the pole and towards the poles, none on cliffs; sand
/// on shores; water. With the default material: tree line at 55 % of the relief, rock from 38°
/// (wholly from 55°), snow from 80 %, 10 % lower facing north.
Rgb material_albedo(const MaterialInput& input, const PackedMaterial& material);

/// v scaled to unit length (v must not be zero): the normals the model and the tracer light.
inline Vec3 normalise(Vec3 v) {
  const float l = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  return {v.x / l, v.y / l, v.z / l};
}

// The model's per-point arithmetic (ramps, the sun's light, bytes of a colour) is inline and
// branch-free in terrain/src/material_model.hpp, for the loops of colour tiles.

}  // namespace terrain
