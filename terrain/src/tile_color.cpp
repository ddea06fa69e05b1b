#include "terrain/tile_color.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "terrain/image_io.hpp"
#include "terrain/material.hpp"
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

}  // namespace

Result<std::vector<std::uint8_t>> color_pixels(const HeightTile& tile,
                                               const ColorTileInputs& inputs) {
  return guarded("cannot colour the tile", [&]() -> Result<Bytes> {
    if (Status ok = check_inputs(tile, inputs); !ok) return ok.error();
    const auto [east, north, up] = towards_light(inputs.light);
    const Vec3 sun{static_cast<float>(east), static_cast<float>(north), static_cast<float>(up)};
    const float z_factor = static_cast<float>(inputs.light.z_factor);
    const float lo = inputs.relief.lo;
    const float width = inputs.relief.width();
    const PackedMaterial material = pack_material(inputs.material);
    const std::size_t row_length = static_cast<std::size_t>(tile.width);
    Bytes rgb(sample_count(tile) * 3);
    for (std::size_t i = 0; i < tile.elevation.size(); ++i) {
      const float ground = tile.elevation[i];
      // NaN (no water near) compares false both ways: neither under water nor on a shore.
      const float surface = inputs.water_surface.empty() ? kNoWater : inputs.water_surface[i];
      MaterialInput input;
      input.water = surface > ground;
      input.shore = ground >= surface && inputs.shore_band > 0.0f
                        ? 1.0f - ramp(ground - surface, 0.0f, inputs.shore_band)
                        : 0.0f;
      input.height = width > 0.0f ? (ground - lo) / width : 0.5f;
      input.northness = northness(tile.slope_east[i], tile.slope_north[i]);
      if (!inputs.polar.empty()) {
        // South of the equator the slopes that face the pole, and keep their snow, face south.
        const float polar = inputs.polar[i / row_length];
        input.polar = std::abs(polar);
        if (polar < 0.0f) input.northness = -input.northness;
      }
      // The slope of the ground itself; the light sees it exaggerated by z_factor.
      const Vec3 normal = normalise({-tile.slope_east[i], -tile.slope_north[i], 1.0f});
      input.slope = std::sqrt(1.0f - std::min(1.0f, normal.z * normal.z));
      // Without exaggeration the light sees the ground's own normal (the same numbers).
      const Vec3 lit =
          input.water ? Vec3{0.0f, 0.0f, 1.0f}
          : z_factor == 1.0f
              ? normal
              : normalise({-z_factor * tile.slope_east[i], -z_factor * tile.slope_north[i], 1.0f});
      const Rgb albedo = material_albedo(input, material);
      const float light = sun_light(lit, sun);
      rgb[3 * i] = colour_byte(albedo.r * light);
      rgb[3 * i + 1] = colour_byte(albedo.g * light);
      rgb[3 * i + 2] = colour_byte(albedo.b * light);
    }
    return rgb;
  });
}

Result<std::vector<std::uint8_t>> encode_color(const HeightTile& tile,
                                               const ColorTileInputs& inputs, ColorCodec codec) {
  Result<Bytes> rgb = color_pixels(tile, inputs);
  if (!rgb) return rgb.error();
  return codec == ColorCodec::png
             ? encode_png_rgb8(tile.width, tile.height, rgb->data(), PngFilter::up)
             : encode_jpeg_rgb8(tile.width, tile.height, rgb->data(), kColorJpegQuality);
}

}  // namespace terrain
