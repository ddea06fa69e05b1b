// Tile meshes resolved to coordinates: the positions, normals and triangles every mesh encoder
// (glTF/Draco, quantized-mesh, …) starts from, and the skirts that hide the cracks between
// neighbouring tiles of different levels of detail.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "terrain/mesh.hpp"
#include "terrain/result.hpp"
#include "terrain/tile.hpp"

namespace terrain {

/// A tile mesh in the scene frame: x east, y north (the scene plane, metres), z up (elevation,
/// metres). Encoders map these axes to their own (glTF: x, z, −y).
struct MeshGeometry {
  std::vector<std::array<double, 3>> positions;
  std::vector<std::array<float, 3>> normals;  ///< unit length, same axes as positions
  std::vector<std::uint32_t> triangles;       ///< 3 vertex indices each, CCW seen from above
  std::vector<std::uint32_t> samples;  ///< grid index (row·n + column) each vertex came from
  std::uint32_t surface_vertices = 0;  ///< vertices [0, this) are the surface; the rest skirts
};

/// The unit normal of a surface with the given slopes: normalize(−∂h/∂east, −∂h/∂north, 1),
/// in (east, north, up) axes.
std::array<float, 3> normal_from_slopes(float slope_east, float slope_north);

/// Resolves every mesh vertex to its sample's scene position, elevation and normal, in the mesh's
/// vertex order. Refuses (error pointers "/tile/…", "/mesh/…") a tile that is not a cell_corners
/// grid matching the mesh, arrays of the wrong size, out-of-range or repeated indices, degenerate
/// triangles, an empty mesh and non-finite samples.
Result<MeshGeometry> mesh_geometry(const HeightTile& tile, const TileMesh& mesh);

/// Appends a skirt: every boundary vertex (on an edge used by one triangle only) duplicated
/// `skirt_height` metres lower with its normal, and two wall triangles per boundary edge joining
/// it to the duplicates, facing outward. Deterministic: duplicates follow the order in which the
/// triangles first reach them. 0 adds nothing. Refuses a negative or non-finite height, and
/// (whatever the height) triangles that are not consistently oriented: an edge used twice in the
/// same direction.
Status add_skirts(MeshGeometry& geometry, double skirt_height);

}  // namespace terrain
