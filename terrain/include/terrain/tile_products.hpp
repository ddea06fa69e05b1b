// Every tile product of a scene from one entry point: address + format + options → bytes, with
// the scene-wide constants (gray16 encoding, quantisation lattices, error allowances) chosen once
// per scene so that neighbouring tiles agree. What the CLI's `terrain tile` and the server call.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/quantized_mesh.hpp"
#include "terrain/tile_color.hpp"
#include "terrain/tile_image.hpp"
#include "terrain/tile_source.hpp"

namespace terrain {

/// The generation of every product's bytes (tiles, meshes, pictures, of scenes and planets).
/// Raised whenever the bytes made for the same input change: an encoder, the sampler, the
/// tracer, planet refinement, the erosion and drainage solvers. Shared caches, baked grids and
/// ETags carry it, so that during a rolling upgrade no two servers answer one immutable URL with
/// different bytes. The product goldens (tests/terrain/goldens, tests/planet/goldens) refuse new
/// hashes under an old generation. 2: erosion routes by Rho8 and sub-steps its diffusion. 3: the
/// material model's forest, scree, aspect-dependent snow line and shores (pictures, colour tiles).
/// 4: pictures' soft shadows, sky occlusion, Rayleigh–Mie sky, aerial perspective and water.
/// 5: material parameters: slope bands at whole degrees, a snow line lower towards planets' poles.
/// 6: pictures draw the scene's water layer (terrain::WaterRaster). 7: PNGs filter every row with
/// one fixed filter (terrain::PngKind) instead of libpng's per-row trial. 8: planet rivers are
/// as deep (and their channels as wide) as their drainage area makes them (depth ∝ A^0.4).
/// 9: planets drain at every level (drain edges, valley floors along rivers and coasts), bisect
/// into well-shaped triangles, and leave the fractal's octaves longer than finest_edge to the mesh.
/// 10: erosion keeps its heights in float and its uplift in 16 bits (fifteen bytes per cell, input
/// included: 2048² in 61.5 MiB); the drainage's water layer weighs nothing on dry land away from
/// water (no shores painted there). 11: planets' dry land is a C1 surface (Clough–Tocher cubics
/// over vertex slopes), and splits among dry vertices predict from it; planets have relief regions
/// (ruggedness, mountain belts); shaded PNGs (colour tiles, pictures) are deflated by Huffman
/// coding alone. 12: planets have lakes, open and closed (lake faces, a `lake` surface type), and
/// continental shelves and slopes on a deeper ocean floor. 13: planets have plateaus and coastal
/// plains (land vertices carry their distance to the coast). 14: planets' base rivers have
/// concave profiles by Flint's law (river_concavity, river_slope_area). 15: planets' river splits
/// keep half of their offset from the edge's midpoint (fewer slivers beside rivers), and valley
/// sides blend into their floors by a dryness that is C1 across every edge. 16: planets take the
/// drainage relief model unless they name another (every dry vertex hangs from the corner it
/// drains to, rivers climb into the belts and plateaus they drain). 17: the drainage model's
/// network grows where its rivers would stand lowest, land beside the coast drains to it rather
/// than to a river that would stand hundreds of metres higher, and new arms climb as the land
/// hung beside them does (fewer rivers on walls). 18: the drainage model's hung links steepen
/// towards the headwaters as l^−1 instead of l^−1.15 (θ ≈ 0.5: fewer land squares too concave).
/// 19: the sea covers the octahedron's four cone points on the equator, where land was slivers
/// whose tiles took seconds, and the base shape keeps a quarter of eq. 2's jitter instead of half
/// (fewer pits: they follow the stored mesh's largest leaves); every continent is new. 20: the
/// drainage model floors valley edges as it floors drains (fewer pits), and turns a drain that
/// would run on along the edge being split across it (no stars of valleys at coarse vertices).
/// 21: the drainage model spreads the rises of links at its steepest slope by up to 30 % either
/// way (no planar facets on steep land at zoom 14). 22: the open sea's floor is refined to
/// edges of about 2 km and no finer (a tile of open sea beside a cone point split 1.5 million
/// triangles).
inline constexpr int kProductGeneration = 22;

enum class TileFormat {
  terrain_rgb,     ///< PNG, Mapbox terrain-RGB
  terrarium,       ///< PNG, Terrarium
  gray16,          ///< PNG, 16-bit grey with the scene's offset and scale
  normal_map,      ///< PNG, RGB normals
  hillshade,       ///< PNG, 8-bit grey shading
  color_png,       ///< PNG, colour imagery (terrain/tile_color.hpp)
  color_jpeg,      ///< JPEG, colour imagery
  geotiff,         ///< TIFF, float32, georeferenced
  quantized_mesh,  ///< .terrain, Cesium quantized-mesh-1.0 (gzipped)
  glb,             ///< glTF binary with KHR_draco_mesh_compression
  draco,           ///< raw Draco mesh
};

/// Names and media types, driven by one table.
struct TileFormatInfo {
  TileFormat format;
  std::string_view extension;  ///< "png", "jpg", "tif", "terrain", "glb", "drc"
  std::string_view encoding;   ///< the `encoding` query value for images, else ""
  std::string_view media_type;
  bool mesh;
};
const TileFormatInfo& format_info(TileFormat format);
const std::vector<TileFormatInfo>& tile_formats();

/// Colour imagery (color_png, color_jpeg), whose pixels also show the source's water.
constexpr bool is_color(TileFormat format) {
  return format == TileFormat::color_png || format == TileFormat::color_jpeg;
}

/// A format from a file extension and an optional encoding (PNG: terrain-rgb (default),
/// terrarium, gray16, normals, hillshade, color; JPEG: color). An extension's first format in
/// tile_formats() is its default. The error names "/format" or "/encoding".
Result<TileFormat> parse_tile_format(std::string_view extension, std::string_view encoding = "");

/// Options beyond the address; each applies to some formats only.
struct ProductOptions {
  int size = 256;       ///< height images: samples per side (64, 128, 256, 512)
  bool border = false;  ///< height images: one more ring of the neighbours' samples
  int grid = 65;        ///< meshes: 2^k + 1 samples per side (3 .. 513)
  /// Meshes: largest vertical error of the adaptive triangulation in metres; by default a quarter
  /// of the mesh grid's ground spacing (it follows the zoom). 0 = every grid sample.
  std::optional<double> max_error;
  bool regular = false;  ///< meshes: the full regular grid instead of the adaptive mesh
  /// quantized-mesh extensions (Cesium asks for them in its Accept header).
  bool octvertexnormals = true;
  bool watermask = true;
  bool metadata = true;
};

/// An encoded tile.
struct Product {
  std::vector<std::uint8_t> bytes;
  std::string media_type;
  std::string content_encoding;  ///< "gzip" for quantized-mesh, else ""
  std::string backend;           ///< what evaluated the heights (TileGenerator::last_backend)
};

/// Constants of a scene's products: every tile of a scene is encoded with these.
struct ProductConstants {
  Gray16Encoding gray16;
  double edge_quantum = 1.0;           ///< quantized-mesh: shared edge heights are multiples of it
  double position_quantum = 1.0;       ///< glb/drc: the position lattice
  int max_useful_zoom[3] = {0, 0, 0};  ///< per scheme: where mesh grid spacing reaches ~1 m
  Interval relief{0.0f, 0.0f};         ///< colour tiles: see ColorTileInputs::relief
  float shore_band = 0.0f;             ///< colour tiles: see ColorTileInputs::shore_band
  Material material;                   ///< colour tiles: see ColorTileInputs::material
};

/// What some products carry besides the tile's heights: the source computes these (ProductMaker
/// from the scene's water layer and availability; other sources, such as planets, their own).
struct ProductExtras {
  std::optional<std::vector<std::uint8_t>> water_mask;  ///< quantized-mesh: QuantizedMeshOptions
  std::optional<std::string> metadata;                  ///< quantized-mesh: JSON text
  std::vector<float> water_surface;  ///< colour tiles: ColorTileInputs::water_surface
  std::vector<float> polar;          ///< colour tiles: ColorTileInputs::polar
};

/// glTF and Draco tiles snap their positions to a lattice of `quantum` metres, so samples
/// `spacing` metres apart, closer than that, would merge: such a request is refused naming "/z"
/// (a shallower zoom or a smaller grid is what helps). Other formats pass.
Status check_mesh_lattice(TileFormat format, double spacing, double quantum);

/// The same lattice spans at most 2^23 − 1 quanta along an axis of one tile (the encoder's
/// limit, draco_mesh.hpp), and a coarse tile of the geographic or Web Mercator scheme projected
/// into a scene's frame spans far more: such a tile is refused naming "/z" (a deeper zoom's
/// tiles fit). Other formats pass.
Status check_mesh_extent(const HeightTile& tile, TileFormat format, double quantum);

/// Encodes a height tile in `format` with a source's constants: the part of ProductMaker::make
/// after the heights are known, for any source of height tiles. The tile must have the layout
/// and size the format asks for (ProductMaker's request for the same options). Meshes use
/// options.max_error or, by default, a quarter of the tile's ground spacing.
Result<Product> encode_product(const HeightTile& tile, TileFormat format,
                               const ProductOptions& options, const ProductConstants& constants,
                               const Georeference& georeference, ProductExtras extras = {});

/// The geometric error CesiumTerrainProvider declares for level z of a geographic layer.json (two
/// root tiles): WGS84's maximum radius·2π·0.25 / (65·2), halved per level
/// (getLevelMaximumGeometricError). Cesium refines a tile when this error, projected on the
/// screen, exceeds its maximum screen-space error, so a tile must not stray further from the
/// surface.
double cesium_level_geometric_error(int z);

/// The triangulation encode_product uses for a mesh tile in `format`. Quantized-mesh (drawn on
/// the globe in Earth-centred coordinates) is triangulated on the ellipsoid
/// (triangulate_rtin_on_ellipsoid) within options.max_error or, by default, the smaller of a
/// quarter of the ground spacing and 0.9 × cesium_level_geometric_error(z), less the tile's
/// unseen_relief; glTF and Draco
/// (local coordinates) on the flat height grid within options.max_error or a quarter of the
/// ground spacing.
TileMesh triangulate_for(const HeightTile& tile, const ProductOptions& options, TileFormat format);

/// Makes products. Holds a TileGenerator, so it is not thread-safe: use one per thread.
class ProductMaker {
 public:
  explicit ProductMaker(TileSource source);

  const ProductConstants& constants() const { return constants_; }
  /// See TileGenerator::set_backend.
  void set_backend(std::shared_ptr<PointsBackend> backend) {
    generator_.set_backend(std::move(backend));
  }
  const TileSource& source() const { return generator_.source(); }

  /// Validates everything (address, format against scheme, options) before any work.
  Result<Product> make(TileScheme scheme, const TileAddress& address, TileFormat format,
                       const ProductOptions& options = {});

  /// The height tile behind a product (what `make` encodes), for tools and tests.
  Result<HeightTile> height_tile(TileScheme scheme, const TileAddress& address, TileFormat format,
                                 const ProductOptions& options = {});
  /// The triangulation `make` uses for a mesh tile.
  TileMesh triangulate(const HeightTile& tile, const ProductOptions& options,
                       TileFormat format) const;
  /// The default error allowance for meshes at zoom z (metres).
  double default_max_error(TileScheme scheme, int z, int grid) const;

  /// Cesium's layer.json for the geographic scheme: availability where the scene is (every
  /// zoom 0 tile, then the tiles covering the scene's area up to max_useful_zoom).
  nlohmann::json layer_json(const LayerJsonOptions& base) const;

  /// The samples `make` evaluates for a product (sample layout, cells, border).
  static TileRequest request_for(TileScheme scheme, const TileAddress& address, TileFormat format,
                                 const ProductOptions& options);

 private:
  Status validate(TileScheme scheme, const TileAddress& address, TileFormat format,
                  const ProductOptions& options) const;
  std::vector<std::vector<AvailabilityRectangle>> availability(int from_z, int to_z,
                                                               const TileAddress* within) const;

  TileGenerator generator_;
  ProductConstants constants_;
};

}  // namespace terrain
