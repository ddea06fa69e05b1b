// Tiling schemes and height tiles from scenes: addresses, sample positions, the geographic frame,
// seams between neighbours, levels of detail, the water mask.
#include <gtest/gtest.h>

#include <GeographicLib/LocalCartesian.hpp>

#include <cmath>
#include <filesystem>

#include "example_tile_sources.hpp"
#include "terrain/tile_source.hpp"

namespace terrain {
namespace {

TileSource source_of(const std::string& name) {
  return testing::example_source(name);
}

HeightTile tile_or_die(TileGenerator& generator, const TileRequest& request) {
  Result<HeightTile> tile = generator.height_tile(request);
  if (!tile) throw std::runtime_error(tile.error().pointer + ": " + tile.error().message);
  return std::move(tile).value();
}

// The tile that holds the scene's georeference point at zoom z.
TileAddress tile_at_origin(const TileSource& source, TileScheme scheme, int z) {
  const Georeference& g = source.georeference;
  const double cols = static_cast<double>(columns_at(scheme, z));
  const double rows = static_cast<double>(rows_at(scheme, z));
  if (scheme == TileScheme::geographic) {
    return {z, static_cast<std::int64_t>((g.longitude + 180.0) / 360.0 * cols),
            static_cast<std::int64_t>((g.latitude + 90.0) / 180.0 * rows)};
  }
  if (scheme == TileScheme::webmercator) {
    const double lat = g.latitude * M_PI / 180.0;
    const double fy = (1.0 - std::asinh(std::tan(lat)) / M_PI) / 2.0;
    return {z, static_cast<std::int64_t>((g.longitude + 180.0) / 360.0 * cols),
            static_cast<std::int64_t>(fy * rows)};
  }
  const TileBounds& sq = source.local_square;
  return {z, static_cast<std::int64_t>(-sq.west / (sq.east - sq.west) * cols),
          static_cast<std::int64_t>(sq.north / (sq.north - sq.south) * rows)};
}

// ---------------------------------------------------------------------------------------------
// Addresses

TEST(TileAddress, GeographicHasTwoRootTiles) {
  EXPECT_EQ(columns_at(TileScheme::geographic, 0), 2);
  EXPECT_EQ(rows_at(TileScheme::geographic, 0), 1);
  EXPECT_TRUE(validate_address(TileScheme::geographic, {0, 1, 0}).ok());
  EXPECT_FALSE(validate_address(TileScheme::webmercator, {0, 1, 0}).ok());
}

TEST(TileAddress, ParsesSchemeNames) {
  for (TileScheme s : {TileScheme::local, TileScheme::webmercator, TileScheme::geographic}) {
    Result<TileScheme> parsed = parse_scheme(scheme_name(s));
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, s);
  }
}

// Malformed addresses and requests, each refused naming its field.
TEST(TileAddressErrors, NamesTheOffendingField) {
  struct Case {
    TileScheme scheme;
    TileAddress address;
    const char* pointer;
  };
  const Case cases[] = {
      {TileScheme::local, {-1, 0, 0}, "/z"},
      {TileScheme::local, {25, 0, 0}, "/z"},
      {TileScheme::geographic, {24, 0, 0}, "/z"},
      {TileScheme::webmercator, {3, -1, 0}, "/x"},
      {TileScheme::webmercator, {3, 8, 0}, "/x"},
      {TileScheme::geographic, {3, 16, 0}, "/x"},
      {TileScheme::geographic, {3, 0, 8}, "/y"},
      {TileScheme::local, {0, 0, -5}, "/y"},
      {TileScheme::local, {2, 0, std::int64_t{1} << 40}, "/y"},
  };
  for (const Case& c : cases) {
    Status s = validate_address(c.scheme, c.address);
    ASSERT_FALSE(s.ok()) << c.address.z << "/" << c.address.x << "/" << c.address.y;
    EXPECT_EQ(s.error().pointer, c.pointer);
  }
  EXPECT_FALSE(parse_scheme("mercator").ok());
  EXPECT_EQ(validate_request({TileScheme::local, {0, 0, 0}, SampleLayout::cell_centres, 300, 0})
                .error()
                .pointer,
            "/size");
  EXPECT_EQ(validate_request({TileScheme::local, {0, 0, 0}, SampleLayout::cell_centres, 256, 2})
                .error()
                .pointer,
            "/border");
  EXPECT_EQ(validate_request({TileScheme::local, {0, 0, 0}, SampleLayout::cell_corners, 100, 0})
                .error()
                .pointer,
            "/grid");
  EXPECT_EQ(validate_request({TileScheme::local, {0, 0, 0}, SampleLayout::cell_corners, 64, 1})
                .error()
                .pointer,
            "/border");
}

// ---------------------------------------------------------------------------------------------
// The geographic frame

TEST(GeoFrame, MatchesGeographicLibLocalCartesian) {
  const Georeference g{45.92, 6.87, 0.0};
  GeoFrame frame(g);
  GeographicLib::LocalCartesian local(g.latitude, g.longitude, 0.0);
  for (double dlat : {-0.05, 0.0, 0.013, 0.04}) {
    for (double dlon : {-0.06, 0.0, 0.021, 0.05}) {
      double x = 0, y = 0, e = 0, n = 0, u = 0;
      ASSERT_TRUE(frame.to_scene(g.latitude + dlat, g.longitude + dlon, x, y));
      local.Forward(g.latitude + dlat, g.longitude + dlon, 0.0, e, n, u);
      EXPECT_NEAR(x, e, 1e-3);
      EXPECT_NEAR(y, n, 1e-3);
    }
  }
}

TEST(GeoFrame, HeadingTurnsSceneAxesClockwiseFromNorth) {
  GeoFrame north_up({10.0, 20.0, 0.0});
  GeoFrame turned({10.0, 20.0, 90.0});  // scene +y points east
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  ASSERT_TRUE(north_up.to_scene(10.0, 20.01, x0, y0));  // a point to the east
  ASSERT_TRUE(turned.to_scene(10.0, 20.01, x1, y1));
  EXPECT_GT(x0, 1000.0);
  EXPECT_NEAR(y1, x0, 1e-6);
  EXPECT_NEAR(x1, -y0, 1e-6);
  float east = 0, north = 0;
  turned.scene_to_east_north(0.0f, 1.0f, east, north);  // slope along scene +y = east
  EXPECT_NEAR(east, 1.0f, 1e-6f);
  EXPECT_NEAR(north, 0.0f, 1e-6f);
}

TEST(GeoFrame, InverseRoundTrips) {
  GeoFrame frame({-33.9, 151.2, 30.0});
  for (double x : {-20000.0, 0.0, 5000.0}) {
    for (double y : {-7000.0, 0.0, 15000.0}) {
      double lat = 0, lon = 0, bx = 0, by = 0;
      frame.to_geographic(x, y, lat, lon);
      ASSERT_TRUE(frame.to_scene(lat, lon, bx, by));
      EXPECT_NEAR(bx, x, 1e-3);
      EXPECT_NEAR(by, y, 1e-3);
    }
  }
}

TEST(GeoFrame, RefusesTheFarSideOfTheGlobe) {
  GeoFrame frame({0.0, 0.0, 0.0});
  double x = 0, y = 0;
  EXPECT_TRUE(frame.to_scene(0.0, 59.0, x, y));
  EXPECT_FALSE(frame.to_scene(0.0, 120.0, x, y));
  EXPECT_FALSE(frame.to_scene(0.0, 180.0, x, y));
}

// ---------------------------------------------------------------------------------------------
// Height tiles

TEST(HeightTile, LocalRootTileCoversTheSceneSquareNorthUp) {
  TileGenerator generator(source_of("hills-river"));
  const HeightTile tile = tile_or_die(generator, {TileScheme::local, {0, 0, 0}});
  EXPECT_EQ(tile.width, 256);
  EXPECT_DOUBLE_EQ(tile.bounds.west, -3000.0);
  EXPECT_DOUBLE_EQ(tile.bounds.north, 3000.0);
  const double step = 6000.0 / 256.0;
  EXPECT_DOUBLE_EQ(tile.scene_x[tile.index(0, 0)], -3000.0 + 0.5 * step);
  EXPECT_DOUBLE_EQ(tile.scene_y[tile.index(0, 0)], 3000.0 - 0.5 * step);  // row 0 is north
  EXPECT_DOUBLE_EQ(tile.ground_spacing, step);
}

TEST(HeightTile, HeightsAreTheProgramsAtTheTilesSpacing) {
  TileSource source = source_of("hills-river");
  Evaluator reference(*source.terrain);
  TileGenerator generator(source);
  const HeightTile tile = tile_or_die(generator, {TileScheme::local, {3, 2, 5}});
  for (int row = 0; row < tile.height; row += 37) {
    for (int col = 0; col < tile.width; col += 29) {
      const std::size_t at = tile.index(col, row);
      const FieldSample s = reference.sample(
          {static_cast<float>(tile.scene_x[at]), static_cast<float>(tile.scene_y[at])},
          static_cast<float>(tile.ground_spacing));
      EXPECT_NEAR(tile.elevation[at], s.elevation, 1e-4f * (1.0f + std::abs(s.elevation)));
      EXPECT_NEAR(tile.slope_east[at], s.elevation_gradient.x, 1e-4f);
      EXPECT_NEAR(tile.slope_north[at], s.elevation_gradient.y, 1e-4f);
    }
  }
}

TEST(HeightTile, CoarserZoomDropsDetail) {
  // The LoD follows the spacing: a zoom-0 tile of a whole scene is smoother (smaller slopes)
  // than the full-detail surface at the same points.
  TileSource source = source_of("mountain-range");
  Evaluator reference(*source.terrain);
  TileGenerator generator(source);
  const HeightTile tile =
      tile_or_die(generator, {TileScheme::local, {0, 0, 0}, SampleLayout::cell_centres, 64});
  double coarse = 0, fine = 0;
  for (std::size_t i = 0; i < tile.elevation.size(); ++i) {
    const FieldSample s = reference.sample(
        {static_cast<float>(tile.scene_x[i]), static_cast<float>(tile.scene_y[i])}, 0.0f);
    coarse += std::hypot(tile.slope_east[i], tile.slope_north[i]);
    fine += length(s.elevation_gradient);
  }
  EXPECT_LT(coarse, 0.9 * fine);
}

// Neighbours share samples: with a border, a tile's outer ring is its neighbours' outermost
// samples; with corner samples, the edges themselves are shared.
void expect_shared(const HeightTile& a, int ca, int ra, const HeightTile& b, int cb, int rb) {
  const std::size_t i = a.index(ca, ra), j = b.index(cb, rb);
  ASSERT_EQ(a.scene_x[i], b.scene_x[j]);
  ASSERT_EQ(a.scene_y[i], b.scene_y[j]);
  ASSERT_EQ(a.elevation[i], b.elevation[j]) << ca << "," << ra;
  ASSERT_EQ(a.slope_east[i], b.slope_east[j]);
  ASSERT_EQ(a.slope_north[i], b.slope_north[j]);
}

class SeamsInScheme : public ::testing::TestWithParam<TileScheme> {};

TEST_P(SeamsInScheme, BorderSamplesAreTheNeighboursOwnBitForBit) {
  const TileScheme scheme = GetParam();
  TileSource source = source_of("mountain-range");
  TileGenerator generator(source);
  const int z = scheme == TileScheme::local ? 3 : 14;
  const TileAddress c = tile_at_origin(source, scheme, z);
  const TileAddress east{z, c.x + 1, c.y};
  // The neighbour whose samples lie north: XYZ rows grow south, TMS rows grow north.
  const TileAddress north{z, c.x, scheme == TileScheme::geographic ? c.y + 1 : c.y - 1};
  const TileRequest bordered{scheme, c, SampleLayout::cell_centres, 256, 1};
  const HeightTile centre = tile_or_die(generator, bordered);
  const HeightTile e = tile_or_die(generator, {scheme, east, SampleLayout::cell_centres, 256, 0});
  const HeightTile n = tile_or_die(generator, {scheme, north, SampleLayout::cell_centres, 256, 0});
  EXPECT_GT(centre.elevation.size(), 0u);
  for (int k = 0; k < 256; ++k) {
    expect_shared(centre, 257, k + 1, e, 0, k);  // east border column = east tile's column 0
    expect_shared(centre, k + 1, 0, n, k, 255);  // north border row = north tile's last row
  }
}

TEST_P(SeamsInScheme, CornerGridsShareTheirEdgesBitForBit) {
  const TileScheme scheme = GetParam();
  TileSource source = source_of("winding-road");
  TileGenerator generator(source);
  const int z = scheme == TileScheme::local ? 2 : 13;
  const TileAddress c = tile_at_origin(source, scheme, z);
  const TileAddress south{z, c.x, scheme == TileScheme::geographic ? c.y - 1 : c.y + 1};
  const TileRequest corners{scheme, c, SampleLayout::cell_corners, 64, 0};
  const HeightTile a = tile_or_die(generator, corners);
  const HeightTile b =
      tile_or_die(generator, {scheme, {z, c.x - 1, c.y}, SampleLayout::cell_corners, 64, 0});
  const HeightTile s = tile_or_die(generator, {scheme, south, SampleLayout::cell_corners, 64, 0});
  ASSERT_EQ(a.width, 65);
  for (int k = 0; k <= 64; ++k) {
    expect_shared(a, 0, k, b, 64, k);  // west edge = west neighbour's east edge
    expect_shared(a, k, 64, s, k, 0);  // south edge = south neighbour's north edge
  }
}

TEST_P(SeamsInScheme, SameTileTwiceInAnyOrderIsIdentical) {
  const TileScheme scheme = GetParam();
  TileSource source = source_of("lake-dunes");
  const int z = scheme == TileScheme::local ? 2 : 13;
  const TileAddress c = tile_at_origin(source, scheme, z);
  TileGenerator first(source), second(source);
  const HeightTile a = tile_or_die(first, {scheme, c});
  (void)tile_or_die(second, {scheme, {z, c.x + 1, c.y}});
  const HeightTile b = tile_or_die(second, {scheme, c});
  EXPECT_EQ(a.elevation, b.elevation);
  EXPECT_EQ(a.slope_east, b.slope_east);
  EXPECT_EQ(a.slope_north, b.slope_north);
}

INSTANTIATE_TEST_SUITE_P(Schemes, SeamsInScheme,
                         ::testing::Values(TileScheme::local, TileScheme::webmercator,
                                           TileScheme::geographic),
                         [](const auto& p) { return std::string(scheme_name(p.param)); });

TEST(HeightTile, GeographicTileAtTheOriginSamplesTheSceneCentre) {
  TileSource source = source_of("hills-river");
  TileGenerator generator(source);
  const TileAddress a = tile_at_origin(source, TileScheme::geographic, 12);
  const HeightTile tile = tile_or_die(generator, {TileScheme::geographic, a});
  // Some sample lies within one ground spacing of the scene origin.
  double nearest = 1e30;
  for (std::size_t i = 0; i < tile.scene_x.size(); ++i) {
    nearest = std::min(nearest, std::hypot(tile.scene_x[i], tile.scene_y[i]));
  }
  EXPECT_LT(nearest, tile.ground_spacing);
  EXPECT_GT(tile.ground_spacing, 10.0);
  EXPECT_LT(tile.ground_spacing, 60.0);
}

TEST(HeightTile, FarFromTheSceneIsTheBaseLevel) {
  TileGenerator generator(source_of("winding-road"));  // base_elevation 150
  for (TileAddress a : {TileAddress{0, 1, 0}, TileAddress{0, 0, 0}}) {
    const HeightTile tile =
        tile_or_die(generator, {TileScheme::geographic, a, SampleLayout::cell_centres, 64});
    // The far hemisphere is not mapped at all; near samples far from the features fade to base.
    EXPECT_EQ(tile.elevation[tile.index(0, 32)], 150.0f);
    EXPECT_EQ(tile.elevation[tile.index(63, 32)], 150.0f);
  }
}

TEST(TilesCoveringArea, HoldTheOriginTile) {
  TileSource source = source_of("mountain-range");
  for (TileScheme scheme : {TileScheme::local, TileScheme::webmercator, TileScheme::geographic}) {
    for (int z : {0, 5, 12, 15}) {
      const TileRange r = tiles_covering_area(source, scheme, z);
      const TileAddress o = tile_at_origin(source, scheme, z);
      EXPECT_LE(r.min_x, o.x);
      EXPECT_GE(r.max_x, o.x);
      EXPECT_LE(r.min_y, o.y);
      EXPECT_GE(r.max_y, o.y);
      if (scheme != TileScheme::local && z == 15) {
        // a 9 km scene, turned by 15°, at zoom 15 (tiles of 420 to 840 m) spans tens of tiles,
        // not the world
        EXPECT_LT(r.max_x - r.min_x, 30);
        EXPECT_LT(r.max_y - r.min_y, 30);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Water

TEST(WaterMask, MarksTheLakeAndNotTheHills) {
  TileSource source = source_of("lake-dunes");
  ASSERT_NE(source.water, nullptr);
  TileGenerator generator(source);
  // Local zoom 1 tile (0, 1) is the south-west quarter, which holds the lake at (-500, -300).
  Result<std::vector<std::uint8_t>> mask = generator.water_mask(TileScheme::local, {1, 0, 1});
  ASSERT_TRUE(mask.ok());
  ASSERT_EQ(mask->size(), 256u * 256u);
  // (-500, -300) → column (−500 + 3000)/3000·256 ≈ 213, row (0 − (−300))/3000·256 ≈ 26
  EXPECT_EQ((*mask)[26 * 256 + 213], 255);
  EXPECT_EQ((*mask)[250 * 256 + 5], 0);  // the far south-west corner is dry land
  // The north-east corner tile holds the ridged hills, far from the water layer: all land,
  // collapsed to one byte.
  Result<std::vector<std::uint8_t>> dry = generator.water_mask(TileScheme::local, {2, 3, 0});
  ASSERT_TRUE(dry.ok());
  EXPECT_EQ(*dry, std::vector<std::uint8_t>{0});
}

TEST(WaterMask, SceneWithoutWaterIsAllLand) {
  TileGenerator generator(source_of("craters"));
  Result<std::vector<std::uint8_t>> mask = generator.water_mask(TileScheme::local, {0, 0, 0});
  ASSERT_TRUE(mask.ok());
  EXPECT_EQ(*mask, std::vector<std::uint8_t>{0});
}

}  // namespace
}  // namespace terrain
