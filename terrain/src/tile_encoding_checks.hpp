// The checks the tile encoders (tile_image.cpp: PNGs, geotiff.cpp: GeoTIFF, tile_color.cpp:
// colour imagery) apply to a HeightTile before encoding, and the helpers they share. Internal to
// the terrain library.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "terrain/result.hpp"
#include "terrain/scene.hpp"
#include "terrain/tile.hpp"
#include "terrain/tile_image.hpp"

namespace terrain::tile_encoding {

using Bytes = std::vector<std::uint8_t>;

// Larger tiles are refused before anything is allocated; image_io reads no more than this either.
inline constexpr int kMaxCells = 8192;

inline std::string text(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

// ---------------------------------------------------------------------------------------------
// Validation

inline Status check_grid(const HeightTile& tile) {
  if (tile.cells < 1 || tile.cells > kMaxCells) {
    return Error{"the tile must have 1.." + std::to_string(kMaxCells) + " cells per side, not " +
                     std::to_string(tile.cells),
                 "/cells"};
  }
  if (tile.border != 0 && tile.border != 1) {
    return Error{"border must be 0 or 1, not " + std::to_string(tile.border), "/border"};
  }
  if (tile.layout == SampleLayout::cell_corners && tile.border != 0) {
    return Error{"a cell_corners tile has no border", "/border"};
  }
  const int expected =
      tile.layout == SampleLayout::cell_corners ? tile.cells + 1 : tile.cells + 2 * tile.border;
  if (tile.width != expected) {
    return Error{"width is " + std::to_string(tile.width) + " but " + std::to_string(tile.cells) +
                     " cells with this layout and border make " + std::to_string(expected) +
                     " samples per row",
                 "/width"};
  }
  if (tile.height != tile.width) {
    return Error{"height is " + std::to_string(tile.height) + " but tiles are square (width " +
                     std::to_string(tile.width) + ")",
                 "/height"};
  }
  return Ok{};
}

inline std::size_t sample_count(const HeightTile& tile) {
  return static_cast<std::size_t>(tile.width) * static_cast<std::size_t>(tile.height);
}

// One value per sample, all finite: quantisation and shading are undefined for NaN, and a
// non-finite height is a bug upstream that an image must not hide.
inline Status check_samples(const HeightTile& tile, const std::vector<float>& values,
                            const std::string& name) {
  if (values.size() != sample_count(tile)) {
    return Error{name + " holds " + std::to_string(values.size()) + " samples but the " +
                     std::to_string(tile.width) + "x" + std::to_string(tile.height) +
                     " grid needs " + std::to_string(sample_count(tile)),
                 "/" + name};
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      const auto width = static_cast<std::size_t>(tile.width);
      return Error{name + " at column " + std::to_string(i % width) + ", row " +
                       std::to_string(i / width) + " is " +
                       (std::isnan(values[i]) ? "NaN" : "infinite"),
                   "/" + name + "/" + std::to_string(i)};
    }
  }
  return Ok{};
}

inline Status check_heights(const HeightTile& tile) {
  if (Status ok = check_grid(tile); !ok) return ok;
  return check_samples(tile, tile.elevation, "elevation");
}

inline Status check_slopes(const HeightTile& tile) {
  if (Status ok = check_grid(tile); !ok) return ok;
  if (Status ok = check_samples(tile, tile.slope_east, "slope_east"); !ok) return ok;
  return check_samples(tile, tile.slope_north, "slope_north");
}

// Everything a tile needs beyond its grid to say where it is.
inline Status check_placement(const HeightTile& tile) {
  if (Status ok = validate_address(tile.scheme, tile.address); !ok) {
    return Error{ok.error().message, "/address" + ok.error().pointer};
  }
  const TileBounds& w = tile.world;
  if (!std::isfinite(w.west) || !std::isfinite(w.east) || !std::isfinite(w.south) ||
      !std::isfinite(w.north) || !(w.east > w.west) || !(w.north > w.south)) {
    return Error{"the world bounds must be finite with east > west and north > south", "/world"};
  }
  return Ok{};
}

inline Status check_georeference(const Georeference& g) {
  if (!std::isfinite(g.latitude) || g.latitude < -90.0 || g.latitude > 90.0) {
    return Error{"latitude must be in [-90, 90], not " + text(g.latitude),
                 "/georeference/latitude"};
  }
  if (!std::isfinite(g.longitude) || g.longitude < -180.0 || g.longitude > 180.0) {
    return Error{"longitude must be in [-180, 180], not " + text(g.longitude),
                 "/georeference/longitude"};
  }
  if (!std::isfinite(g.heading)) {
    return Error{"heading must be finite", "/georeference/heading"};
  }
  return Ok{};
}

// The encoders' own allocations are the only thing left that can throw.
template <class F>
Result<Bytes> guarded(const char* what, F&& body) {
  try {
    return body();
  } catch (const std::exception& e) {
    return Error{std::string(what) + ": " + e.what(), ""};
  }
}

// Cosine and sine of an angle in degrees, exact at multiples of 90° so that axis-aligned
// headings and overhead light give exact zeros and ones.
inline std::pair<double, double> cos_sin_degrees(double degrees) {
  double reduced = std::fmod(degrees, 360.0);
  if (reduced < 0.0) reduced += 360.0;
  if (reduced == 0.0) return {1.0, 0.0};
  if (reduced == 90.0) return {0.0, 1.0};
  if (reduced == 180.0) return {-1.0, 0.0};
  if (reduced == 270.0) return {0.0, -1.0};
  const double radians = reduced * (std::numbers::pi / 180.0);
  return {std::cos(radians), std::sin(radians)};
}

// A hillshade's light: its pointers under "/hillshade".
inline Status check_light(const HillshadeOptions& light) {
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
  return Ok{};
}

// The unit vector towards a hillshade's light in (east, north, up): azimuth clockwise from
// north in the east-north plane, raised by the altitude.
inline std::array<double, 3> towards_light(const HillshadeOptions& light) {
  const auto [cos_azimuth, sin_azimuth] = cos_sin_degrees(light.azimuth_deg);
  const auto [cos_altitude, sin_altitude] = cos_sin_degrees(light.altitude_deg);
  return {sin_azimuth * cos_altitude, cos_azimuth * cos_altitude, sin_altitude};
}

// ---------------------------------------------------------------------------------------------

}  // namespace terrain::tile_encoding
