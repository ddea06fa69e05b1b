// Cesium's quantized-mesh-1.0 terrain format (github.com/CesiumGS/quantized-mesh): an encoder
// from a geographic height tile and its triangulation, an independent decoder, and the
// layer.json a CesiumTerrainProvider reads. docs/quantized-mesh.md describes the layout we write.
//
// Edge-exact heights. A vertex height is stored as k ∈ [0, 32767] and decoded as
// m + (M − m)·k/32767 from the tile's own header minimum m and maximum M, so two neighbours with
// different height ranges would in general decode their shared edge vertices to different
// heights (cracks). We make the arithmetic exact instead: with a scene-wide edge quantum Q (a
// power of two in metres), edge vertices are rounded to multiples of Q; m = floor(min/Q)·Q; the
// tile's own quantum is q = Q/2^j for the largest j ≥ 0 (j ≤ 20, and m, M exact in float) with
// 32767·q ≥ max − m; M = m + 32767·q; interior vertices are rounded to multiples of q. Then
// (M − m)·k is exact, its division by 32767 gives k·q exactly, and adding m is exact: every
// vertex decodes to exactly what we rounded it to, and a shared edge vertex to the same multiple
// of Q in both tiles. Edge error ≤ Q/2, interior error ≤ q/2. (CesiumJS itself evaluates
// lerp(m, M, k/32767) = (1 − t)·m + t·M, which rounds; there the two sides of a shared edge agree
// to a few ulps, nanometres, instead of bit for bit.)
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/mesh.hpp"
#include "terrain/result.hpp"
#include "terrain/tile.hpp"

namespace terrain {

/// The smallest power of two Q (metres, at least 2^-10) with 32766·Q ≥ elevation_range: the
/// edge quantum for a scene whose heights span that range. One step less than 32767 leaves room
/// for rounding a tile's minimum down to a multiple of Q. With Q ≥ 2^-10, every header minimum
/// and maximum of heights within ±16 000 m is exact in float. Non-positive or NaN ranges give
/// the minimum, 2^-10.
double edge_quantum_for(double elevation_range);
/// The edge quantum for a scene whose heights lie within [lowest, highest]: that of its range,
/// doubled while a tile header (a float, m and M on multiples of Q next to heights that far from
/// zero) could not be exact: so every tile of every valid scene fits, 40 km up as much as at sea
/// level. Non-finite bounds give infinity, as above.
double edge_quantum_for(double lowest, double highest);

/// What to write besides the mandatory parts.
struct QuantizedMeshOptions {
  /// Q: a power of two in metres, the same for every tile of a scene (see edge_quantum_for).
  double edge_quantum = 1.0;
  /// Extension 1: oct-encoded per-vertex normals (ECEF), from the tile's slopes.
  bool normals = false;
  /// Extension 2: 1 byte (whole tile land 0 or water 255) or 256·256 bytes, rows north to south,
  /// each west to east (the first byte is the north-west corner).
  std::optional<std::vector<std::uint8_t>> water_mask;
  /// Extension 4: a JSON text, e.g. quantized_mesh_metadata_json(...).dump().
  std::optional<std::string> metadata;
};

/// A quantized-mesh-1.0 tile (uncompressed; the server gzips it) for `tile`, which must be a
/// geographic-scheme, cell_corners tile whose grid matches mesh.grid_size (≤ 32 768), with
/// finite heights (and slopes when normals are requested). Vertex positions: u = column/(n−1),
/// v = (n−1−row)/(n−1), both scaled to 0..32767 and rounded, over the tile's bounds (degrees).
/// Vertices are reordered by first use in the triangle list, as the index encoding requires.
/// Refuses (Error with a pointer such as "/layout", "/mesh/triangles/7",
/// "/options/edge_quantum") anything it cannot encode exactly as documented above.
Result<std::vector<std::uint8_t>> encode_quantized_mesh(const HeightTile& tile,
                                                        const TileMesh& mesh,
                                                        const QuantizedMeshOptions& options);

/// The fixed 88-byte header.
struct QuantizedMeshHeader {
  std::array<double, 3> center{};  ///< ECEF metres (we write the bounding sphere's centre)
  float minimum_height = 0.0f;
  float maximum_height = 0.0f;
  std::array<double, 3> bounding_sphere_center{};  ///< ECEF metres
  double bounding_sphere_radius = 0.0;
  /// In the ellipsoid-scaled frame (ECEF divided by the radii), as Cesium's EllipsoidalOccluder
  /// computes it: if this point is below the horizon, the whole tile is.
  std::array<double, 3> horizon_occlusion_point{};
};

/// A decoded tile: zig-zag, delta and high-water-mark encodings undone, all lengths and indices
/// checked.
struct QuantizedMesh {
  QuantizedMeshHeader header;
  std::vector<std::uint16_t> u, v, height;              ///< 0..32767 per vertex
  std::vector<std::uint32_t> indices;                   ///< 3 per triangle, counter-clockwise
  std::vector<std::uint32_t> west, south, east, north;  ///< edge vertices, as stored
  std::optional<std::vector<std::uint8_t>> normals;     ///< 2 oct bytes per vertex
  std::optional<std::vector<std::uint8_t>> water_mask;  ///< 1 or 65 536 bytes
  std::optional<std::string> metadata;                  ///< JSON text
  std::vector<std::uint8_t> unknown_extensions;         ///< ids skipped, in order

  std::size_t vertex_count() const { return u.size(); }
  /// m + ((M − m)·k)/32767 in double, evaluated in that order, which is exact for tiles we write.
  double height_metres(std::size_t vertex) const;
};

/// Parses a quantized-mesh-1.0 tile (uncompressed). Never reads out of bounds; refuses truncated
/// or inconsistent input (counts beyond the data, decoded coordinates above 32767, indices out of
/// range or breaking the high-water mark, extension lengths that disagree with their content,
/// repeated extensions, non-finite or inverted header values). Unknown extensions are skipped.
Result<QuantizedMesh> decode_quantized_mesh(std::span<const std::uint8_t> bytes);

/// Cesium's AttributeCompression.octEncode (8 bits per component) of a unit vector.
std::array<std::uint8_t, 2> oct_encode(const std::array<double, 3>& unit);
/// Cesium's AttributeCompression.octDecode: the unit vector two oct bytes stand for.
std::array<double, 3> oct_decode(std::uint8_t x, std::uint8_t y);

/// A rectangle of available tiles at one level, in TMS numbering (y grows north), inclusive.
struct AvailabilityRectangle {
  std::int64_t start_x = 0;
  std::int64_t start_y = 0;
  std::int64_t end_x = 0;
  std::int64_t end_y = 0;
};

/// How many levels below itself a tile's metadata extension lists availability for, and so
/// layer.json's `metadataAvailability`: tiles at levels 0, n, 2n, … are the ones CesiumJS
/// reads availability from.
inline constexpr int kMetadataAvailabilityLevels = 10;

/// The fields of layer.json we let the caller choose.
struct LayerJsonOptions {
  std::string name = "Terrain";
  std::string description;
  std::string attribution;
  std::string version = "1.2.0";  ///< substituted for {version} in the templates
  /// URL templates relative to layer.json, with {z}, {x}, {y} (TMS) and {version}.
  std::vector<std::string> tiles = {"{z}/{x}/{y}.terrain?v={version}"};
  TileBounds bounds{-180.0, -90.0, 180.0, 90.0};  ///< degrees
  int minzoom = 0;
  int maxzoom = 0;
  std::vector<std::string> extensions = {"octvertexnormals", "watermask", "metadata"};
  /// available[z]: the rectangles of tiles that exist at zoom z. Left out of the document when
  /// empty (Cesium would read an empty list as "no tile exists").
  std::vector<std::vector<AvailabilityRectangle>> available;
};

/// The layer.json document CesiumTerrainProvider reads: tilejson "2.1.0", format
/// "quantized-mesh-1.0", scheme "tms", projection "EPSG:4326" and the options' fields. When the
/// extensions list `metadata`, it also carries `metadataAvailability`
/// (kMetadataAvailabilityLevels): CesiumJS keeps the bookkeeping for tile metadata only then,
/// and fails on every tile's metadata without it.
nlohmann::json quantized_mesh_layer_json(const LayerJsonOptions& options);

/// {"available": [[rectangles of level z+1], [level z+2], ...]}: the metadata extension's
/// availability for the levels below a tile, as Cesium reads it.
nlohmann::json quantized_mesh_metadata_json(
    const std::vector<std::vector<AvailabilityRectangle>>& levels_below);

}  // namespace terrain
