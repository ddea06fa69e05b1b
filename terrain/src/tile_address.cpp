// Tile addresses and sample positions of the three schemes (no scene involved).
#include <cassert>
#include <cmath>
#include <numbers>
#include <string>

#include "terrain/tile.hpp"

namespace terrain {

std::string_view scheme_name(TileScheme scheme) {
  switch (scheme) {
    case TileScheme::local:
      return "local";
    case TileScheme::webmercator:
      return "webmercator";
    case TileScheme::geographic:
      return "geographic";
  }
  assert(false && "unknown scheme");
  return "local";
}

Result<TileScheme> parse_scheme(std::string_view name) {
  for (TileScheme s : {TileScheme::local, TileScheme::webmercator, TileScheme::geographic}) {
    if (scheme_name(s) == name) return s;
  }
  return Error{"unknown tiling scheme '" + std::string(name) +
                   "' (expected local, webmercator or geographic)",
               "/scheme"};
}

int max_zoom(TileScheme scheme) {
  return scheme == TileScheme::geographic ? 23 : 24;
}

std::int64_t columns_at(TileScheme scheme, int z) {
  assert(z >= 0 && z <= max_zoom(scheme));
  return (scheme == TileScheme::geographic ? std::int64_t{2} : std::int64_t{1}) << z;
}

std::int64_t rows_at([[maybe_unused]] TileScheme scheme, int z) {
  assert(z >= 0 && z <= max_zoom(scheme));
  return std::int64_t{1} << z;
}

Status validate_address(TileScheme scheme, const TileAddress& a) {
  const std::string name(scheme_name(scheme));
  if (a.z < 0 || a.z > max_zoom(scheme)) {
    return Error{"zoom " + std::to_string(a.z) + " is outside 0.." +
                     std::to_string(max_zoom(scheme)) + " for the " + name + " scheme",
                 "/z"};
  }
  const std::int64_t columns = columns_at(scheme, a.z), rows = rows_at(scheme, a.z);
  if (a.x < 0 || a.x >= columns) {
    return Error{"column " + std::to_string(a.x) + " is outside 0.." + std::to_string(columns - 1) +
                     " at zoom " + std::to_string(a.z),
                 "/x"};
  }
  if (a.y < 0 || a.y >= rows) {
    return Error{"row " + std::to_string(a.y) + " is outside 0.." + std::to_string(rows - 1) +
                     " at zoom " + std::to_string(a.z),
                 "/y"};
  }
  return Ok{};
}

TileBounds tile_footprint(TileScheme scheme, const TileBounds& world, const TileAddress& a) {
  const double w = (world.east - world.west) / static_cast<double>(columns_at(scheme, a.z));
  const double h = (world.north - world.south) / static_cast<double>(rows_at(scheme, a.z));
  const auto x = static_cast<double>(a.x);
  const auto from_north =
      static_cast<double>(scheme == TileScheme::geographic ? rows_at(scheme, a.z) - 1 - a.y : a.y);
  return {world.west + x * w, world.north - (from_north + 1) * h, world.west + (x + 1) * w,
          world.north - from_north * h};
}

double web_mercator_longitude(double x) {
  return x / kWebMercatorRadius * (180.0 / std::numbers::pi);
}

double web_mercator_latitude(double y) {
  return std::atan(std::sinh(y / kWebMercatorRadius)) * (180.0 / std::numbers::pi);
}

namespace {

// Sample positions come from global sample indices (tile index · N + sample index) times one
// step per zoom level, so two tiles compute a shared position with the same operations on the
// same numbers and get the same bits.
double sample_offset(const HeightTile& tile) {
  return tile.layout == SampleLayout::cell_centres ? 0.5 - tile.border : 0.0;
}

// Rows counted from the north edge of the world, whatever way the scheme numbers its rows.
std::int64_t rows_from_north(const HeightTile& tile) {
  return tile.scheme == TileScheme::geographic
             ? rows_at(tile.scheme, tile.address.z) - 1 - tile.address.y
             : tile.address.y;
}

}  // namespace

double HeightTile::sample_crs_x(int column) const {
  const double step =
      (world.east - world.west) / static_cast<double>(columns_at(scheme, address.z) * cells);
  const double global = static_cast<double>(address.x * cells) + column + sample_offset(*this);
  return world.west + global * step;
}

double HeightTile::sample_crs_y(int row) const {
  const double step =
      (world.north - world.south) / static_cast<double>(rows_at(scheme, address.z) * cells);
  const double global =
      static_cast<double>(rows_from_north(*this) * cells) + row + sample_offset(*this);
  return world.north - global * step;
}

}  // namespace terrain
