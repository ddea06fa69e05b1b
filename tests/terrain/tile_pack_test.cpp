// Offline packs (terrain/tile_pack.hpp): MBTiles and PMTiles hold exactly the server's bytes,
// the PMTiles structures follow the v3 specification, output is independent of the thread
// count, interrupted exports resume to the same result, and bad requests are refused early.
#include "terrain/tile_pack.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "example_tile_sources.hpp"
#include "terrain/scene.hpp"

namespace terrain {
namespace {

namespace fs = std::filesystem;

std::vector<std::uint8_t> file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("tile-pack-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
             "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::size_t entries() const {
    return static_cast<std::size_t>(std::distance(fs::directory_iterator(path_), {}));
  }

 private:
  fs::path path_;
};

// A scene's tiles of a few zooms where it covers a handful of tiles.
PackPlan scene_plan(const TileSource& source, TileScheme scheme, TileFormat format, int z0,
                    int z1) {
  PackArea area;
  area.scheme = scheme;
  area.min_zoom = z0;
  area.max_zoom = z1;
  area.max_useful_zoom = 24;
  area.default_range = [&](int z) { return tiles_covering_area(source, scheme, z); };
  PackPlan plan;
  plan.scheme = scheme;
  plan.format = format;
  plan.zooms = plan_zoom_ranges(area).value();
  plan.bounds = range_bounds_degrees(scheme, z1, plan.zooms.back().range);
  plan.name = "test";
  plan.source_id = source.terrain->scene_hash;
  return plan;
}

MakeTileFactory product_factory(const TileSource& source, TileScheme scheme, TileFormat format) {
  return [&source, scheme, format]() -> MakeTile {
    auto maker = std::make_shared<ProductMaker>(source);
    return [maker, scheme, format](const TileAddress& a) -> Result<std::vector<std::uint8_t>> {
      Result<Product> product = maker->make(scheme, a, format);
      if (!product) return product.error();
      return std::move(product->bytes);
    };
  };
}

// Synthetic tiles, cheap enough for large plans: most are one shared "ocean" tile; every
// `unique_every`-th (by x) is its own content of an address-dependent length.
MakeTileFactory synthetic_factory(int unique_every) {
  return [unique_every]() -> MakeTile {
    return [unique_every](const TileAddress& a) -> Result<std::vector<std::uint8_t>> {
      if (a.x % unique_every != 0) return std::vector<std::uint8_t>{'o', 'c', 'e', 'a', 'n'};
      const std::string text =
          std::to_string(a.z) + "/" + std::to_string(a.x) + "/" + std::to_string(a.y) +
          std::string(static_cast<std::size_t>((a.x * 7 + a.y * 13) % 97), '.');
      return std::vector<std::uint8_t>(text.begin(), text.end());
    };
  };
}

PackPlan world_plan(int z0, int z1, TileScheme scheme = TileScheme::webmercator) {
  PackArea area;
  area.scheme = scheme;
  area.min_zoom = z0;
  area.max_zoom = z1;
  area.max_useful_zoom = 20;
  PackPlan plan;
  plan.scheme = scheme;
  plan.zooms = plan_zoom_ranges(area).value();
  plan.bounds = {-180, -kWebMercatorMaxLatitude, 180, kWebMercatorMaxLatitude};
  plan.name = "world";
  plan.source_id = "synthetic";
  return plan;
}

TEST(PmtilesTileId, FollowsTheHilbertCurveOfEachZoom) {
  EXPECT_EQ(pmtiles_tile_id(0, 0, 0), 0u);
  EXPECT_EQ(pmtiles_tile_id(1, 0, 0), 1u);
  EXPECT_EQ(pmtiles_tile_id(1, 0, 1), 2u);
  EXPECT_EQ(pmtiles_tile_id(1, 1, 1), 3u);
  EXPECT_EQ(pmtiles_tile_id(1, 1, 0), 4u);
  EXPECT_EQ(pmtiles_tile_id(2, 0, 0), 5u);
  EXPECT_EQ(pmtiles_tile_id(3, 0, 0), 21u);
  EXPECT_EQ(pmtiles_tile_id(3, 7, 0), 21u + 63u);  // the curve ends at the top right
  EXPECT_EQ(pmtiles_tile_id(12, 0, 0), 5592405u);
  // Every id of zooms 0..5 maps back to its address, and consecutive ids are neighbours.
  for (std::uint64_t id = 0; id < pmtiles_tile_id(6, 0, 0); ++id) {
    const TileAddress a = pmtiles_tile_address(id);
    ASSERT_EQ(
        pmtiles_tile_id(a.z, static_cast<std::uint64_t>(a.x), static_cast<std::uint64_t>(a.y)), id);
    const TileAddress b = pmtiles_tile_address(id + 1);
    if (b.z == a.z) {
      ASSERT_EQ(std::abs(a.x - b.x) + std::abs(a.y - b.y), 1) << id;
    }
  }
  const TileAddress deep = pmtiles_tile_address(pmtiles_tile_id(24, 12345678, 8765432));
  EXPECT_EQ(deep.z, 24);
  EXPECT_EQ(deep.x, 12345678);
  EXPECT_EQ(deep.y, 8765432);
}

TEST(PmtilesDirectory, SerialisesColumnsOfVarintsAsTheSpecSays) {
  const std::vector<PmtilesEntry> entries{
      {0, 0, 10, 1}, {1, 10, 5, 2}, {5, 0, 10, 1}, {300, 15, 200, 1}};
  // count; id deltas; run lengths; lengths; offsets (0 = follows the previous, else +1).
  const std::vector<std::uint8_t> expected{4,  0, 1,  4,    0xa7, 0x02, 1, 2, 1, 1,
                                           10, 5, 10, 0xc8, 0x01, 1,    0, 1, 16};
  EXPECT_EQ(encode_pmtiles_directory(entries), expected);
  const auto back = decode_pmtiles_directory(expected).value();
  ASSERT_EQ(back.size(), entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    EXPECT_EQ(back[i].tile_id, entries[i].tile_id);
    EXPECT_EQ(back[i].offset, entries[i].offset);
    EXPECT_EQ(back[i].length, entries[i].length);
    EXPECT_EQ(back[i].run_length, entries[i].run_length);
  }
  EXPECT_FALSE(decode_pmtiles_directory(std::vector<std::uint8_t>{4, 0, 1}).ok());
  EXPECT_FALSE(decode_pmtiles_directory(std::vector<std::uint8_t>{0}).ok());
}

TEST(PmtilesHeader, PutsEachFieldAtItsSpecOffset) {
  PmtilesHeader h;
  h.root_offset = 127;
  h.root_length = 0x1234;
  h.data_offset = 0x0102030405060708;
  h.tile_type = 2;
  h.tile_compression = 1;
  h.internal_compression = 2;
  h.clustered = true;
  h.min_zoom = 3;
  h.max_zoom = 9;
  h.min_lon = -12.5;
  h.max_lat = 45.25;
  h.center_zoom = 3;
  const std::vector<std::uint8_t> bytes = encode_pmtiles_header(h);
  ASSERT_EQ(bytes.size(), 127u);
  EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + 7), "PMTiles");
  EXPECT_EQ(bytes[7], 3);
  EXPECT_EQ(bytes[8], 127);
  EXPECT_EQ(bytes[16], 0x34);
  EXPECT_EQ(bytes[17], 0x12);
  EXPECT_EQ(bytes[56], 0x08);
  EXPECT_EQ(bytes[63], 0x01);
  EXPECT_EQ(bytes[96], 1);
  EXPECT_EQ(bytes[97], 2);
  EXPECT_EQ(bytes[98], 1);
  EXPECT_EQ(bytes[99], 2);
  EXPECT_EQ(bytes[100], 3);
  EXPECT_EQ(bytes[101], 9);
  // -12.5° · 10^7 = -125000000 = 0xF88C_A6C0, little-endian.
  EXPECT_EQ(bytes[102], 0xc0);
  EXPECT_EQ(bytes[103], 0xa6);
  EXPECT_EQ(bytes[104], 0x8c);
  EXPECT_EQ(bytes[105], 0xf8);
  const PmtilesHeader back = decode_pmtiles_header(bytes).value();
  EXPECT_EQ(back.data_offset, h.data_offset);
  EXPECT_DOUBLE_EQ(back.min_lon, -12.5);
  EXPECT_DOUBLE_EQ(back.max_lat, 45.25);
  std::vector<std::uint8_t> v2 = bytes;
  v2[7] = 2;
  EXPECT_EQ(decode_pmtiles_header(v2).error().pointer, "/version");
  EXPECT_EQ(decode_pmtiles_header(std::vector<std::uint8_t>(127, 0)).error().pointer, "/magic");
}

TEST(PlanZoomRanges, ChoosesTheTilesCoveringTheBbox) {
  PackArea area;
  area.max_useful_zoom = 20;
  area.min_zoom = area.max_zoom = 1;
  area.bbox = TileBounds{0.1, 0.1, 10, 10};
  auto zooms = plan_zoom_ranges(area).value();
  ASSERT_EQ(zooms.size(), 1u);
  EXPECT_EQ(zooms[0].range.min_x, 1);
  EXPECT_EQ(zooms[0].range.max_x, 1);
  EXPECT_EQ(zooms[0].range.min_y, 0);  // XYZ: the northern half
  EXPECT_EQ(zooms[0].range.max_y, 0);
  area.scheme = TileScheme::geographic;
  area.bbox = TileBounds{10, 10, 20, 20};
  zooms = plan_zoom_ranges(area).value();
  EXPECT_EQ(zooms[0].range.min_x, 2);  // four columns of 90°
  EXPECT_EQ(zooms[0].range.max_x, 2);
  EXPECT_EQ(zooms[0].range.min_y, 1);  // TMS: the northern row
  EXPECT_EQ(zooms[0].range.max_y, 1);
  area.min_zoom = 0;
  area.max_zoom = 3;
  area.bbox.reset();
  EXPECT_EQ(plan_zoom_ranges(area).value().back().count(), 16u * 8u);
  const TileBounds b = range_bounds_degrees(TileScheme::webmercator, 0, {0, 0, 0, 0});
  EXPECT_NEAR(b.north, kWebMercatorMaxLatitude, 1e-9);
  EXPECT_DOUBLE_EQ(b.west, -180.0);
}

TEST(PlanZoomRanges, RefusesBadRangesNamingTheOption) {
  PackArea area;
  area.max_useful_zoom = 14;
  area.min_zoom = 5;
  area.max_zoom = 4;
  EXPECT_EQ(plan_zoom_ranges(area).error().pointer, "/zoom");
  area.min_zoom = 0;
  area.max_zoom = 15;
  EXPECT_EQ(plan_zoom_ranges(area).error().pointer, "/zoom");
  area.max_zoom = 3;
  for (const TileBounds& bad : {TileBounds{-181, 0, 10, 10}, TileBounds{0, 0, 10, 86},
                                TileBounds{10, 0, 10, 5}, TileBounds{0, 5, 10, 5}}) {
    area.bbox = bad;
    EXPECT_EQ(plan_zoom_ranges(area).error().pointer, "/bbox");
  }
  area.scheme = TileScheme::geographic;
  area.bbox = TileBounds{0, 0, 10, 86};  // fine on the geographic scheme
  EXPECT_TRUE(plan_zoom_ranges(area).ok());
  area.bbox.reset();
  area.max_zoom = 12;
  area.max_tiles = 1000;
  const Error e = plan_zoom_ranges(area).error();
  EXPECT_EQ(e.pointer, "/max_tiles");
  EXPECT_NE(e.message.find("1000"), std::string::npos);
}

TEST(MbtilesPack, HoldsTheServersBytesAtTmsRows) {
  const TileSource source = testing::example_source("mountain-range");
  const PackPlan plan = scene_plan(source, TileScheme::webmercator, TileFormat::terrain_rgb, 9, 11);
  ASSERT_GT(plan.tile_count(), 2u);
  ASSERT_LT(plan.tile_count(), 40u);
  TempDir dir;
  const std::string path = dir.file("pack.mbtiles");
  PackOptions options;
  options.threads = 2;
  const PackReport report =
      write_pack(path, plan, product_factory(source, plan.scheme, plan.format), options).value();
  EXPECT_EQ(report.tiles, plan.tile_count());
  EXPECT_EQ(report.made, plan.tile_count());
  ProductMaker maker(source);
  for (const ZoomRange& zoom : plan.zooms) {
    for (std::int64_t y = zoom.range.min_y; y <= zoom.range.max_y; ++y) {
      for (std::int64_t x = zoom.range.min_x; x <= zoom.range.max_x; ++x) {
        const auto stored =
            read_mbtiles_tile(path, zoom.z, x, (std::int64_t{1} << zoom.z) - 1 - y).value();
        ASSERT_TRUE(stored.has_value()) << zoom.z << "/" << x << "/" << y;
        EXPECT_EQ(*stored, maker.make(plan.scheme, {zoom.z, x, y}, plan.format)->bytes);
      }
    }
  }
  const nlohmann::json metadata = read_mbtiles_metadata(path).value();
  EXPECT_EQ(metadata["format"], "png");
  EXPECT_EQ(metadata["minzoom"], "9");
  EXPECT_EQ(metadata["maxzoom"], "11");
  EXPECT_EQ(metadata["name"], "test");
  EXPECT_EQ(metadata["crs"], "EPSG:3857");
  EXPECT_EQ(metadata["terrain_export_state"], "complete");
  const std::string bounds = metadata["bounds"].get<std::string>();
  EXPECT_EQ(std::count(bounds.begin(), bounds.end(), ','), 3) << bounds;
}

TEST(PmtilesPack, HoldsTheServersBytesAndASpecConformingLayout) {
  const TileSource source = testing::example_source("mountain-range");
  const PackPlan plan = scene_plan(source, TileScheme::webmercator, TileFormat::terrarium, 9, 11);
  TempDir dir;
  const std::string path = dir.file("pack.pmtiles");
  write_pack(path, plan, product_factory(source, plan.scheme, plan.format)).value();
  EXPECT_EQ(dir.entries(), 1u) << "the scratch files are gone";
  const PmtilesReader reader = PmtilesReader::open(path).value();
  const PmtilesHeader& h = reader.header();
  EXPECT_EQ(h.root_offset, 127u);
  EXPECT_LE(h.root_offset + h.root_length, 16384u);
  EXPECT_EQ(h.metadata_offset, h.root_offset + h.root_length);
  EXPECT_EQ(h.leaves_offset, h.metadata_offset + h.metadata_length);
  EXPECT_EQ(h.data_offset, h.leaves_offset + h.leaves_length);
  EXPECT_EQ(h.data_offset + h.data_length, fs::file_size(path));
  EXPECT_EQ(h.tile_type, 2);         // png
  EXPECT_EQ(h.tile_compression, 1);  // none
  EXPECT_EQ(h.internal_compression, 2);
  EXPECT_TRUE(h.clustered);
  EXPECT_EQ(h.min_zoom, 9);
  EXPECT_EQ(h.max_zoom, 11);
  EXPECT_EQ(h.addressed_tiles, plan.tile_count());
  EXPECT_NEAR(h.min_lon, plan.bounds.west, 1e-7);
  EXPECT_NEAR(h.max_lat, plan.bounds.north, 1e-7);
  EXPECT_EQ(reader.metadata()["tile_scheme"], "webmercator");
  EXPECT_EQ(reader.metadata()["terrain_export"], plan.identity());
  const auto entries = reader.tile_entries().value();
  EXPECT_EQ(entries.size(), h.tile_entries);
  std::uint64_t addressed = 0;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    addressed += entries[i].run_length;
    if (i > 0) {
      EXPECT_GE(entries[i].tile_id, entries[i - 1].tile_id + entries[i - 1].run_length);
    }
  }
  EXPECT_EQ(addressed, plan.tile_count());
  ProductMaker maker(source);
  for (const ZoomRange& zoom : plan.zooms) {
    for (std::int64_t y = zoom.range.min_y; y <= zoom.range.max_y; ++y) {
      for (std::int64_t x = zoom.range.min_x; x <= zoom.range.max_x; ++x) {
        const auto stored =
            reader.tile(zoom.z, static_cast<std::uint64_t>(x), static_cast<std::uint64_t>(y))
                .value();
        ASSERT_TRUE(stored.has_value()) << zoom.z << "/" << x << "/" << y;
        EXPECT_EQ(*stored, maker.make(plan.scheme, {zoom.z, x, y}, plan.format)->bytes);
      }
    }
  }
  EXPECT_FALSE(reader.tile(8, 0, 0).value().has_value());
}

TEST(PmtilesPack, HoldsColourImageryAsJpegOrPngTiles) {
  const TileSource source = testing::example_source("lake-dunes");
  TempDir dir;
  for (const TileFormat format : {TileFormat::color_jpeg, TileFormat::color_png}) {
    const bool jpeg = format == TileFormat::color_jpeg;
    const PackPlan plan = scene_plan(source, TileScheme::webmercator, format, 12, 13);
    const std::string path = dir.file(jpeg ? "jpeg.pmtiles" : "png.pmtiles");
    write_pack(path, plan, product_factory(source, plan.scheme, plan.format)).value();
    const PmtilesReader reader = PmtilesReader::open(path).value();
    EXPECT_EQ(reader.header().tile_type, jpeg ? 3 : 2);
    EXPECT_EQ(reader.metadata()["format"], jpeg ? "jpg" : "png");
    EXPECT_EQ(reader.metadata()["encoding"], jpeg ? "color-jpg" : "color-png");
    const ZoomRange& zoom = plan.zooms.back();
    const TileAddress at{zoom.z, zoom.range.min_x, zoom.range.min_y};
    const auto stored =
        reader.tile(at.z, static_cast<std::uint64_t>(at.x), static_cast<std::uint64_t>(at.y))
            .value();
    ASSERT_TRUE(stored.has_value());
    EXPECT_EQ(*stored, ProductMaker(source).make(plan.scheme, at, format)->bytes);
  }
  // A pack of JPEG tiles is not resumed as PNG: the identities differ.
  EXPECT_NE(scene_plan(source, TileScheme::webmercator, TileFormat::color_jpeg, 12, 13).identity(),
            scene_plan(source, TileScheme::webmercator, TileFormat::color_png, 12, 13).identity());
}

TEST(PmtilesPack, StoresGeographicMeshesGzippedOneZoomDown) {
  const TileSource source = testing::example_source("hills-river");
  const PackPlan plan =
      scene_plan(source, TileScheme::geographic, TileFormat::quantized_mesh, 8, 10);
  ASSERT_LT(plan.tile_count(), 40u);
  TempDir dir;
  const auto factory = product_factory(source, plan.scheme, plan.format);
  write_pack(dir.file("mesh.pmtiles"), plan, factory).value();
  write_pack(dir.file("mesh.mbtiles"), plan, factory).value();
  const PmtilesReader reader = PmtilesReader::open(dir.file("mesh.pmtiles")).value();
  EXPECT_EQ(reader.header().tile_compression, 2);  // gzip, stored as served
  EXPECT_EQ(reader.header().tile_type, 0);
  EXPECT_EQ(reader.header().min_zoom, 9);
  EXPECT_EQ(reader.metadata()["minzoom"], 8);
  EXPECT_EQ(reader.metadata()["crs"], "EPSG:4326");
  ProductMaker maker(source);
  for (const ZoomRange& zoom : plan.zooms) {
    for (std::int64_t y = zoom.range.min_y; y <= zoom.range.max_y; ++y) {
      for (std::int64_t x = zoom.range.min_x; x <= zoom.range.max_x; ++x) {
        const Product served = maker.make(plan.scheme, {zoom.z, x, y}, plan.format).value();
        ASSERT_EQ(served.content_encoding, "gzip");
        const auto in_pm =
            reader.tile(zoom.z + 1, static_cast<std::uint64_t>(x), static_cast<std::uint64_t>(y))
                .value();
        ASSERT_TRUE(in_pm.has_value());
        EXPECT_EQ(*in_pm, served.bytes);
        const auto in_mb = read_mbtiles_tile(dir.file("mesh.mbtiles"), zoom.z, x, y).value();
        ASSERT_TRUE(in_mb.has_value());  // geographic rows are TMS already
        EXPECT_EQ(*in_mb, served.bytes);
      }
    }
  }
}

TEST(PmtilesPack, DeduplicatesAndUsesLeafDirectoriesWhenTheRootWouldNotFit) {
  // 87 381 tiles of which a third are distinct: the root alone would exceed 16 KiB.
  const PackPlan plan = world_plan(0, 8);
  TempDir dir;
  const std::string path = dir.file("world.pmtiles");
  PackOptions options;
  options.commit_every = 20000;
  const PackReport report = write_pack(path, plan, synthetic_factory(3), options).value();
  const PmtilesReader reader = PmtilesReader::open(path).value();
  const PmtilesHeader& h = reader.header();
  EXPECT_GT(h.leaves_length, 0u);
  EXPECT_LE(h.root_offset + h.root_length, 16384u);
  for (const PmtilesEntry& e : reader.root()) EXPECT_EQ(e.run_length, 0u) << "root: leaves only";
  EXPECT_EQ(h.addressed_tiles, plan.tile_count());
  EXPECT_LT(h.tile_entries, h.addressed_tiles) << "runs of ocean share an entry";
  EXPECT_EQ(h.tile_contents, report.unique_contents);
  // Distinct contents: the x ≡ 0 (mod 3) tiles, plus one ocean tile.
  std::uint64_t distinct = 1;
  for (const ZoomRange& zoom : plan.zooms) {
    distinct += static_cast<std::uint64_t>((zoom.range.max_x + 3) / 3) *
                static_cast<std::uint64_t>(zoom.range.max_y + 1);
  }
  EXPECT_EQ(h.tile_contents, distinct);
  const MakeTile make = synthetic_factory(3)();
  for (std::uint64_t id = 0; id < h.addressed_tiles; id += 97) {
    const TileAddress a = pmtiles_tile_address(id);
    const auto stored =
        reader.tile(a.z, static_cast<std::uint64_t>(a.x), static_cast<std::uint64_t>(a.y)).value();
    ASSERT_TRUE(stored.has_value()) << id;
    EXPECT_EQ(*stored, make(a).value()) << id;
  }
}

TEST(PmtilesPack, BytesDoNotDependOnTheThreadCount) {
  const TileSource source = testing::example_source("mountain-range");
  const PackPlan plan =
      scene_plan(source, TileScheme::webmercator, TileFormat::terrain_rgb, 10, 11);
  TempDir dir;
  const auto factory = product_factory(source, plan.scheme, plan.format);
  PackOptions one, three;
  three.threads = 3;
  write_pack(dir.file("one.pmtiles"), plan, factory, one).value();
  write_pack(dir.file("three.pmtiles"), plan, factory, three).value();
  EXPECT_EQ(file_bytes(dir.file("one.pmtiles")), file_bytes(dir.file("three.pmtiles")));
  // The synthetic world, where workers finish far out of order.
  const PackPlan world = world_plan(0, 6);
  write_pack(dir.file("w1.pmtiles"), world, synthetic_factory(2), one).value();
  write_pack(dir.file("w3.pmtiles"), world, synthetic_factory(2), three).value();
  EXPECT_EQ(file_bytes(dir.file("w1.pmtiles")), file_bytes(dir.file("w3.pmtiles")));
}

TEST(PmtilesPack, ResumesAnInterruptedExportToTheSameBytes) {
  const PackPlan plan = world_plan(0, 6);
  TempDir dir;
  write_pack(dir.file("whole.pmtiles"), plan, synthetic_factory(2)).value();
  PackOptions interrupted;
  interrupted.commit_every = 100;
  interrupted.commit_interval = std::chrono::hours(1);
  interrupted.stop_after = 1050;  // 1000 committed, 50 left in an abandoned transaction
  interrupted.threads = 2;
  const std::string path = dir.file("resumed.pmtiles");
  EXPECT_FALSE(write_pack(path, plan, synthetic_factory(2), interrupted).ok());
  EXPECT_FALSE(fs::exists(path));
  EXPECT_TRUE(fs::exists(path + ".partial"));
  const PackReport report = write_pack(path, plan, synthetic_factory(2)).value();
  EXPECT_EQ(report.resumed, 1000u);
  EXPECT_EQ(report.made, plan.tile_count() - 1000);
  EXPECT_EQ(file_bytes(path), file_bytes(dir.file("whole.pmtiles")));
  EXPECT_FALSE(fs::exists(path + ".partial"));
  // A finished pack is not made again.
  const PackReport again = write_pack(path, plan, synthetic_factory(2)).value();
  EXPECT_EQ(again.made, 0u);
  EXPECT_EQ(again.resumed, plan.tile_count());
}

TEST(MbtilesPack, ResumesAnInterruptedExportWithTheSameTiles) {
  const TileSource source = testing::example_source("mountain-range");
  const PackPlan plan = scene_plan(source, TileScheme::webmercator, TileFormat::terrain_rgb, 9, 11);
  TempDir dir;
  const auto factory = product_factory(source, plan.scheme, plan.format);
  PackOptions interrupted;
  interrupted.commit_every = 2;
  interrupted.commit_interval = std::chrono::hours(1);
  interrupted.stop_after = 3;
  const std::string path = dir.file("resumed.mbtiles");
  EXPECT_FALSE(write_pack(path, plan, factory, interrupted).ok());
  EXPECT_EQ(read_mbtiles_metadata(path).value()["terrain_export_state"], "incomplete");
  const PackReport report = write_pack(path, plan, factory).value();
  EXPECT_EQ(report.resumed, 2u);
  EXPECT_EQ(report.made, plan.tile_count() - 2);
  ProductMaker maker(source);
  for (const ZoomRange& zoom : plan.zooms) {
    for (std::int64_t y = zoom.range.min_y; y <= zoom.range.max_y; ++y) {
      for (std::int64_t x = zoom.range.min_x; x <= zoom.range.max_x; ++x) {
        const auto stored =
            read_mbtiles_tile(path, zoom.z, x, (std::int64_t{1} << zoom.z) - 1 - y).value();
        ASSERT_TRUE(stored.has_value());
        EXPECT_EQ(*stored, maker.make(plan.scheme, {zoom.z, x, y}, plan.format)->bytes);
      }
    }
  }
  EXPECT_EQ(read_mbtiles_metadata(path).value()["terrain_export_state"], "complete");
}

TEST(TilePack, StopsAtItsTileEvenInTheMiddleOfABatch) {
  // The synthetic tiles come far faster than SQLite commits, so the writer takes them in batches.
  const PackPlan plan = world_plan(0, 6);
  for (int attempt = 0; attempt < 5; ++attempt) {
    TempDir dir;
    PackOptions interrupted;
    interrupted.commit_every = 2;
    interrupted.commit_interval = std::chrono::hours(1);
    interrupted.stop_after = 3;
    const std::string path = dir.file("stopped.mbtiles");
    EXPECT_FALSE(write_pack(path, plan, synthetic_factory(2), interrupted).ok());
    const PackReport report = write_pack(path, plan, synthetic_factory(2)).value();
    EXPECT_EQ(report.resumed, 2u);
    EXPECT_EQ(report.made, plan.tile_count() - 2);
  }
}

TEST(TilePack, RefusesToResumeAPackMadeWithOtherParameters) {
  const PackPlan plan = world_plan(0, 3);
  PackPlan other = plan;
  other.source_id = "another scene";
  PackPlan deeper = world_plan(0, 4);
  TempDir dir;
  for (const std::string name : {"done.pmtiles", "done.mbtiles"}) {
    write_pack(dir.file(name), plan, synthetic_factory(2)).value();
    const auto before = file_bytes(dir.file(name));
    const Error e = write_pack(dir.file(name), other, synthetic_factory(2)).error();
    EXPECT_EQ(e.pointer, "/output");
    EXPECT_NE(e.message.find("source"), std::string::npos) << e.message;
    EXPECT_NE(
        write_pack(dir.file(name), deeper, synthetic_factory(2)).error().message.find("ranges"),
        std::string::npos);
    EXPECT_EQ(file_bytes(dir.file(name)), before);
  }
  PackOptions interrupted;
  interrupted.commit_every = 10;
  interrupted.stop_after = 10;
  EXPECT_FALSE(write_pack(dir.file("part.pmtiles"), plan, synthetic_factory(2), interrupted).ok());
  const Error e = write_pack(dir.file("part.pmtiles"), other, synthetic_factory(2)).error();
  EXPECT_NE(e.message.find("interrupted export"), std::string::npos) << e.message;
  // Files that are not packs are left alone.
  std::ofstream(dir.file("notes.mbtiles")) << "not a database";
  std::ofstream(dir.file("notes.pmtiles")) << "not an archive";
  EXPECT_FALSE(write_pack(dir.file("notes.mbtiles"), plan, synthetic_factory(2)).ok());
  EXPECT_FALSE(write_pack(dir.file("notes.pmtiles"), plan, synthetic_factory(2)).ok());
  EXPECT_EQ(file_bytes(dir.file("notes.pmtiles")).size(), 14u);
  EXPECT_FALSE(fs::exists(dir.file("notes.pmtiles.partial")));
}

TEST(TilePack, StopsAtATileErrorAndKeepsWhatWasMade) {
  const PackPlan plan = world_plan(0, 3);
  TempDir dir;
  const MakeTileFactory failing = [] {
    const MakeTile ok = synthetic_factory(2)();
    return MakeTile([ok](const TileAddress& a) -> Result<std::vector<std::uint8_t>> {
      if (a.z == 3 && a.x == 5 && a.y == 2) return Error{"no heights here", "/x"};
      return ok(a);
    });
  };
  const Error e = write_pack(dir.file("e.pmtiles"), plan, failing).error();
  EXPECT_NE(e.message.find("tile 3/5/2: no heights here"), std::string::npos) << e.message;
  const PackReport report = write_pack(dir.file("e.pmtiles"), plan, synthetic_factory(2)).value();
  EXPECT_GT(report.resumed, 0u);
  EXPECT_EQ(write_pack(dir.file("x.zip"), plan, failing).error().pointer, "/output");
  EXPECT_FALSE(fs::exists(dir.file("x.zip")));
}

}  // namespace
}  // namespace terrain
