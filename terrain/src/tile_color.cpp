#include "terrain/tile_color.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "material_model.hpp"
#include "terrain/image_io.hpp"
#include "terrain/material.hpp"
#include "terrain/simd.hpp"
#include "tile_encoding_checks.hpp"

namespace terrain {
namespace {

using namespace tile_encoding;  // NOLINT(google-build-using-namespace): the shared checks

Status check_inputs(const HeightTile& tile, const ColorTileInputs& inputs) {
  if (!(std::isfinite(inputs.relief.lo) && std::isfinite(inputs.relief.hi) &&
        inputs.relief.lo <= inputs.relief.hi)) {
    return Error{"the relief must be a finite interval", "/relief"};
  }
  if (!inputs.water_surface.empty() && inputs.water_surface.size() != sample_count(tile)) {
    return Error{"water_surface has " + std::to_string(inputs.water_surface.size()) +
                     " values for " + std::to_string(sample_count(tile)) + " samples",
                 "/water_surface"};
  }
  if (!(inputs.shore_band >= 0.0f && std::isfinite(inputs.shore_band))) {
    return Error{"the shore band must be finite and at least 0", "/shore_band"};
  }
  if (!inputs.polar.empty() && inputs.polar.size() != static_cast<std::size_t>(tile.height)) {
    return Error{"must hold one value per row of samples", "/polar"};
  }
  for (std::size_t row = 0; row < inputs.polar.size(); ++row) {
    if (!(std::abs(inputs.polar[row]) <= 1.0f)) {
      return Error{"must be a sine, -1 to 1", "/polar/" + std::to_string(row)};
    }
  }
  if (Status ok = check_light(inputs.light); !ok) return ok.error();
  if (Status ok = check_heights(tile); !ok) return ok.error();
  return check_slopes(tile);
}

constexpr float kNoWater = std::numeric_limits<float>::quiet_NaN();

/// One row of a colour tile and what colours it.
struct ColourRow {
  const float* ground = nullptr;
  const float* slope_east = nullptr;
  const float* slope_north = nullptr;
  const float* surface = nullptr;  ///< the water's surface per sample, NaN where none is near
  int count = 0;
  float polar = 0.0f;  ///< the row's latitude's sine on planets (signed), 0 on scenes
  float lo = 0.0f, width = 0.0f, shore_band = 0.0f, z_factor = 1.0f;
  Vec3 sun;
  const float* material = nullptr;  ///< the packed material
};

/// Colours one row into three channel rows. Branch-free (material_model.hpp), so GCC
/// vectorises it; `exaggerated`: the light sees the slopes times z_factor rather than the
/// ground's own normal.
template <bool exaggerated>
TERRAIN_SIMD_INLINE void colour_row_kernel(const ColourRow& row, std::uint8_t* __restrict red,
                                           std::uint8_t* __restrict green,
                                           std::uint8_t* __restrict blue) {
  const float polar = std::abs(row.polar);
  // South of the equator the slopes that face the pole, and keep their snow, face south.
  const std::uint32_t southern = simd::mask_of(row.polar < 0.0f);
  const std::uint32_t has_relief = simd::mask_of(row.width > 0.0f);
  const std::uint32_t has_shores = simd::mask_of(row.shore_band > 0.0f);
  for (int i = 0; i < row.count; ++i) {
    const float ground = row.ground[i];
    const float east = row.slope_east[i], north = row.slope_north[i];
    // NaN (no water near) compares false both ways: neither under water nor on a shore.
    const float surface = row.surface[i];
    MaterialInput input;
    input.water = surface > ground;
    input.shore =
        simd::select(simd::mask_of(ground >= surface) & has_shores,
                     1.0f - material_model::ramp(ground - surface, 0.0f, row.shore_band), 0.0f);
    input.height = simd::select(has_relief, (ground - row.lo) / row.width, 0.5f);
    const float facing = material_model::northness(east, north);
    input.northness = simd::select(southern, -facing, facing);
    input.polar = polar;
    // The slope of the ground itself; the light sees it exaggerated by z_factor.
    const Vec3 normal = normalise({-east, -north, 1.0f});
    input.slope = std::sqrt(1.0f - material_model::at_most_one(normal.z * normal.z));
    Vec3 lit = normal;
    if constexpr (exaggerated) {
      lit = normalise({-row.z_factor * east, -row.z_factor * north, 1.0f});
    }
    const std::uint32_t water = simd::mask_of(input.water);
    lit = {simd::select(water, 0.0f, lit.x), simd::select(water, 0.0f, lit.y),
           simd::select(water, 1.0f, lit.z)};
    const Rgb albedo = material_model::albedo(input, row.material);
    const float light = material_model::sun_light(lit, row.sun);
    red[i] = material_model::colour_byte(albedo.r * light);
    green[i] = material_model::colour_byte(albedo.g * light);
    blue[i] = material_model::colour_byte(albedo.b * light);
  }
}

TERRAIN_SIMD_CLONES void colour_row(const ColourRow& row, std::uint8_t* __restrict red,
                                    std::uint8_t* __restrict green, std::uint8_t* __restrict blue) {
  if (row.z_factor == 1.0f) {
    colour_row_kernel<false>(row, red, green, blue);
  } else {
    colour_row_kernel<true>(row, red, green, blue);
  }
}

}  // namespace

Result<std::vector<std::uint8_t>> color_pixels(const HeightTile& tile,
                                               const ColorTileInputs& inputs) {
  return guarded("cannot colour the tile", [&]() -> Result<Bytes> {
    if (Status ok = check_inputs(tile, inputs); !ok) return ok.error();
    const auto [east, north, up] = towards_light(inputs.light);
    const PackedMaterial material = pack_material(inputs.material);
    ColourRow row;
    row.count = tile.width;
    row.lo = inputs.relief.lo;
    row.width = inputs.relief.width();
    row.shore_band = inputs.shore_band;
    row.z_factor = static_cast<float>(inputs.light.z_factor);
    row.sun = {static_cast<float>(east), static_cast<float>(north), static_cast<float>(up)};
    row.material = material.data();
    const auto row_length = static_cast<std::size_t>(tile.width);
    const std::vector<float> no_water(inputs.water_surface.empty() ? row_length : 0, kNoWater);
    std::vector<std::uint8_t> channels(3 * row_length);
    Bytes rgb(sample_count(tile) * 3);
    for (int j = 0; j < tile.height; ++j) {
      const std::size_t start = static_cast<std::size_t>(j) * row_length;
      row.ground = tile.elevation.data() + start;
      row.slope_east = tile.slope_east.data() + start;
      row.slope_north = tile.slope_north.data() + start;
      row.surface =
          inputs.water_surface.empty() ? no_water.data() : inputs.water_surface.data() + start;
      row.polar = inputs.polar.empty() ? 0.0f : inputs.polar[static_cast<std::size_t>(j)];
      colour_row(row, channels.data(), channels.data() + row_length,
                 channels.data() + 2 * row_length);
      for (std::size_t i = 0; i < row_length; ++i) {
        rgb[3 * (start + i)] = channels[i];
        rgb[3 * (start + i) + 1] = channels[row_length + i];
        rgb[3 * (start + i) + 2] = channels[2 * row_length + i];
      }
    }
    return rgb;
  });
}

Result<std::vector<std::uint8_t>> encode_color(const HeightTile& tile,
                                               const ColorTileInputs& inputs, ColorCodec codec) {
  Result<Bytes> rgb = color_pixels(tile, inputs);
  if (!rgb) return rgb.error();
  return codec == ColorCodec::png
             ? encode_png_rgb8(tile.width, tile.height, rgb->data(), PngKind::shaded)
             : encode_jpeg_rgb8(tile.width, tile.height, rgb->data(), kColorJpegQuality);
}

}  // namespace terrain
