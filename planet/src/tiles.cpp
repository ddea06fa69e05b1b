#include "planet/tiles.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "terrain/draco_mesh.hpp"
#include "terrain/quantized_mesh.hpp"

namespace planet {
namespace {

using terrain::HeightTile;
using terrain::SampleLayout;
using terrain::TileAddress;
using terrain::TileFormat;
using terrain::TileRequest;
using terrain::TileScheme;

constexpr double kDegree = std::numbers::pi / 180.0;

TileRequest request_for(TileScheme scheme, const TileAddress& address, TileFormat format,
                        const terrain::ProductOptions& options) {
  if (terrain::format_info(format).mesh) {
    return {scheme, address, SampleLayout::cell_corners, options.grid - 1, 0};
  }
  return {scheme, address, SampleLayout::cell_centres, options.size, options.border ? 1 : 0};
}

// Rectangles of every tile at levels from_z … to_z, or of the descendants of one tile.
std::vector<std::vector<terrain::AvailabilityRectangle>> everything(int from_z, int to_z,
                                                                    const TileAddress* within) {
  std::vector<std::vector<terrain::AvailabilityRectangle>> levels;
  for (int z = from_z; z <= to_z; ++z) {
    terrain::AvailabilityRectangle a{0, 0, (std::int64_t{2} << z) - 1, (std::int64_t{1} << z) - 1};
    if (within != nullptr) {
      const int k = z - within->z;
      a = {within->x << k, within->y << k, ((within->x + 1) << k) - 1, ((within->y + 1) << k) - 1};
    }
    levels.push_back({a});
  }
  return levels;
}

}  // namespace

// A new zoom-10 tile adds about 10 000 to 270 000 triangles of refinement, as its leaves vary
// (planet.md "Leaves per tile"), so a thread keeps from one to dozens of tiles' worth of splits
// (about 35 MB; the sampler trims before a tile past that): neighbours share the levels above
// them, and a tile already made is in the product cache. Keeping eight times as many (about
// 260 MB a thread) made a new tile beside the last (BM_PlanetTilePanning over hundreds of tiles)
// 12–19 % slower at zoom 10, with a working set eight times larger and the first round of splits
// on fresh pages. Half as many made zoom-2 tiles a third slower: they share coarse levels.
PlanetTiles::PlanetTiles(std::shared_ptr<const Planet> planet)
    : sampler_(std::move(planet), kTrimTriangles) {}

int PlanetTiles::max_zoom() {
  return terrain::max_zoom(TileScheme::geographic);
}

terrain::ProductConstants PlanetTiles::constants_for(const Planet& planet, int z) {
  terrain::ProductConstants c;
  const terrain::Interval range = planet.elevation_range();
  c.gray16 = terrain::gray16_encoding_for(range);
  // Colours measure the relief from sea level: the lowlands of every continent are green.
  c.relief = {0.0f, std::max(range.hi, 1.0f)};
  c.shore_band = 15.0f;  // metres of beach above the sea
  c.material = planet.definition().material;
  const double span = static_cast<double>(range.hi) - range.lo;
  c.edge_quantum = terrain::edge_quantum_for(range.lo, range.hi);
  c.position_quantum = terrain::position_quantum_for(
      std::numbers::pi * planet.definition().radius / std::ldexp(1.0, z), span);
  c.max_useful_zoom[static_cast<int>(TileScheme::geographic)] = max_zoom();
  c.max_useful_zoom[static_cast<int>(TileScheme::webmercator)] =
      terrain::max_zoom(TileScheme::webmercator);
  return c;
}

terrain::Status PlanetTiles::validate(TileScheme scheme, const TileAddress& address,
                                      TileFormat format, const terrain::ProductOptions& options) {
  if (scheme == TileScheme::local) {
    return Error{"planets are tiled in the geographic and webmercator schemes", "/scheme"};
  }
  if (terrain::format_info(format).mesh && scheme != TileScheme::geographic) {
    return Error{"planet meshes are on the geographic scheme (Cesium's) only", "/scheme"};
  }
  if (terrain::Status s = terrain::validate_request(request_for(scheme, address, format, options));
      !s) {
    return s;
  }
  if (terrain::format_info(format).mesh && options.max_error &&
      !(*options.max_error >= 0.0 && *options.max_error <= 1e6)) {
    return Error{"max_error must be between 0 and 1e6 metres", "/max_error"};
  }
  return terrain::Ok{};
}

Result<HeightTile> PlanetTiles::evaluate(const TileRequest& request,
                                         std::vector<std::uint8_t>* submerged) {
  if (request.scheme == TileScheme::local) {
    return Error{"planets are tiled in the geographic and webmercator schemes", "/scheme"};
  }
  if (terrain::Status valid = terrain::validate_request(request); !valid) return valid.error();
  const Planet& world = planet();
  HeightTile tile = terrain::tile_layout_for(request);
  const TileAddress& a = request.address;
  // Web Mercator (for MapLibre): the same planet seen through EPSG:3857's longitude and
  // latitude. Its tiles span twice the longitude of a geographic tile of the same zoom, so the
  // level of detail is that of the geographic zoom above; one spacing for the whole zoom keeps
  // shared edges seamless (finer than needed towards the poles).
  const bool mercator = request.scheme == TileScheme::webmercator;
  if (mercator) {
    const double half = std::numbers::pi * terrain::kWebMercatorRadius;
    tile.world = {-half, -half, half, half};
    tile.bounds = terrain::tile_footprint(request.scheme, tile.world, a);
    tile.ground_spacing = 2.0 * world.ground_spacing(a.z, request.cells);
  } else {
    tile.world = {-180.0, -90.0, 180.0, 90.0};
    const double size = 180.0 / std::ldexp(1.0, a.z);  // degrees per tile, both ways
    tile.bounds = {
        -180.0 + static_cast<double>(a.x) * size, -90.0 + static_cast<double>(a.y) * size,
        -180.0 + static_cast<double>(a.x + 1) * size, -90.0 + static_cast<double>(a.y + 1) * size};
    tile.ground_spacing = world.ground_spacing(a.z, request.cells);
  }
  tile.unseen_relief = world.relief_between_samples(tile.ground_spacing);
  const auto longitude_of = [&](double crs_x) {
    return mercator ? terrain::web_mercator_longitude(crs_x) : crs_x;
  };
  const auto latitude_of = [&](double crs_y) {
    return mercator ? terrain::web_mercator_latitude(crs_y) : crs_y;
  };
  const int level = world.level_for_spacing(tile.ground_spacing);
  const double octaves = world.octaves_for_spacing(tile.ground_spacing);

  // One ring of samples beyond the tile for central-difference slopes: a shared sample's slope
  // is then computed from the same neighbours in every tile that holds it.
  const int n = tile.width, ext = n + 2;
  std::vector<double> sin_lon(static_cast<std::size_t>(ext)), cos_lon(sin_lon.size());
  std::vector<double> lon_deg(sin_lon.size());
  for (int c = 0; c < ext; ++c) {
    double lon = longitude_of(tile.sample_crs_x(c - 1));
    lon_deg[static_cast<std::size_t>(c)] = lon;
    if (lon >= 180.0) lon -= 360.0;  // the antimeridian is one direction, seen from either side
    if (lon < -180.0) lon += 360.0;
    sin_lon[static_cast<std::size_t>(c)] = std::sin(lon * kDegree);
    cos_lon[static_cast<std::size_t>(c)] = std::cos(lon * kDegree);
  }
  std::vector<double> ground(static_cast<std::size_t>(ext) * static_cast<std::size_t>(ext));
  std::vector<std::uint8_t> wet(ground.size());
  std::vector<double> lat_deg(static_cast<std::size_t>(ext));
  std::vector<double> sin_lat(lat_deg.size()), cos_lat(lat_deg.size());
  for (int r = 0; r < ext; ++r) {
    const double lat = std::clamp(latitude_of(tile.sample_crs_y(r - 1)), -90.0, 90.0);
    lat_deg[static_cast<std::size_t>(r)] = lat;
    sin_lat[static_cast<std::size_t>(r)] = std::sin(lat * kDegree);
    cos_lat[static_cast<std::size_t>(r)] = std::cos(lat * kDegree);
  }
  sampler_.grid({ext, ext, lat_deg, lon_deg, sin_lat, cos_lat, sin_lon, cos_lon}, level, octaves,
                [&](std::size_t at, const PointSample& sample) {
                  ground[at] = sample.ground;
                  wet[at] =
                      sample.type == SurfaceType::land || sample.type == SurfaceType::coast ? 0 : 1;
                });
  const auto count = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  tile.elevation.resize(count);
  tile.slope_east.resize(count);
  tile.slope_north.resize(count);
  tile.scene_x.resize(count);
  tile.scene_y.resize(count);
  if (submerged != nullptr) submerged->resize(count);
  const double radius = world.definition().radius;
  const double step_x =
      (longitude_of(tile.sample_crs_x(1)) - longitude_of(tile.sample_crs_x(0))) * kDegree;
  const double step_y = (tile.sample_crs_y(0) - tile.sample_crs_y(1)) * kDegree;
  // Metres from a row's northern neighbour to its southern one: uniform on the geographic
  // grid, shrinking towards the equator on Web Mercator's.
  const auto north_span = [&](int r) {
    if (!mercator) return 2.0 * step_y * radius;
    return (lat_deg[static_cast<std::size_t>(r)] - lat_deg[static_cast<std::size_t>(r + 2)]) *
           kDegree * radius;
  };
  for (int r = 0; r < n; ++r) {
    const double lat = lat_deg[static_cast<std::size_t>(r + 1)];
    const double east_metres = 2.0 * step_x * radius * std::cos(lat * kDegree);
    for (int c = 0; c < n; ++c) {
      const std::size_t at = tile.index(c, r);
      const std::size_t e = static_cast<std::size_t>(r + 1) * static_cast<std::size_t>(ext) +
                            static_cast<std::size_t>(c + 1);
      tile.elevation[at] = static_cast<float>(ground[e]);
      tile.slope_east[at] = east_metres > 1e-9
                                ? static_cast<float>((ground[e + 1] - ground[e - 1]) / east_metres)
                                : 0.0f;
      tile.slope_north[at] = static_cast<float>(
          (ground[e - static_cast<std::size_t>(ext)] - ground[e + static_cast<std::size_t>(ext)]) /
          north_span(r));
      tile.scene_x[at] = radius * lon_deg[static_cast<std::size_t>(c + 1)] * kDegree;
      tile.scene_y[at] = radius * lat * kDegree;
      if (submerged != nullptr) (*submerged)[at] = wet[e];
    }
  }
  return tile;
}

Result<HeightTile> PlanetTiles::height_tile(const TileRequest& request) {
  return evaluate(request, nullptr);
}

Result<HeightTile> PlanetTiles::height_tile(TileScheme scheme, const TileAddress& address,
                                            TileFormat format,
                                            const terrain::ProductOptions& options) {
  if (terrain::Status s = validate(scheme, address, format, options); !s) return s.error();
  return evaluate(request_for(scheme, address, format, options), nullptr);
}

Result<std::vector<std::uint8_t>> PlanetTiles::water_mask(const TileAddress& address) {
  std::vector<std::uint8_t> wet;
  Result<HeightTile> tile =
      evaluate({TileScheme::geographic, address, SampleLayout::cell_centres, 256, 0}, &wet);
  if (!tile) return tile.error();
  bool any_land = false, any_water = false;
  for (std::uint8_t& w : wet) {
    (w != 0 ? any_water : any_land) = true;
    w = w != 0 ? 255 : 0;
  }
  if (!any_water) return std::vector<std::uint8_t>{0};
  if (!any_land) return std::vector<std::uint8_t>{255};
  return wet;
}

Result<terrain::Product> PlanetTiles::make(TileScheme scheme, const TileAddress& address,
                                           TileFormat format,
                                           const terrain::ProductOptions& options) {
  if (terrain::Status s = validate(scheme, address, format, options); !s) return s.error();
  const terrain::ProductConstants constants = constants_at(address.z);
  if (terrain::Status s = terrain::check_mesh_lattice(
          format, planet().ground_spacing(address.z, options.grid - 1), constants.position_quantum);
      !s) {
    return s.error();
  }
  terrain::ProductExtras extras;
  // Colour tiles show the water of their own samples, sea and rivers, and beaches above sea
  // level: a wet sample's surface is +∞ (drawn as water; its level is not needed), a dry one's
  // the sea's.
  const bool color = terrain::is_color(format);
  std::vector<std::uint8_t> wet;
  Result<HeightTile> tile =
      evaluate(request_for(scheme, address, format, options), color ? &wet : nullptr);
  if (!tile) return tile.error();
  for (std::uint8_t w : wet) {
    extras.water_surface.push_back(w != 0 ? std::numeric_limits<float>::infinity() : 0.0f);
  }
  if (color) {
    // Each row's latitude (its scene_y is radius × latitude) lowers the snow line poleward.
    const double radius = planet().definition().radius;
    for (int row = 0; row < tile->height; ++row) {
      const double latitude = tile->scene_y[static_cast<std::size_t>(row * tile->width)] / radius;
      extras.polar.push_back(static_cast<float>(std::sin(latitude)));
    }
  }
  if (format == TileFormat::quantized_mesh) {
    if (options.watermask) {
      Result<std::vector<std::uint8_t>> mask = water_mask(address);
      if (!mask) return mask.error();
      extras.water_mask = std::move(*mask);
    }
    if (options.metadata && address.z < max_zoom()) {
      extras.metadata =
          terrain::quantized_mesh_metadata_json(
              everything(address.z + 1,
                         std::min(max_zoom(), address.z + terrain::kMetadataAvailabilityLevels),
                         &address))
              .dump();
    }
  }
  // The request was validated: what the encoders refuse now is a fault of this module's.
  Result<terrain::Product> product = terrain::encode_product(
      *tile, format, options, constants, terrain::Georeference{}, std::move(extras));
  if (!product) return terrain::internal_error(product.error());
  product->backend = "cpu (planet)";
  return product;
}

nlohmann::json PlanetTiles::layer_json(const terrain::LayerJsonOptions& base) {
  terrain::LayerJsonOptions options = base;
  options.minzoom = 0;
  options.maxzoom = max_zoom();
  options.available = everything(0, max_zoom(), nullptr);
  return terrain::quantized_mesh_layer_json(options);
}

}  // namespace planet
