// Tile products of real scenes, end to end: every format decodes back to the evaluated heights
// within its quantum, neighbours agree on what they share, bytes are reproducible across
// generators and processes, and bad requests are refused before any work.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include "example_tile_sources.hpp"
#include "terrain/gzip.hpp"
#include "terrain/image_io.hpp"
#include "terrain/tile_products.hpp"
#include "terrain/tile_source.hpp"

namespace terrain {
namespace {

namespace fs = std::filesystem;
const fs::path& kScenes = testing::kExampleScenes;

TileSource source_of(const std::string& name) {
  return testing::example_source(name);
}

// One maker per scene for the whole test binary (compiling a scene is the slow part).
ProductMaker& maker(const std::string& name) {
  static std::map<std::string, std::unique_ptr<ProductMaker>> makers;
  auto& m = makers[name];
  if (!m) m = std::make_unique<ProductMaker>(source_of(name));
  return *m;
}

Product make_or_die(ProductMaker& m, TileScheme scheme, TileAddress a, TileFormat f,
                    const ProductOptions& o = {}) {
  Result<Product> p = m.make(scheme, a, f, o);
  if (!p) throw std::runtime_error(p.error().pointer + ": " + p.error().message);
  return std::move(p).value();
}

HeightTile tile_or_die(ProductMaker& m, TileScheme scheme, TileAddress a, TileFormat f,
                       const ProductOptions& o = {}) {
  Result<HeightTile> t = m.height_tile(scheme, a, f, o);
  if (!t) throw std::runtime_error(t.error().pointer + ": " + t.error().message);
  return std::move(t).value();
}

// The geographic tile holding the scene origin.
TileAddress geographic_origin_tile(const TileSource& s, int z) {
  const double n = std::ldexp(1.0, z);
  return {z, static_cast<std::int64_t>((s.georeference.longitude + 180.0) / 180.0 * n),
          static_cast<std::int64_t>((s.georeference.latitude + 90.0) / 180.0 * n)};
}

Raster decode_png(const Product& p) {
  Result<Raster> r = decode_heightfield(p.bytes, "png");
  if (!r) throw std::runtime_error(r.error().message);
  return std::move(r).value();
}

QuantizedMesh decode_qm(const Product& p) {
  EXPECT_EQ(p.content_encoding, "gzip");
  Result<std::vector<std::uint8_t>> raw = gzip_decompress(p.bytes, 1u << 26);
  if (!raw) throw std::runtime_error(raw.error().message);
  Result<QuantizedMesh> mesh = decode_quantized_mesh(*raw);
  if (!mesh) throw std::runtime_error(mesh.error().message);
  return std::move(mesh).value();
}

// ---------------------------------------------------------------------------------------------
// Every format decodes to the evaluated heights

TEST(TileProducts, HeightImagesDecodeWithinTheirQuantum) {
  ProductMaker& m = maker("hills-river");
  const TileAddress a{2, 1, 2};
  const HeightTile tile = tile_or_die(m, TileScheme::local, a, TileFormat::gray16);
  // decode_heightfield gives the first channel normalised to [0, 1]: the gray16 code / 65535.
  const Raster grey = decode_png(make_or_die(m, TileScheme::local, a, TileFormat::gray16));
  ASSERT_EQ(grey.width, 256);
  const Gray16Encoding g = m.constants().gray16;
  for (std::size_t i = 0; i < tile.elevation.size(); i += 97) {
    const double v = std::round(grey.samples[i] * 65535.0);
    EXPECT_NEAR(g.offset + g.scale * v, tile.elevation[i], g.scale / 2 + 1e-6);
  }
  // terrain-RGB's red channel holds the top 8 bits of (h + 10000)·10.
  const Raster rgb = decode_png(make_or_die(m, TileScheme::local, a, TileFormat::terrain_rgb));
  for (std::size_t i = 0; i < tile.elevation.size(); i += 97) {
    const double code = std::round((tile.elevation[i] + 10000.0) * 10.0);
    EXPECT_EQ(std::lround(rgb.samples[i] * 255.0), static_cast<long>(code) >> 16);
  }
}

TEST(TileProducts, GeoTiffHoldsTheExactHeights) {
  ProductMaker& m = maker("craters");
  const TileAddress a = geographic_origin_tile(m.source(), 12);
  const Product p = make_or_die(m, TileScheme::geographic, a, TileFormat::geotiff);
  const HeightTile tile = tile_or_die(m, TileScheme::geographic, a, TileFormat::geotiff);
  Result<Raster> r = decode_heightfield(p.bytes, "tif");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->samples, tile.elevation);
}

TEST(TileProducts, QuantizedMeshDecodesToTheGridHeights) {
  ProductMaker& m = maker("mountain-range");
  const TileAddress a = geographic_origin_tile(m.source(), 13);
  const HeightTile tile = tile_or_die(m, TileScheme::geographic, a, TileFormat::quantized_mesh);
  const QuantizedMesh qm =
      decode_qm(make_or_die(m, TileScheme::geographic, a, TileFormat::quantized_mesh));
  ASSERT_GT(qm.vertex_count(), 256u);       // at least the full-resolution boundary
  EXPECT_LT(qm.vertex_count(), 65u * 65u);  // and adaptive inside
  const double quantum = (qm.header.maximum_height - qm.header.minimum_height) / 32767.0;
  for (std::size_t k = 0; k < qm.vertex_count(); ++k) {
    const int col = static_cast<int>(std::lround(qm.u[k] / 32767.0 * 64));
    const int row = 64 - static_cast<int>(std::lround(qm.v[k] / 32767.0 * 64));
    const float h = tile.elevation[tile.index(col, row)];
    EXPECT_NEAR(qm.height_metres(k), h, std::max(quantum, m.constants().edge_quantum) / 2 + 1e-6);
  }
  ASSERT_TRUE(qm.normals.has_value());
  ASSERT_TRUE(qm.water_mask.has_value());
  ASSERT_TRUE(qm.metadata.has_value());
  EXPECT_NE(qm.metadata->find("available"), std::string::npos);
}

TEST(TileProducts, QuantizedMeshWaterMaskShowsTheLake) {
  ProductMaker& m = maker("lake-dunes");
  const TileAddress a = geographic_origin_tile(m.source(), 13);
  const QuantizedMesh qm =
      decode_qm(make_or_die(m, TileScheme::geographic, a, TileFormat::quantized_mesh));
  ASSERT_TRUE(qm.water_mask.has_value());
  ASSERT_EQ(qm.water_mask->size(), 65536u);
  const auto wet = std::count(qm.water_mask->begin(), qm.water_mask->end(), 255);
  EXPECT_GT(wet, 100);
  EXPECT_LT(wet, 65536 - 100);
}

// ---------------------------------------------------------------------------------------------
// Seams

TEST(TileSeams, TerrainRgbBorderIsTheNeighboursEdge) {
  ProductMaker& m = maker("winding-road");
  ProductOptions bordered;
  bordered.border = true;
  const Raster a =
      decode_png(make_or_die(m, TileScheme::local, {3, 3, 4}, TileFormat::terrain_rgb, bordered));
  const Raster b =
      decode_png(make_or_die(m, TileScheme::local, {3, 4, 4}, TileFormat::terrain_rgb));
  ASSERT_EQ(a.width, 258);
  for (int row = 0; row < 256; ++row) {
    ASSERT_EQ(a.at(257, row + 1), b.at(0, row)) << row;
  }
}

TEST(TileSeams, QuantizedMeshNeighboursDecodeIdenticalEdges) {
  ProductMaker& m = maker("mountain-range");
  const TileAddress a = geographic_origin_tile(m.source(), 13);
  const QuantizedMesh west =
      decode_qm(make_or_die(m, TileScheme::geographic, a, TileFormat::quantized_mesh));
  const QuantizedMesh east = decode_qm(
      make_or_die(m, TileScheme::geographic, {a.z, a.x + 1, a.y}, TileFormat::quantized_mesh));
  const QuantizedMesh north = decode_qm(
      make_or_die(m, TileScheme::geographic, {a.z, a.x, a.y + 1}, TileFormat::quantized_mesh));
  auto edge = [](const QuantizedMesh& q, const std::vector<std::uint32_t>& list, bool along_v) {
    std::map<int, std::pair<double, std::uint16_t>> out;  // position → (height, oct normal)
    for (std::uint32_t k : list) {
      const std::uint16_t normal =
          static_cast<std::uint16_t>(((*q.normals)[2 * k] << 8) | (*q.normals)[2 * k + 1]);
      out[along_v ? q.v[k] : q.u[k]] = {q.height_metres(k), normal};
    }
    return out;
  };
  const auto we = edge(west, west.east, true), ew = edge(east, east.west, true);
  ASSERT_EQ(we.size(), 65u);
  EXPECT_EQ(we, ew);
  const auto wn = edge(west, west.north, false), ns = edge(north, north.south, false);
  ASSERT_EQ(wn.size(), 65u);
  EXPECT_EQ(wn, ns);
}

// ---------------------------------------------------------------------------------------------
// Reproducibility

TEST(TileReproducibility, EveryFormatGivesTheSameBytesFromAnotherGenerator) {
  ProductMaker other(source_of("butte"));
  ProductMaker& m = maker("butte");
  const TileAddress g = geographic_origin_tile(m.source(), 12);
  for (const TileFormatInfo& info : tile_formats()) {
    const TileScheme scheme =
        info.format == TileFormat::quantized_mesh ? TileScheme::geographic : TileScheme::local;
    const TileAddress a = scheme == TileScheme::geographic ? g : TileAddress{1, 1, 0};
    // The other generator first makes a neighbour, so its state differs.
    (void)make_or_die(other, scheme, {a.z, a.x ^ 1, a.y}, info.format);
    EXPECT_EQ(make_or_die(m, scheme, a, info.format).bytes,
              make_or_die(other, scheme, a, info.format).bytes)
        << info.extension << " " << info.encoding;
  }
}

TEST(TileReproducibility, TheCliInAnotherProcessWritesTheSameBytes) {
  ProductMaker& m = maker("lake-dunes");
  const fs::path out =
      fs::temp_directory_path() / ("terrain-cli-tile-" + std::to_string(::getpid()) + ".png");
  const std::string command = std::string(TERRAIN_CLI) + " tile " +
                              (kScenes / "lake-dunes.json").string() +
                              " 2 1 2 --encoding terrarium -o " + out.string() + " > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream in(out, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  fs::remove(out);
  EXPECT_EQ(bytes, make_or_die(m, TileScheme::local, {2, 1, 2}, TileFormat::terrarium).bytes);
}

// ---------------------------------------------------------------------------------------------
// Bad requests, refused before any work, naming the field

TEST(TileProductErrors, NameTheOffendingField) {
  ProductMaker& m = maker("craters");
  struct Case {
    TileScheme scheme;
    TileAddress address;
    TileFormat format;
    ProductOptions options;
    const char* pointer;
  };
  ProductOptions big_size, odd_grid, negative_error;
  big_size.size = 1024;
  odd_grid.grid = 64;
  negative_error.max_error = -1.0;
  const Case cases[] = {
      {TileScheme::local, {-1, 0, 0}, TileFormat::terrain_rgb, {}, "/z"},
      {TileScheme::webmercator, {25, 0, 0}, TileFormat::terrain_rgb, {}, "/z"},
      {TileScheme::local, {3, 8, 0}, TileFormat::glb, {}, "/x"},
      {TileScheme::local, {3, -1, 0}, TileFormat::draco, {}, "/x"},
      {TileScheme::geographic, {3, 0, 8}, TileFormat::quantized_mesh, {}, "/y"},
      {TileScheme::local, {0, 0, 0}, TileFormat::quantized_mesh, {}, "/scheme"},
      {TileScheme::local, {0, 0, 0}, TileFormat::terrain_rgb, big_size, "/size"},
      {TileScheme::local, {0, 0, 0}, TileFormat::glb, odd_grid, "/grid"},
      {TileScheme::local, {0, 0, 0}, TileFormat::glb, negative_error, "/max_error"},
  };
  for (const Case& c : cases) {
    Result<Product> p = m.make(c.scheme, c.address, c.format, c.options);
    ASSERT_FALSE(p.ok()) << c.pointer;
    EXPECT_EQ(p.error().pointer, c.pointer) << p.error().message;
    EXPECT_EQ(p.error().kind, ErrorKind::invalid) << c.pointer;  // the caller's to mend: a 400
  }
  EXPECT_EQ(parse_tile_format("webp").error().pointer, "/format");
  EXPECT_EQ(parse_tile_format("webp").error().kind, ErrorKind::not_found);  // no such resource
  EXPECT_EQ(parse_tile_format("png", "rainbow").error().kind, ErrorKind::invalid);
  EXPECT_EQ(parse_tile_format("png", "rainbow").error().pointer, "/encoding");
  EXPECT_EQ(parse_tile_format("glb", "terrarium").error().pointer, "/encoding");
  EXPECT_EQ(*parse_tile_format("png"), TileFormat::terrain_rgb);
  EXPECT_EQ(*parse_tile_format("png", "hillshade"), TileFormat::hillshade);
}

// glTF and Draco tiles snap to the scene's position lattice: the deepest zoom whose samples are a
// quantum apart is served, the next one refused naming the zoom (it was a 500: two vertices
// merged), and a smaller grid there is served again.
TEST(TileProductErrors, MeshesFinerThanThePositionLatticeAreRefusedNamingTheZoom) {
  ProductMaker& m = maker("butte");
  const double q = m.constants().position_quantum;
  const int deepest_scheme_zoom = max_zoom(TileScheme::local);
  int deepest = 0;
  while (deepest < deepest_scheme_zoom &&
         ground_spacing(m.source(), TileScheme::local, deepest + 1, 64) >= q) {
    ++deepest;
  }
  ASSERT_LT(deepest, deepest_scheme_zoom) << "the lattice binds at no zoom of the local scheme";
  ProductOptions coarser;
  coarser.grid = 33;
  for (const TileFormat format : {TileFormat::glb, TileFormat::draco}) {
    const Result<Product> served = m.make(TileScheme::local, {deepest, 0, 0}, format);
    EXPECT_TRUE(served.ok()) << served.error().message;
    const Result<Product> deeper = m.make(TileScheme::local, {deepest + 1, 0, 0}, format);
    ASSERT_FALSE(deeper.ok());
    EXPECT_EQ(deeper.error().pointer, "/z") << deeper.error().message;
    EXPECT_EQ(deeper.error().kind, ErrorKind::invalid);
    const Result<Product> smaller = m.make(TileScheme::local, {deepest + 1, 0, 0}, format, coarser);
    EXPECT_TRUE(smaller.ok()) << smaller.error().message;
  }
  // Height images have no lattice.
  EXPECT_TRUE(m.make(TileScheme::local, {deepest + 1, 0, 0}, TileFormat::terrain_rgb).ok());
}

// A small scene's lattice spans 2^23 quanta of 7.8 mm, 65 km: the Web Mercator and geographic
// tiles of coarse zooms, projected into the scene's frame, are wider, and are refused naming the
// zoom (they were a 500); the tiles over the scene at its deepest useful zoom are served.
TEST(TileProductErrors, MeshesWiderThanThePositionLatticeAreRefusedNamingTheZoom) {
  ProductMaker& m = maker("butte");
  for (const TileScheme scheme : {TileScheme::webmercator, TileScheme::geographic}) {
    for (const int z : {0, m.constants().max_useful_zoom[static_cast<int>(scheme)]}) {
      const TileRange over = tiles_covering_area(m.source(), scheme, z);
      const Result<Product> p = m.make(scheme, {z, over.min_x, over.min_y}, TileFormat::glb);
      if (z == 0) {
        ASSERT_FALSE(p.ok());
        EXPECT_EQ(p.error().pointer, "/z") << p.error().message;
        EXPECT_EQ(p.error().kind, ErrorKind::invalid);
      } else {
        EXPECT_TRUE(p.ok()) << "zoom " << z << ": " << p.error().message;
      }
    }
  }
}

// The loosest mesh a request may ask for (max_error 1e6 m) wants skirts five times that deep,
// more than a tile's 2^23 quanta: they are shortened to fit, not refused (that was a 500).
TEST(TileProducts, MeshesAtTheLargestMaxErrorAreMade) {
  ProductMaker& m = maker("craters");
  ProductOptions loosest;
  loosest.max_error = 1e6;
  for (const TileFormat format : {TileFormat::glb, TileFormat::draco}) {
    const Result<Product> p = m.make(TileScheme::local, {0, 0, 0}, format, loosest);
    EXPECT_TRUE(p.ok()) << p.error().message;
  }
}

TEST(LayerJson, ListsTheRootsAndTheScenesTiles) {
  ProductMaker& m = maker("hills-river");
  const nlohmann::json layer = m.layer_json({});
  EXPECT_EQ(layer["format"], "quantized-mesh-1.0");
  EXPECT_EQ(layer["scheme"], "tms");
  const auto& available = layer["available"];
  ASSERT_GE(available.size(), 14u);
  EXPECT_EQ(available[0][0]["endX"], 1);
  const TileAddress a = geographic_origin_tile(m.source(), 13);
  const auto& r = available[13][0];
  EXPECT_LE(r["startX"].get<std::int64_t>(), a.x);
  EXPECT_GE(r["endX"].get<std::int64_t>(), a.x);
  EXPECT_LE(r["startY"].get<std::int64_t>(), a.y);
  EXPECT_GE(r["endY"].get<std::int64_t>(), a.y);
}

// The quantized-mesh/layer.json contract with metadataAvailability n: a tile at level k·n lists,
// in its metadata, the available tiles of its own subtree for the next n levels; those lists
// agree with layer.json's `available` cut to the tile.
TEST(LayerJson, AvailabilityTilesAgreeWithLayerJson) {
  ProductMaker& m = maker("hills-river");
  const nlohmann::json layer = m.layer_json({});
  ASSERT_EQ(layer["metadataAvailability"], kMetadataAvailabilityLevels);
  const auto& available = layer["available"];
  for (const TileAddress a : {TileAddress{0, 0, 0}, TileAddress{0, 1, 0},
                              geographic_origin_tile(m.source(), kMetadataAvailabilityLevels)}) {
    const QuantizedMesh qm =
        decode_qm(make_or_die(m, TileScheme::geographic, a, TileFormat::quantized_mesh));
    ASSERT_TRUE(qm.metadata.has_value());
    const nlohmann::json listed = nlohmann::json::parse(*qm.metadata)["available"];
    // The next n levels, or as many as there are below the tile.
    const int below = std::min(kMetadataAvailabilityLevels, layer["maxzoom"].get<int>() - a.z);
    ASSERT_EQ(listed.size(), static_cast<std::size_t>(below));
    for (int k = 1; k <= below; ++k) {
      // The layer's rectangle at level z + k, cut to the tile's descendants.
      const auto& whole = available[static_cast<std::size_t>(a.z + k)][0];
      const std::int64_t x0 = std::max<std::int64_t>(whole["startX"].get<std::int64_t>(), a.x << k);
      const std::int64_t y0 = std::max<std::int64_t>(whole["startY"].get<std::int64_t>(), a.y << k);
      const std::int64_t x1 =
          std::min<std::int64_t>(whole["endX"].get<std::int64_t>(), ((a.x + 1) << k) - 1);
      const std::int64_t y1 =
          std::min<std::int64_t>(whole["endY"].get<std::int64_t>(), ((a.y + 1) << k) - 1);
      const auto& level = listed[static_cast<std::size_t>(k - 1)];
      if (x0 > x1 || y0 > y1) {
        EXPECT_TRUE(level.empty()) << a.z << "/" << a.x << "/" << a.y << " level +" << k;
        continue;
      }
      ASSERT_EQ(level.size(), 1u);
      EXPECT_EQ(level[0],
                (nlohmann::json{{"startX", x0}, {"startY", y0}, {"endX", x1}, {"endY", y1}}))
          << a.z << "/" << a.x << "/" << a.y << " level +" << k;
    }
  }
}

}  // namespace
}  // namespace terrain
