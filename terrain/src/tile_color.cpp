#include "terrain/tile_color.hpp"

#include <algorithm>
#include <cmath>
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
  if (!inputs.water.empty() && inputs.water.size() != sample_count(tile)) {
    return Error{"water has " + std::to_string(inputs.water.size()) + " flags for " +
                     std::to_string(sample_count(tile)) + " samples",
                 "/water"};
  }
  const HillshadeOptions& light = inputs.light;
  if (!std::isfinite(light.azimuth_deg)) {
    return Error{"the light azimuth must be finite", "/hillshade/azimuth_deg"};
  }
  if (!(light.altitude_deg >= 0.0 && light.altitude_deg <= 90.0)) {
    return Error{"the light altitude must be in [0, 90] degrees, not " + text(light.altitude_deg),
                 "/hillshade/altitude_deg"};
  }
  if (!std::isfinite(light.z_factor) || !(light.z_factor > 0.0)) {
    return Error{"z_factor must be finite and positive, not " + text(light.z_factor),
                 "/hillshade/z_factor"};
  }
  if (Status ok = check_heights(tile); !ok) return ok.error();
  return check_slopes(tile);
}

Vec3 normalise(Vec3 v) {
  const float length = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  return {v.x / length, v.y / length, v.z / length};
}

}  // namespace

Result<std::vector<std::uint8_t>> color_pixels(const HeightTile& tile,
                                               const ColorTileInputs& inputs) {
  return guarded("cannot colour the tile", [&]() -> Result<Bytes> {
    if (Status ok = check_inputs(tile, inputs); !ok) return ok.error();
    // Towards the sun, in (east, north, up): azimuth clockwise from north, raised by the altitude.
    const auto [cos_azimuth, sin_azimuth] = cos_sin_degrees(inputs.light.azimuth_deg);
    const auto [cos_altitude, sin_altitude] = cos_sin_degrees(inputs.light.altitude_deg);
    const Vec3 sun{static_cast<float>(sin_azimuth * cos_altitude),
                   static_cast<float>(cos_azimuth * cos_altitude),
                   static_cast<float>(sin_altitude)};
    const float z_factor = static_cast<float>(inputs.light.z_factor);
    const float lo = inputs.relief.lo;
    const float width = inputs.relief.width();
    Bytes rgb(sample_count(tile) * 3);
    for (std::size_t i = 0; i < tile.elevation.size(); ++i) {
      MaterialInput input;
      input.water = !inputs.water.empty() && inputs.water[i] != 0;
      input.height = width > 0.0f ? (tile.elevation[i] - lo) / width : 0.5f;
      // The slope of the ground itself; the light sees it exaggerated by z_factor.
      const Vec3 ground = normalise({-tile.slope_east[i], -tile.slope_north[i], 1.0f});
      input.slope = std::sqrt(1.0f - std::min(1.0f, ground.z * ground.z));
      const Vec3 lit =
          input.water
              ? Vec3{0.0f, 0.0f, 1.0f}
              : normalise({-z_factor * tile.slope_east[i], -z_factor * tile.slope_north[i], 1.0f});
      const Rgb albedo = material_albedo(input);
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
             ? encode_png_rgb8(tile.width, tile.height, rgb->data())
             : encode_jpeg_rgb8(tile.width, tile.height, rgb->data(), kColorJpegQuality);
}

}  // namespace terrain
