// Height tiles built by hand from one smooth function of global scene position, so that
// neighbouring tiles agree bit for bit on their shared edge samples, as the tiler's do.
#pragma once

#include <cmath>
#include <cstdint>

#include "terrain/tile.hpp"

namespace terrain::test_tiles {

/// A local-scheme square away from the origin and not a power of two wide, so that sample
/// positions are not lattice points of any position quantum.
inline TileBounds synthetic_world() {
  return {-2047.37, -1500.11, -2047.37 + 3000.5, -1500.11 + 3000.5};
}

/// Hills with a tilt; exact slopes.
inline double synthetic_height(double x, double y) {
  return 420.0 + 150.0 * std::sin(x / 900.0) * std::cos(y / 650.0) + 0.013 * x - 0.007 * y;
}
inline double synthetic_slope_east(double x, double y) {
  return 150.0 / 900.0 * std::cos(x / 900.0) * std::cos(y / 650.0) + 0.013;
}
inline double synthetic_slope_north(double x, double y) {
  return -150.0 / 650.0 * std::sin(x / 900.0) * std::sin(y / 650.0) - 0.007;
}

/// The cell_corners tile (z, x, y) of `cells` cells per side over synthetic_world().
inline HeightTile synthetic_tile(int z, std::int64_t x, std::int64_t y, int cells) {
  HeightTile t;
  t.scheme = TileScheme::local;
  t.address = {z, x, y};
  t.layout = SampleLayout::cell_corners;
  t.cells = cells;
  t.width = t.height = cells + 1;
  t.world = synthetic_world();
  t.bounds = {t.sample_crs_x(0), t.sample_crs_y(cells), t.sample_crs_x(cells), t.sample_crs_y(0)};
  t.ground_spacing =
      (t.world.east - t.world.west) / static_cast<double>((std::int64_t{1} << z) * cells);
  for (int row = 0; row < t.height; ++row) {
    for (int column = 0; column < t.width; ++column) {
      const double sx = t.sample_crs_x(column), sy = t.sample_crs_y(row);
      t.scene_x.push_back(sx);
      t.scene_y.push_back(sy);
      t.elevation.push_back(static_cast<float>(synthetic_height(sx, sy)));
      t.slope_east.push_back(static_cast<float>(synthetic_slope_east(sx, sy)));
      t.slope_north.push_back(static_cast<float>(synthetic_slope_north(sx, sy)));
    }
  }
  return t;
}

}  // namespace terrain::test_tiles
