// Rivers and lakes (terrain/rivers.hpp) and the drainage node: channels whose beds and water
// descend, no pits outside lakes, lakes at their spill level, hydraulic geometry, the same bits
// every time, the water layer that carries them, and refused input that names its field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "synthetic_land.hpp"
#include "terrain/erosion.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/geomorphometry.hpp"
#include "terrain/program.hpp"
#include "terrain/rivers.hpp"
#include "terrain/scene.hpp"
#include "terrain/tile_source.hpp"

namespace terrain {
namespace {

constexpr int kSide = 128;
constexpr double kCell = 4000.0 / (kSide - 1);

/// Eroded land (dendritic valleys) on a plane falling 3% to the south, with a bowl 40 m deep
/// dug into it near the middle: one lake.
const std::vector<float>& valley_land() {
  static const std::vector<float> land = [] {
    std::vector<float> rough = testing::rough_land(kSide);
    for (int j = 0; j < kSide; ++j) {
      for (int i = 0; i < kSide; ++i) {
        float& z = rough[static_cast<std::size_t>(j * kSide + i)];
        z = static_cast<float>(0.1 * (z - 100.0) + 0.03 * kCell * j);
      }
    }
    std::vector<float> z = *erode({kSide, kSide, kCell, rough, std::nullopt, {}}, {});
    for (int j = 0; j < kSide; ++j) {
      for (int i = 0; i < kSide; ++i) {
        const double bowl = std::hypot(i - 64.0, j - 64.0) / 10.0;
        if (bowl < 1.0) {
          z[static_cast<std::size_t>(j * kSide + i)] -=
              static_cast<float>(40.0 * (1.0 - bowl * bowl));
        }
      }
    }
    return z;
  }();
  return land;
}

RiverParams params() {
  RiverParams p;
  p.channel_area = 40 * kCell * kCell;
  p.width = 20.0;
  p.depth = 2.0;
  p.lake_depth = 1.0;
  return p;
}

RiverNetwork carve_or_die(const std::vector<float>& z, const RiverParams& p = params()) {
  Result<RiverNetwork> out = carve_rivers({kSide, kSide, kCell, z, std::nullopt, {}}, p);
  EXPECT_TRUE(out.ok()) << (out ? "" : out.error().pointer + ": " + out.error().message);
  return out ? std::move(*out) : RiverNetwork{};
}

TEST(Rivers, EveryChannelsBedAndWaterDescendDownstream) {
  const RiverNetwork r = carve_or_die(valley_land());
  int links = 0;
  for (std::size_t c = 0; c < r.channel.size(); ++c) {
    if (r.channel[c] == 0) continue;
    EXPECT_GT(r.water[c], r.terrain[c]) << "channel cell " << c << " is dry";
    const std::int32_t d = r.downstream[c];
    if (d < 0) continue;
    ++links;
    EXPECT_LT(r.terrain[static_cast<std::size_t>(d)], r.terrain[c]) << c;
    EXPECT_LT(r.water[static_cast<std::size_t>(d)], r.water[c]) << c;
  }
  EXPECT_GT(links, 200);
}

TEST(Rivers, LeaveNoPitsOutsideLakesAndNoClosedDepressions) {
  const RiverNetwork r = carve_or_die(valley_land());
  const ElevationGrid grid{kSide, kSide, kCell, r.terrain, std::nullopt, {}, r.lake};
  const Geomorphometry g = *analyze(grid);
  EXPECT_EQ(g.pits, 0);
  EXPECT_EQ(g.depression_cells, 0);
}

TEST(Rivers, KeepDeepDepressionsAsLakesAtTheirSpillLevel) {
  const std::vector<float>& z = valley_land();
  const RiverNetwork r = carve_or_die(z);
  // The bowl, and pockets its digging left on the valley sides.
  EXPECT_GE(r.lakes, 1);
  const auto middle = static_cast<std::size_t>(64 * kSide + 64);
  ASSERT_EQ(r.lake[middle], 1);
  EXPECT_EQ(r.terrain[middle], z[middle]) << "a lake's floor stays";
  EXPECT_GT(r.water[middle] - z[middle], 15.0f);
  // Each lake is flat, above its floor, and spills: a cell at its level borders land no lower
  // than the level only where the flood came over the rim.
  int at_middle_level = 0;
  for (std::size_t c = 0; c < r.lake.size(); ++c) {
    if (r.lake[c] == 0) continue;
    EXPECT_GE(r.water[c], z[c]);
    EXPECT_EQ(r.terrain[c], z[c]);
    at_middle_level += r.water[c] == r.water[middle] ? 1 : 0;
  }
  EXPECT_GT(at_middle_level, 100);
}

TEST(Rivers, FillADepressionShallowerThanALakeAsSediment) {
  // A plane falling 0.1% to the south with a dimple 0.3 m deep: closed, but no lake.
  constexpr int side = 32;
  std::vector<float> z(side * side);
  for (int j = 0; j < side; ++j) {
    for (int i = 0; i < side; ++i) {
      const double dimple = std::hypot(i - 16.0, j - 16.0) / 4.0;
      z[static_cast<std::size_t>(j * side + i)] = static_cast<float>(
          100.0 + 0.001 * 10.0 * j - (dimple < 1.0 ? 0.3 * (1.0 - dimple * dimple) : 0.0));
    }
  }
  RiverParams p = params();
  p.channel_area = 1e9;  // no channels: the filling alone
  const RiverNetwork r = *carve_rivers({side, side, 10.0, z, std::nullopt, {}}, p);
  const auto middle = static_cast<std::size_t>(16 * side + 16);
  EXPECT_EQ(r.lakes, 0);
  EXPECT_EQ(r.lake[middle], 0);
  EXPECT_GT(r.terrain[middle], z[middle] + 0.2f);
  EXPECT_LT(r.water[middle], r.terrain[middle]);
  const Geomorphometry g = *analyze({side, side, 10.0, r.terrain, std::nullopt, {}});
  EXPECT_EQ(g.pits, 0);
}

TEST(Rivers, ChannelsGrowWideAndDeepDownstream) {
  const std::vector<float>& z = valley_land();
  const RiverNetwork r = carve_or_die(z);
  // The largest river's mouth against its sources: deeper water, and more wet cells around it.
  std::size_t mouth = 0;
  int highest = 0;
  for (std::size_t c = 0; c < r.channel.size(); ++c) {
    if (r.channel[c] != 0 && r.strahler[c] > highest) {
      highest = r.strahler[c];
      mouth = c;
    }
  }
  EXPECT_GE(highest, 3);
  double head_depth = 0.0;
  int heads = 0;
  for (std::size_t c = 0; c < r.channel.size(); ++c) {
    if (r.channel[c] != 0 && r.strahler[c] == 1) {
      head_depth += r.water[c] - r.terrain[c];
      ++heads;
    }
  }
  ASSERT_GT(heads, 0);
  EXPECT_GT(r.water[mouth] - r.terrain[mouth], 1.5 * head_depth / heads);
  const auto wet_around = [&](std::size_t c) {
    int wet = 0;
    const int ci = static_cast<int>(c) % kSide, cj = static_cast<int>(c) / kSide;
    for (int j = std::max(cj - 4, 0); j <= std::min(cj + 4, kSide - 1); ++j) {
      for (int i = std::max(ci - 4, 0); i <= std::min(ci + 4, kSide - 1); ++i) {
        const auto x = static_cast<std::size_t>(j * kSide + i);
        wet += r.water[x] > r.terrain[x] ? 1 : 0;
      }
    }
    return wet;
  };
  EXPECT_GT(wet_around(mouth), 5);
}

TEST(Rivers, AreTheSameBitsEveryTime) {
  const RiverNetwork a = carve_or_die(valley_land());
  const RiverNetwork b = carve_or_die(valley_land());
  EXPECT_EQ(a.terrain, b.terrain);
  EXPECT_EQ(a.water, b.water);
  EXPECT_EQ(a.downstream, b.downstream);
}

TEST(Rivers, TheSeaIsWaterAtItsLevel) {
  const std::vector<float>& z = valley_land();
  RiverParams p = params();
  const float sea_level = *std::min_element(z.begin(), z.end()) + 10.0f;
  p.sea_level = sea_level;
  const RiverNetwork r = carve_or_die(z, p);
  int sea = 0;
  for (std::size_t c = 0; c < z.size(); ++c) {
    if (z[c] <= sea_level) {
      ++sea;
      EXPECT_EQ(r.water[c], sea_level);
      EXPECT_EQ(r.terrain[c], z[c]);
    }
  }
  EXPECT_GT(sea, 0);
}

TEST(RiversRefuse, ParametersOutOfRangeNamingTheField) {
  const std::vector<float>& z = valley_land();
  const ElevationGrid grid{kSide, kSide, kCell, z, std::nullopt, {}};
  const auto refused = [&](RiverParams p) {
    Result<RiverNetwork> r = carve_rivers(grid, p);
    return r ? std::string("accepted") : r.error().pointer;
  };
  RiverParams p = params();
  p.channel_area = 0.0;
  EXPECT_EQ(refused(p), "/channel_area");
  p = params();
  p.width = -1.0;
  EXPECT_EQ(refused(p), "/width");
  p = params();
  p.depth = NAN;
  EXPECT_EQ(refused(p), "/depth");
  p = params();
  p.bank_slope = 100.0;
  EXPECT_EQ(refused(p), "/bank_slope");
  p = params();
  p.lake_depth = 0.0;
  EXPECT_EQ(refused(p), "/lake_depth");
  p = params();
  p.sea_level = INFINITY;
  EXPECT_EQ(refused(p), "/sea_level");
}

// A drained dome: gentle noisy hills with a bowl dug into their top, under a drainage.
constexpr const char* kDrainedScene = R"({"format": "terrain-scene/1", "seed": 5,
  "extent": {"min": [-1000, -1000], "max": [1000, 1000]},
  "water": {"type": "disc", "id": "pond", "center": [3000, 3000], "radius": 300, "elevation": 50},
  "root": {"type": "drainage", "id": "drained", "resolution": 128, "center": [0, 0],
    "size": 2000, "channel_area": 20000, "width": 12, "depth": 2, "lake_depth": 1,
    "children": [{"type": "add", "children": [
      {"type": "disc", "center": [0, 0], "radius": 1400, "elevation": 400,
        "noise": {"kind": "fbm", "amplitude": 40, "wavelength": 600, "octaves": 5}},
      {"type": "disc", "center": [0, 0], "radius": 400, "elevation": -80}]}]}})";

Result<Scene> parse_text(const std::string& text, const ParseOptions& options = {}) {
  return parse_scene(nlohmann::json::parse(text), options);
}

TEST(DrainageNode, PutsItsLakeAndRiversInTheWaterLayer) {
  Result<Scene> scene = parse_text(kDrainedScene);
  ASSERT_TRUE(scene.ok()) << scene.error().pointer << ": " << scene.error().message;
  ASSERT_NE(scene->water, nullptr);
  const Program terrain = *compile(*scene);
  const Program water = *compile_water(*scene);
  Evaluator ground(terrain), surface(water);
  // The bowl holds water; far from any channel, the high ground is dry; the authored pond stays.
  const auto wet = [&](Vec2 p) {
    const FieldSample s = surface.sample(p, 1.0f);
    return s.weight >= 0.5f && s.elevation > ground.sample(p, 1.0f).elevation;
  };
  EXPECT_TRUE(wet({0, 0}));
  EXPECT_TRUE(wet({3000, 3000}));
  // Wet cells on the node's grid: the lake and channels, a small share of the square.
  int wet_cells = 0;
  for (int j = 0; j < 64; ++j) {
    for (int i = 0; i < 64; ++i) {
      wet_cells += wet({-1000.0f + 2000.0f * static_cast<float>(i) / 63,
                        -1000.0f + 2000.0f * static_cast<float>(j) / 63})
                       ? 1
                       : 0;
    }
  }
  EXPECT_GT(wet_cells, 20);
  EXPECT_LT(wet_cells, 64 * 64 / 4);
}

TEST(DrainageNode, DryLandAwayFromWaterHasNoWaterSurface) {
  // Dry cells carry a surface kDryDepth below the ground so that shorelines interpolate; far
  // from water the layer's weight is 0, or every dry slope would be a metre above water (and
  // pictures and colour tiles would paint it as a shore: 36% of river-lake's colour tile was).
  Result<Scene> scene = parse_text(kDrainedScene);
  ASSERT_TRUE(scene.ok()) << scene.error().pointer << ": " << scene.error().message;
  const Program terrain = *compile(*scene);
  const Program water = *compile_water(*scene);
  Evaluator ground(terrain), surface(water);
  int with_surface = 0, dry_with_surface = 0, wet = 0;
  for (int j = 0; j < 64; ++j) {
    for (int i = 0; i < 64; ++i) {
      const Vec2 p{-1000.0f + 2000.0f * static_cast<float>(i) / 63,
                   -1000.0f + 2000.0f * static_cast<float>(j) / 63};
      const FieldSample s = surface.sample(p, 1.0f);
      if (!(s.weight >= 0.5f)) continue;
      ++with_surface;
      const bool under = s.elevation > ground.sample(p, 1.0f).elevation;
      wet += under ? 1 : 0;
      dry_with_surface += under ? 0 : 1;
    }
  }
  EXPECT_GT(wet, 20);
  // Banks within a few cells of the water keep a surface (its shore); the rest of the land none.
  EXPECT_LT(with_surface, 64 * 64 / 2);
  EXPECT_LT(dry_with_surface, 64 * 64 / 3);
}

TEST(Rivers, WaterWeighsOneNearWaterAndNothingFarFromIt) {
  const RiverNetwork r = carve_or_die(valley_land());
  ASSERT_EQ(r.water_weight.size(), r.water.size());
  std::vector<int> wet_cells;
  for (std::size_t c = 0; c < r.water.size(); ++c) {
    if (r.water[c] > r.terrain[c]) wet_cells.push_back(static_cast<int>(c));
  }
  ASSERT_GT(wet_cells.size(), 50u);
  for (std::size_t c = 0; c < r.water.size(); ++c) {
    const int i = static_cast<int>(c) % kSide, j = static_cast<int>(c) / kSide;
    int nearest = kSide;  // Chebyshev distance to the nearest wet cell
    for (const int w : wet_cells) {
      nearest = std::min(nearest, std::max(std::abs(w % kSide - i), std::abs(w / kSide - j)));
    }
    EXPECT_EQ(r.water_weight[c], nearest <= kWaterReachCells ? 1.0f : 0.0f) << i << ", " << j;
  }
}

TEST(DrainageNode, ItsSurfaceHasNoPitsOutsideItsWater) {
  Result<Scene> scene = parse_text(kDrainedScene);
  ASSERT_TRUE(scene.ok());
  const Program terrain = *compile(*scene);
  const Program water = *compile_water(*scene);
  GridSpec spec{-1000.0, -1000.0, 2000.0 / 127, 128, 128, -1.0f};
  const GridResult grid = evaluate_grid(terrain, spec, 1);
  Evaluator surface(water);
  std::vector<std::uint8_t> wet(grid.elevation.size(), 0);
  for (int j = 0; j < 128; ++j) {
    for (int i = 0; i < 128; ++i) {
      const auto c = static_cast<std::size_t>(j * 128 + i);
      const FieldSample s = surface.sample({static_cast<float>(spec.origin_x + i * spec.step),
                                            static_cast<float>(spec.origin_y + j * spec.step)},
                                           static_cast<float>(spec.step));
      wet[c] = s.weight >= 0.5f && s.elevation > grid.elevation[c] ? 1 : 0;
    }
  }
  const Geomorphometry g = *analyze({128, 128, spec.step, grid.elevation, std::nullopt, {}, wet});
  EXPECT_EQ(g.pits, 0);
  EXPECT_EQ(g.depression_cells, 0);
  EXPECT_GT(g.wet_cells, 0);
}

TEST(DrainageNode, MarksQuantizedMeshWaterWhereTheLakeIs) {
  Result<Scene> scene = parse_text(kDrainedScene);
  ASSERT_TRUE(scene.ok());
  Result<TileSource> source = TileSource::from_scene(*scene);
  ASSERT_TRUE(source.ok()) << source.error().message;
  TileGenerator generator(std::move(*source));
  // Cesium's geographic tiles over the scene at a zoom where a tile is about its size.
  const TileRange range = tiles_covering_area(generator.source(), TileScheme::geographic, 13);
  bool any_wet = false;
  for (std::int64_t x = range.min_x; x <= range.max_x; ++x) {
    for (std::int64_t y = range.min_y; y <= range.max_y; ++y) {
      Result<std::vector<std::uint8_t>> mask =
          generator.water_mask(TileScheme::geographic, {13, x, y});
      ASSERT_TRUE(mask.ok()) << mask.error().message;
      for (const std::uint8_t m : *mask) any_wet = any_wet || m == 255;
    }
  }
  EXPECT_TRUE(any_wet);
}

TEST(DrainageNode, ParsedAgainWithTheCacheGivesTheSameGrids) {
  BakeCache cache(64u << 20);
  ParseOptions options;
  options.bake_cache = &cache;
  Result<Scene> a = parse_text(kDrainedScene, options);
  Result<Scene> b = parse_text(kDrainedScene, options);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->root->params.pool, b->root->params.pool);
  EXPECT_EQ(a->water->children.at(1)->params.pool, b->water->children.at(1)->params.pool);
}

TEST(DrainageNode, TakesExtremeParametersWithinTheirRanges) {
  // A metre-wide square with channels as wide as allowed: the carve's reach is clamped.
  for (const double width : {1e-3, 1e4}) {
    nlohmann::json doc = nlohmann::json::parse(kDrainedScene);
    doc["root"]["size"] = 1.0;
    doc["root"]["resolution"] = 16;
    doc["root"]["channel_area"] = 1.0;
    doc["root"]["width"] = width;
    doc["root"]["depth"] = 1e3;
    doc["root"]["bank_slope"] = 0.05;
    Result<Scene> scene = parse_scene(doc);
    ASSERT_TRUE(scene.ok()) << scene.error().pointer << ": " << scene.error().message;
    EXPECT_TRUE(compile(*scene).ok());
  }
}

TEST(DrainageNodeRefuses, ParametersOutOfRangeNamingTheField) {
  for (const auto& [field, value] :
       std::vector<std::pair<std::string, std::string>>{{"channel_area", "-5"},
                                                        {"width", "0"},
                                                        {"depth", "5000"},
                                                        {"bank_slope", "0"},
                                                        {"lake_depth", "-1"},
                                                        {"resolution", "4"}}) {
    nlohmann::json doc = nlohmann::json::parse(kDrainedScene);
    doc["root"][field] = nlohmann::json::parse(value);
    Result<Scene> scene = parse_scene(doc);
    ASSERT_FALSE(scene.ok()) << field;
    EXPECT_EQ(scene.error().pointer, "/root/" + field);
  }
}

TEST(DrainageNodeRefuses, SittingUnderATransformOrInTheWaterTree) {
  nlohmann::json doc = nlohmann::json::parse(kDrainedScene);
  const nlohmann::json drainage = doc["root"];
  doc["root"] = {{"type", "transform"}, {"translate", {10, 0}}, {"children", {drainage}}};
  Result<Scene> moved = parse_scene(doc);
  ASSERT_FALSE(moved.ok());
  EXPECT_EQ(moved.error().pointer, "/root/children/0/type");

  doc = nlohmann::json::parse(kDrainedScene);
  doc["water"] = drainage;
  Result<Scene> in_water = parse_scene(doc);
  ASSERT_FALSE(in_water.ok());
  EXPECT_EQ(in_water.error().pointer, "/water/type");
}

TEST(DrainageNodeRefuses, WorkBeyondTheLimitAsUnsupportedNamingTheResolution) {
  ParseOptions options;
  options.limits.max_erosion_work = 4 * 128 * 128 - 1;  // its grid is 128²
  Result<Scene> scene = parse_text(kDrainedScene, options);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.error().kind, ErrorKind::unsupported);
  EXPECT_TRUE(scene.error().pointer.ends_with("/resolution")) << scene.error().pointer;
}

}  // namespace
}  // namespace terrain
