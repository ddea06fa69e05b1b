#include <cassert>

#include "terrain/mesh.hpp"

namespace terrain {

TileMesh triangulate_grid(int grid_size) {
  assert(grid_size >= 2);
  TileMesh mesh;
  mesh.grid_size = grid_size;
  const auto n = static_cast<std::uint32_t>(grid_size);
  mesh.vertices.resize(static_cast<std::size_t>(n) * n);
  for (std::uint32_t i = 0; i < n * n; ++i) mesh.vertices[i] = i;
  mesh.triangles.reserve(static_cast<std::size_t>(n - 1) * (n - 1) * 6);
  for (std::uint32_t row = 0; row + 1 < n; ++row) {
    for (std::uint32_t col = 0; col + 1 < n; ++col) {
      // Row 0 is north, so "down" in the grid is south: nw, sw, se is counter-clockwise.
      const std::uint32_t nw = row * n + col, ne = nw + 1, sw = nw + n, se = sw + 1;
      mesh.triangles.insert(mesh.triangles.end(), {nw, sw, se, nw, se, ne});
    }
  }
  return mesh;
}

}  // namespace terrain
