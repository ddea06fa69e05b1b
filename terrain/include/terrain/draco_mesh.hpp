// Draco (.drc) and glTF 2.0 binary (.glb, KHR_draco_mesh_compression) encodings of a tile mesh.
// Positions are snapped to one lattice of multiples of a power-of-two quantum shared by every
// tile of a scene, and Draco's quantisation grid is that lattice, so neighbouring tiles decode
// their shared edge vertices to the same world positions, bit for bit (docs/meshes-gltf-draco.md).
#pragma once

#include <cstdint>
#include <vector>

#include "terrain/mesh.hpp"
#include "terrain/result.hpp"
#include "terrain/tile.hpp"

namespace terrain {

struct DracoOptions {
  /// Q: metres between lattice points, a power of two in [2^-16, 2^16], the same for every tile
  /// of a scene (see position_quantum_for). Vertices move by at most Q/2.
  double position_quantum = 1.0 / 128.0;
  /// Bits per octahedral coordinate of the normals, 2..16 (10: error below 0.2°).
  int normal_bits = 10;
  /// Depth of the skirt below the boundary vertices in metres; 0 for none, else at least Q.
  /// Shortened where it would take the tile's positions past 2^23 − 1 quanta.
  double skirt_height = 0.0;
  /// Draco's compression level, 0 (fastest) … 10 (smallest): speed options 10 − level.
  int compression_level = 7;
};

/// The most quanta a tile's positions may span along one axis: from 2^23 on, the float Draco
/// quantises in has no bit left for its half-step rounding.
inline constexpr std::int64_t kMaxPositionQuanta = (std::int64_t{1} << 23) - 1;

/// The position quantum for a scene: the largest power of two not above one centimetre (2^-7 m),
/// doubled until the larger of the scene's horizontal extent and elevation range (metres, skirts
/// included) spans at most 2^22 quanta, half the 2^23 a tile may span, which leaves room for
/// skirts and snapping. Non-finite or negative spans count as 0; the result is at most 2^16.
double position_quantum_for(double extent_metres, double elevation_range);

/// A Draco mesh (edgebreaker) of the tile with POSITION and NORMAL, in glTF axes (x east, y up,
/// z south) relative to the tile origin, a lattice point stored as the geometry metadata entry
/// "translation" (3 doubles; world = translation + position) next to "position_quantum".
/// Identical input gives identical bytes. Bad input is refused with a pointer into the tile
/// ("/tile/…"), the mesh ("/mesh/…") or the options ("/options/…").
Result<std::vector<std::uint8_t>> encode_draco(const HeightTile& tile, const TileMesh& mesh,
                                               const DracoOptions& options);

/// A glTF 2.0 binary asset requiring KHR_draco_mesh_compression: one scene, one node whose
/// translation is the tile origin, one triangle primitive with POSITION (exact min/max) and
/// NORMAL, the Draco mesh (without metadata) in the BIN chunk. Same axes, checks and
/// determinism as encode_draco.
Result<std::vector<std::uint8_t>> encode_glb(const HeightTile& tile, const TileMesh& mesh,
                                             const DracoOptions& options);

}  // namespace terrain
