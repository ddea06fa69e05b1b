// How far a quantized-mesh tile, drawn the way CesiumJS draws it, dips below the surface it
// stands for. Written from Cesium's behaviour, independently of the encoder and of the
// triangulation: vertices go to ECEF on the WGS84 ellipsoid (longitude and latitude linear in u
// and v over the tile's rectangle, the decoded height along the ellipsoid normal) and the
// triangles between them are flat. Shared by the terrain and planet tests.
#pragma once

#include <GeographicLib/Geocentric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <vector>

#include "terrain/quantized_mesh.hpp"
#include "terrain/tile.hpp"

namespace terrain::testing {

/// CesiumTerrainProvider.getLevelMaximumGeometricError(level) for a layer.json with
/// "projection": "EPSG:4326": levelZeroMaximumGeometricError =
/// TerrainProvider.getEstimatedLevelZeroGeometricErrorForAHeightmap(WGS84, 65, 2) =
/// maximumRadius·2π·heightmapTerrainQuality (0.25) / (65·2), halved per level.
inline double cesium_level_maximum_geometric_error(int level) {
  constexpr double kMaximumRadius = 6378137.0;  // Ellipsoid.WGS84.maximumRadius
  return kMaximumRadius * 2.0 * std::numbers::pi * 0.25 / (65.0 * 2.0) / std::ldexp(1.0, level);
}

/// The largest depth (metres, ≥ 0) of the drawn triangles under the surface, over a dense set of
/// points inside every triangle (`steps` subdivisions of each side). A point of a drawn triangle
/// is converted back to geodetic longitude, latitude and height; the surface there is the
/// ellipsoid plus the triangle's own height interpolated linearly in longitude and latitude —
/// what the tile would show on a curved globe — so the figure is the curvature the flat
/// triangles lose, not the triangulation's height error.
inline double max_dip_below_surface(const QuantizedMesh& mesh, const TileBounds& bounds,
                                    int steps = 12) {
  const GeographicLib::Geocentric& earth = GeographicLib::Geocentric::WGS84();
  const std::size_t count = mesh.u.size();
  std::vector<double> lon(count), lat(count), height(count);
  std::vector<std::array<double, 3>> ecef(count);
  for (std::size_t i = 0; i < count; ++i) {
    lon[i] = bounds.west + (bounds.east - bounds.west) * mesh.u[i] / 32767.0;
    lat[i] = bounds.south + (bounds.north - bounds.south) * mesh.v[i] / 32767.0;
    height[i] = mesh.height_metres(i);
    earth.Forward(lat[i], lon[i], height[i], ecef[i][0], ecef[i][1], ecef[i][2]);
  }
  double worst = 0.0;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const std::size_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
    // Barycentric coordinates of a longitude/latitude in the triangle (a, b, c).
    const double det =
        (lon[b] - lon[a]) * (lat[c] - lat[a]) - (lon[c] - lon[a]) * (lat[b] - lat[a]);
    if (det == 0.0) continue;  // not a triangle of the tile's rectangle at all
    for (int i = 0; i <= steps; ++i) {
      for (int j = 0; i + j <= steps; ++j) {
        const double wb = double(i) / steps, wc = double(j) / steps, wa = 1.0 - wb - wc;
        double p[3];
        for (int k = 0; k < 3; ++k) p[k] = wa * ecef[a][k] + wb * ecef[b][k] + wc * ecef[c][k];
        double p_lat = 0.0, p_lon = 0.0, p_height = 0.0;
        earth.Reverse(p[0], p[1], p[2], p_lat, p_lon, p_height);
        // Longitudes of points at a pole are arbitrary: measure those points at the longitude
        // the tile would give them, which is any of its own.
        if (std::abs(p_lat) > 90.0 - 1e-9) p_lon = wa * lon[a] + wb * lon[b] + wc * lon[c];
        // Reverse gives longitudes in [−180°, 180°]: take the turn nearest the tile (a tile
        // ending at ±180° sees the far side of the antimeridian as its own).
        const double centre = 0.5 * (bounds.west + bounds.east);
        if (p_lon - centre > 180.0) p_lon -= 360.0;
        if (p_lon - centre < -180.0) p_lon += 360.0;
        const double sb =
            ((p_lon - lon[a]) * (lat[c] - lat[a]) - (lon[c] - lon[a]) * (p_lat - lat[a])) / det;
        const double sc =
            ((lon[b] - lon[a]) * (p_lat - lat[a]) - (p_lon - lon[a]) * (lat[b] - lat[a])) / det;
        const double surface =
            height[a] + sb * (height[b] - height[a]) + sc * (height[c] - height[a]);
        worst = std::max(worst, surface - p_height);
      }
    }
  }
  return worst;
}

/// The rectangle Cesium's GeographicTilingScheme gives tile (z, x, y), TMS, in degrees.
inline TileBounds geographic_tile_bounds(const TileAddress& a) {
  const double size = 180.0 / std::ldexp(1.0, a.z);
  return {-180.0 + static_cast<double>(a.x) * size, -90.0 + static_cast<double>(a.y) * size,
          -180.0 + static_cast<double>(a.x + 1) * size,
          -90.0 + static_cast<double>(a.y + 1) * size};
}

/// Tiles of zoom z to measure: every tile up to zoom 1; deeper, in the column east of the prime
/// meridian, the rows at both poles and both sides of the equator (where the tiles are widest in
/// metres), plus `extra`.
inline std::vector<TileAddress> curvature_probe_tiles(int z,
                                                      const std::vector<TileAddress>& extra = {}) {
  std::vector<TileAddress> tiles;
  const std::int64_t columns = std::int64_t{2} << z, rows = std::int64_t{1} << z;
  if (z <= 1) {
    for (std::int64_t y = 0; y < rows; ++y) {
      for (std::int64_t x = 0; x < columns; ++x) tiles.push_back({z, x, y});
    }
  } else {
    for (std::int64_t y : {std::int64_t{0}, rows / 2 - 1, rows / 2, rows - 1}) {
      tiles.push_back({z, columns / 2, y});
    }
  }
  for (const TileAddress& a : extra) {
    if (a.z == z) tiles.push_back(a);
  }
  return tiles;
}

}  // namespace terrain::testing
