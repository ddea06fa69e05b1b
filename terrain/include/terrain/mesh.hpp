// Triangulations of a tile's (2^k + 1)² corner grid (SampleLayout::cell_corners): the regular
// grid, and an adaptive, error-bounded right-triangulated irregular network (RTIN). Vertices are
// grid indices, so every encoder (quantized-mesh, glTF, Draco) maps them to its own coordinates.
#pragma once

#include <cstdint>
#include <vector>

#include "terrain/tile.hpp"

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

/// An adaptive right-triangulated irregular network (RTIN, as in Mapbox's Martini) over an n×n
/// grid of heights (row 0 north, index row·n + column), n = 2^k + 1 (asserted), max_error ≥ 0
/// and finite (asserted), heights finite.
///
/// Guarantees:
///  - every grid sample lies within max_error of the mesh surface (the error of a triangle is
///    measured against every sample it covers, not only at its hypotenuse midpoint as Martini
///    does, so the bound is exact rather than an estimate);
///  - the mesh is conforming (no T-junctions): a triangle's error is stored at its hypotenuse
///    midpoint, shared with its neighbour across the hypotenuse, and propagated bottom-up so
///    every midpoint's error is at least its children's; both sides of an edge split together;
///  - max_error 0 reproduces the full grid surface.
///
/// Deliberate difference from Martini: every sample on the tile's boundary is a vertex (the
/// boundary edges are forced to full grid resolution) and only the interior adapts. Neighbouring
/// tiles share their edge samples bit for bit, so they get identical edge vertices: no cracks,
/// no skirts needed between tiles of one zoom level, and matching edge normals. The cost is a
/// band of small triangles along the boundary, graded towards the interior: a flat 257² tile
/// needs 3 960 triangles instead of 2 (about 15·(n−1); the full grid has 131 072); a hilly
/// 257² tile needs 9 356 instead of 6 386 at 1 m and 4 602 instead of 988 at 5 m. The overhead
/// is a fixed O(n) band, so it matters most for coarse tolerances.
///
/// Vertices are listed in increasing grid index; triangles in depth-first order of the RTIN
/// hierarchy; both are deterministic functions of the heights and max_error.
TileMesh triangulate_rtin(const float* heights, int grid_size, float max_error);

/// triangulate_rtin for a client that draws the mesh on the globe, as CesiumJS draws
/// quantized-mesh: each vertex at its height above the WGS84 ellipsoid in Earth-centred
/// coordinates, flat triangles between. `degrees` gives the longitudes of the first and last
/// columns and the latitudes of the first (north) and last rows; samples are evenly spaced.
///
/// A triangle's error is measured at every sample it covers along the sample's ellipsoid normal:
/// the larger of the distance between the sample's point and the drawn triangle, and how far the
/// drawn triangle lies under the heights interpolated between its corners (the chordal sag of
/// the flat triangle under the curved surface). So every sample lies within max_error of the
/// drawn mesh, and no triangle cuts under its own curved surface by more than max_error at a
/// sample. Triangles degenerate in space (two corners at a pole) split. Same hierarchy,
/// full-resolution boundary, conformity and order as triangulate_rtin.
TileMesh triangulate_rtin_on_ellipsoid(const float* heights, int grid_size,
                                       const TileBounds& degrees, float max_error);

}  // namespace terrain
