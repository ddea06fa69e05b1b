// Triangulations of a tile's (2^k + 1)² corner grid (SampleLayout::cell_corners): the regular
// grid, and an adaptive, error-bounded right-triangulated irregular network (RTIN). Vertices are
// grid indices, so every encoder (quantized-mesh, glTF, Draco) maps them to its own coordinates.
#pragma once

#include <cstdint>
#include <vector>

namespace terrain {

/// A triangulation of an n×n grid of samples (row 0 north, column 0 west).
struct TileMesh {
  int grid_size = 0;                     ///< n = 2^k + 1
  std::vector<std::uint32_t> vertices;   ///< grid indices (row·n + column), each used once
  std::vector<std::uint32_t> triangles;  ///< 3 indices into `vertices` per triangle,
                                         ///< counter-clockwise seen from above (east, north, up)
};

/// Every grid cell as two triangles; vertices in grid order.
TileMesh triangulate_grid(int grid_size);

}  // namespace terrain
