// A planet's tile products on the geographic scheme (EPSG:4326 TMS, two root tiles, as Cesium
// reads it), and its height images on Web Mercator (EPSG:3857 XYZ, for MapLibre): height tiles that
// plug into terrain's encoders (every format of docs/tiles.md), quantized-mesh with a water mask
// from the sea and the rivers, and layer.json. What the server's /api/v1/planets/{id}/… routes
// call.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "planet/planet.hpp"
#include "terrain/tile_products.hpp"

namespace planet {

/// Makes tiles of one planet. Holds a Sampler (a cache), so it is not thread-safe: use one per
/// thread; the bytes never depend on which one made them or what it made before.
class PlanetTiles {
 public:
  explicit PlanetTiles(std::shared_ptr<const Planet> planet);

  const Planet& planet() const { return sampler_.planet(); }
  /// The deepest zoom offered (the geographic scheme's).
  static int max_zoom();

  /// The products' constants: one gray16 encoding and edge quantum for the whole planet; the
  /// glTF/Draco position lattice per zoom (tile positions are plate carrée metres, R·λ and R·φ,
  /// whose span shrinks with the zoom, so each zoom's lattice is as fine as a tile allows).
  terrain::ProductConstants constants_at(int z) const { return constants_for(planet(), z); }
  /// The same for any planet (what its colour tiles measure relief and shores with, and the
  /// viewer's planet mode too).
  static terrain::ProductConstants constants_for(const Planet& planet, int z);

  /// Checks the scheme (geographic; webmercator for height images, not meshes), address,
  /// format and options; the error names the field ("/scheme", "/z", "/x", "/size", "/grid",
  /// "/max_error"). Static: it depends on no planet, so servers check a request before any work.
  static terrain::Status validate(terrain::TileScheme scheme, const terrain::TileAddress& address,
                                  terrain::TileFormat format,
                                  const terrain::ProductOptions& options);
  static terrain::Status validate(const terrain::TileAddress& address, terrain::TileFormat format,
                                  const terrain::ProductOptions& options) {
    return validate(terrain::TileScheme::geographic, address, format, options);
  }

  /// Heights and slopes (east, north) of a geographic or Web Mercator tile request. Samples at the
  /// same place in two tiles of one zoom and size are bit-identical (positions come from global
  /// sample indices, the height from the position alone). The error's pointer names the field.
  Result<terrain::HeightTile> height_tile(const terrain::TileRequest& request);
  /// The height tile behind a product (geographic unless the scheme is named).
  Result<terrain::HeightTile> height_tile(terrain::TileScheme scheme,
                                          const terrain::TileAddress& address,
                                          terrain::TileFormat format,
                                          const terrain::ProductOptions& options = {});
  Result<terrain::HeightTile> height_tile(const terrain::TileAddress& address,
                                          terrain::TileFormat format,
                                          const terrain::ProductOptions& options = {}) {
    return height_tile(terrain::TileScheme::geographic, address, format, options);
  }
  /// quantized-mesh's water mask: 256×256 bytes, row 0 north, 255 where the sea or a river
  /// covers the ground, else 0; one byte when the whole tile is land (0) or water (255).
  Result<std::vector<std::uint8_t>> water_mask(const terrain::TileAddress& address);

  /// A product: the height tile encoded by terrain::encode_product (geographic unless the
  /// scheme is named).
  Result<terrain::Product> make(terrain::TileScheme scheme, const terrain::TileAddress& address,
                                terrain::TileFormat format,
                                const terrain::ProductOptions& options = {});
  Result<terrain::Product> make(const terrain::TileAddress& address, terrain::TileFormat format,
                                const terrain::ProductOptions& options = {}) {
    return make(terrain::TileScheme::geographic, address, format, options);
  }

  /// Its sampler's trim bound: past this many triangles of refinement kept between tiles, the
  /// sampler trims back to the base mesh before the next tile (tiles.cpp says why this many).
  static constexpr std::size_t kTrimTriangles = std::size_t{1} << 19;
  /// Triangles the sampler holds now, the base mesh's included.
  std::size_t cached_triangles() const { return sampler_.cached_triangles(); }

  /// Cesium's layer.json: every tile exists at every zoom up to max_zoom().
  /// Static: availability is the same for every planet.
  static nlohmann::json layer_json(const terrain::LayerJsonOptions& base);

 private:
  Result<terrain::HeightTile> evaluate(const terrain::TileRequest& request,
                                       std::vector<std::uint8_t>* submerged);
  Sampler sampler_;
};

}  // namespace planet
