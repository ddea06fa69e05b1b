#include "terrain/tile_products.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "terrain/draco_mesh.hpp"
#include "terrain/gzip.hpp"
#include "terrain/material.hpp"

namespace terrain {
namespace {

bool is_mesh(TileFormat format) {
  return format_info(format).mesh;
}

// glTF and Draco tiles, whose positions snap to the lattice of draco_mesh.hpp.
bool on_position_lattice(TileFormat format) {
  return format == TileFormat::glb || format == TileFormat::draco;
}

// A length for a message: "0.00781 m", "65.5 km".
std::string length_text(double metres) {
  char text[32];
  if (std::abs(metres) >= 1000.0) {
    std::snprintf(text, sizeof text, "%.3g km", metres / 1000.0);
  } else {
    std::snprintf(text, sizeof text, "%.3g m", metres);
  }
  return text;
}

constexpr TileScheme kSchemes[] = {TileScheme::local, TileScheme::webmercator,
                                   TileScheme::geographic};

}  // namespace

const std::vector<TileFormatInfo>& tile_formats() {
  static const std::vector<TileFormatInfo> table = {
      {TileFormat::terrain_rgb, "png", "terrain-rgb", "image/png", false},
      {TileFormat::terrarium, "png", "terrarium", "image/png", false},
      {TileFormat::gray16, "png", "gray16", "image/png", false},
      {TileFormat::normal_map, "png", "normals", "image/png", false},
      {TileFormat::hillshade, "png", "hillshade", "image/png", false},
      {TileFormat::color_png, "png", "color", "image/png", false},
      {TileFormat::color_jpeg, "jpg", "color", "image/jpeg", false},
      {TileFormat::geotiff, "tif", "", "image/tiff", false},
      {TileFormat::quantized_mesh, "terrain", "", "application/vnd.quantized-mesh", true},
      {TileFormat::glb, "glb", "", "model/gltf-binary", true},
      {TileFormat::draco, "drc", "", "application/vnd.google.draco", true},
  };
  return table;
}

const TileFormatInfo& format_info(TileFormat format) {
  for (const TileFormatInfo& info : tile_formats()) {
    if (info.format == format) return info;
  }
  assert(false && "unknown tile format");
  return tile_formats().front();
}

Result<TileFormat> parse_tile_format(std::string_view extension, std::string_view encoding) {
  std::string extensions;  // the lists in the messages, from the table
  std::string encodings;
  const TileFormatInfo* fallback = nullptr;
  for (const TileFormatInfo& info : tile_formats()) {
    if (extensions.find(std::string(info.extension) + ",") == std::string::npos) {
      extensions += std::string(info.extension) + ", ";
    }
    if (info.extension != extension) continue;
    if (fallback == nullptr) fallback = &info;
    if (info.encoding == encoding) return info.format;
    if (!info.encoding.empty()) encodings += std::string(info.encoding) + ", ";
  }
  if (fallback == nullptr) {
    return Error{"unknown tile format '" + std::string(extension) + "' (expected " +
                     extensions.substr(0, extensions.size() - 2) + ")",
                 "/format", ErrorKind::not_found};
  }
  if (encoding.empty()) return fallback->format;
  if (encodings.empty()) {
    return Error{"the ." + std::string(extension) + " format takes no encoding", "/encoding"};
  }
  return Error{"unknown ." + std::string(extension) + " encoding '" + std::string(encoding) +
                   "' (expected " + encodings.substr(0, encodings.size() - 2) + ")",
               "/encoding"};
}

ProductMaker::ProductMaker(TileSource source) : generator_(std::move(source)) {
  const TileSource& s = generator_.source();
  constants_.gray16 = gray16_encoding_for(s.elevation_range);
  constants_.relief = s.elevation_range;
  constants_.shore_band = shore_band_for(s.elevation_range);
  constants_.material = s.material;
  const double range = static_cast<double>(s.elevation_range.hi) - s.elevation_range.lo;
  constants_.edge_quantum = edge_quantum_for(s.elevation_range.lo, s.elevation_range.hi);
  // Positions span the scene's square; skirts reach below it by at most a few tens of metres
  // on useful zooms, which the factor two in position_quantum_for's rule leaves room for.
  constants_.position_quantum =
      position_quantum_for(s.local_square.east - s.local_square.west, range);
  for (TileScheme scheme : kSchemes) {
    int z = 0;
    while (z < max_zoom(scheme) && ground_spacing(s, scheme, z, 64) > 1.0) ++z;
    constants_.max_useful_zoom[static_cast<int>(scheme)] = z;
  }
}

double ProductMaker::default_max_error(TileScheme scheme, int z, int grid) const {
  return 0.25 * ground_spacing(generator_.source(), scheme, z, grid - 1);
}

TileRequest ProductMaker::request_for(TileScheme scheme, const TileAddress& address,
                                      TileFormat format, const ProductOptions& options) {
  if (is_mesh(format)) return {scheme, address, SampleLayout::cell_corners, options.grid - 1, 0};
  return {scheme, address, SampleLayout::cell_centres, options.size, options.border ? 1 : 0};
}

Status check_mesh_lattice(TileFormat format, double spacing, double quantum) {
  if (!on_position_lattice(format) || spacing >= quantum) return Ok{};
  return Error{"glTF and Draco tiles snap positions to a lattice of " + length_text(quantum) +
                   ", and this zoom and grid put samples " + length_text(spacing) +
                   " apart: ask for a shallower zoom or a smaller grid",
               "/z"};
}

Status check_mesh_extent(const HeightTile& tile, TileFormat format, double quantum) {
  if (!on_position_lattice(format)) return Ok{};
  const auto span = [](const std::vector<double>& v) {
    const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
    return v.empty() ? 0.0 : *hi - *lo;
  };
  const double widest = std::max(span(tile.scene_x), span(tile.scene_y));
  // 4 quanta spare for snapping both ends, as the encoder leaves below a tile's skirts.
  const double room = quantum * static_cast<double>(kMaxPositionQuanta - 3);
  if (widest <= room) return Ok{};
  return Error{"a glTF or Draco tile spans at most 2^23 quanta of " + length_text(quantum) + " (" +
                   length_text(room) + "), and this zoom's tile spans " + length_text(widest) +
                   ": ask for a deeper zoom",
               "/z"};
}

Status ProductMaker::validate(TileScheme scheme, const TileAddress& address, TileFormat format,
                              const ProductOptions& options) const {
  // Address and sizes are the sampler's to check; only what is particular to meshes is here.
  if (Status s = validate_request(request_for(scheme, address, format, options)); !s) return s;
  if (!is_mesh(format)) return Ok{};
  if (options.max_error && !(*options.max_error >= 0.0 && *options.max_error <= 1e6)) {
    return Error{"max_error must be between 0 and 1e6 metres", "/max_error"};
  }
  if (format == TileFormat::quantized_mesh && scheme != TileScheme::geographic) {
    return Error{"quantized-mesh tiles exist in the geographic scheme only (Cesium's)", "/scheme"};
  }
  return check_mesh_lattice(
      format, ground_spacing(generator_.source(), scheme, address.z, options.grid - 1),
      constants_.position_quantum);
}

Result<HeightTile> ProductMaker::height_tile(TileScheme scheme, const TileAddress& address,
                                             TileFormat format, const ProductOptions& options) {
  if (Status s = validate(scheme, address, format, options); !s) return s.error();
  return generator_.height_tile(request_for(scheme, address, format, options));
}

TileMesh ProductMaker::triangulate(const HeightTile& tile, const ProductOptions& options,
                                   TileFormat format) const {
  // The tile's ground spacing is ground_spacing(source, scheme, z, grid − 1): the same default
  // error allowance as default_max_error.
  return triangulate_for(tile, options, format);
}

std::vector<std::vector<AvailabilityRectangle>> ProductMaker::availability(
    int from_z, int to_z, const TileAddress* within) const {
  std::vector<std::vector<AvailabilityRectangle>> levels;
  for (int z = from_z; z <= to_z; ++z) {
    std::vector<AvailabilityRectangle> level;
    if (z == 0) {
      level.push_back({0, 0, 1, 0});  // both root tiles always exist
    } else {
      const TileRange r = tiles_covering_area(generator_.source(), TileScheme::geographic, z);
      AvailabilityRectangle a{r.min_x, r.min_y, r.max_x, r.max_y};
      if (within != nullptr) {  // only the descendants of one tile
        const int k = z - within->z;
        a.start_x = std::max(a.start_x, within->x << k);
        a.start_y = std::max(a.start_y, within->y << k);
        a.end_x = std::min(a.end_x, ((within->x + 1) << k) - 1);
        a.end_y = std::min(a.end_y, ((within->y + 1) << k) - 1);
      }
      if (a.start_x <= a.end_x && a.start_y <= a.end_y) level.push_back(a);
    }
    levels.push_back(std::move(level));
  }
  return levels;
}

nlohmann::json ProductMaker::layer_json(const LayerJsonOptions& base) const {
  LayerJsonOptions options = base;
  options.minzoom = 0;
  options.maxzoom = constants_.max_useful_zoom[static_cast<int>(TileScheme::geographic)];
  options.available = availability(0, options.maxzoom, nullptr);
  return quantized_mesh_layer_json(options);
}

double cesium_level_geometric_error(int z) {
  constexpr double kWgs84MaximumRadius = 6378137.0;
  return kWgs84MaximumRadius * 2.0 * std::numbers::pi * 0.25 / (65.0 * 2.0) / std::ldexp(1.0, z);
}

TileMesh triangulate_for(const HeightTile& tile, const ProductOptions& options, TileFormat format) {
  if (options.regular) return triangulate_grid(tile.width);
  if (format == TileFormat::quantized_mesh && tile.scheme == TileScheme::geographic) {
    // The allowance bounds what the samples see; 10 % of Cesium's error stays for what they
    // cannot: the sag inside one grid cell (at most 5 % at zoom 0 with 65 samples, halving per
    // zoom) and the height and position quanta; and the relief between samples, where the
    // surface says how much it has.
    const double max_error = options.max_error.value_or(std::max(
        0.0,
        std::min(0.25 * tile.ground_spacing, 0.9 * cesium_level_geometric_error(tile.address.z)) -
            tile.unseen_relief));
    const int last = tile.width - 1;
    const TileBounds degrees{tile.sample_crs_x(0), tile.sample_crs_y(last), tile.sample_crs_x(last),
                             tile.sample_crs_y(0)};
    return triangulate_rtin_on_ellipsoid(tile.elevation.data(), tile.width, degrees,
                                         static_cast<float>(max_error));
  }
  const double max_error = options.max_error.value_or(0.25 * tile.ground_spacing);
  return triangulate_rtin(tile.elevation.data(), tile.width, static_cast<float>(max_error));
}

Result<Product> encode_product(const HeightTile& tile, TileFormat format,
                               const ProductOptions& options, const ProductConstants& constants,
                               const Georeference& georeference, ProductExtras extras) {
  Product product;
  product.media_type = std::string(format_info(format).media_type);
  Result<std::vector<std::uint8_t>> bytes = std::vector<std::uint8_t>{};
  switch (format) {
    case TileFormat::terrain_rgb:
      bytes = encode_terrain_rgb(tile);
      break;
    case TileFormat::terrarium:
      bytes = encode_terrarium(tile);
      break;
    case TileFormat::gray16:
      bytes = encode_gray16(tile, constants.gray16);
      break;
    case TileFormat::normal_map:
      bytes = encode_normal_map(tile);
      break;
    case TileFormat::hillshade:
      bytes = encode_hillshade(tile);
      break;
    case TileFormat::color_png:
    case TileFormat::color_jpeg: {
      ColorTileInputs inputs;
      inputs.relief = constants.relief;
      inputs.water_surface = extras.water_surface;
      inputs.shore_band = constants.shore_band;
      inputs.material = constants.material;
      inputs.polar = extras.polar;
      bytes = encode_color(tile, inputs,
                           format == TileFormat::color_png ? ColorCodec::png : ColorCodec::jpeg);
      break;
    }
    case TileFormat::geotiff:
      bytes = encode_geotiff(tile, georeference);
      break;
    case TileFormat::glb:
    case TileFormat::draco: {
      DracoOptions draco;
      draco.position_quantum = constants.position_quantum;
      const double max_error = options.max_error.value_or(0.25 * tile.ground_spacing);
      // Skirts deep enough to hide the largest step between neighbours of adjacent levels, and
      // at least a quantum (a planet's coarse zooms have quanta of metres), or they would snap
      // onto the surface.
      draco.skirt_height = std::max({5.0 * max_error, 1.0, constants.position_quantum});
      const TileMesh mesh = triangulate_for(tile, options, format);
      bytes = format == TileFormat::glb ? encode_glb(tile, mesh, draco)
                                        : encode_draco(tile, mesh, draco);
      break;
    }
    case TileFormat::quantized_mesh: {
      QuantizedMeshOptions qm;
      qm.edge_quantum = constants.edge_quantum;
      qm.normals = options.octvertexnormals;
      if (options.watermask) qm.water_mask = std::move(extras.water_mask);
      if (options.metadata) qm.metadata = std::move(extras.metadata);
      Result<std::vector<std::uint8_t>> raw =
          encode_quantized_mesh(tile, triangulate_for(tile, options, format), qm);
      if (!raw) return raw.error();
      bytes = gzip_compress(std::span<const std::uint8_t>(*raw), 6);
      product.content_encoding = "gzip";
      break;
    }
  }
  if (!bytes) return bytes.error();
  product.bytes = std::move(*bytes);
  return product;
}

Result<Product> ProductMaker::make(TileScheme scheme, const TileAddress& address, TileFormat format,
                                   const ProductOptions& options) {
  if (Status s = validate(scheme, address, format, options); !s) return s.error();
  ProductExtras extras;
  const bool color = is_color(format);
  Result<HeightTile> generated =
      color ? generator_.height_tile_with_water(request_for(scheme, address, format, options),
                                                extras.water_surface, constants_.shore_band)
            : generator_.height_tile(request_for(scheme, address, format, options));
  if (!generated) return generated.error();
  if (Status s = check_mesh_extent(*generated, format, constants_.position_quantum); !s) {
    return s.error();
  }
  if (format == TileFormat::quantized_mesh) {
    if (options.watermask) {
      Result<std::vector<std::uint8_t>> mask = generator_.water_mask(scheme, address);
      if (!mask) return internal_error(mask.error());
      extras.water_mask = std::move(*mask);
    }
    if (options.metadata) {
      const int deepest = constants_.max_useful_zoom[static_cast<int>(TileScheme::geographic)];
      extras.metadata =
          quantized_mesh_metadata_json(
              availability(address.z + 1,
                           std::min(deepest, address.z + kMetadataAvailabilityLevels), &address))
              .dump();
    }
  }
  // The request was validated with the tile: what the encoders refuse now is what this module
  // made, a fault of its own.
  Result<Product> product = encode_product(*generated, format, options, constants_,
                                           generator_.source().georeference, std::move(extras));
  if (!product) return internal_error(product.error());
  product->backend = generator_.last_backend();
  return product;
}

}  // namespace terrain
