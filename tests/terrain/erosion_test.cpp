// The erosion solver (terrain/erosion.hpp) and the erosion node: results that drain, follow
// Flint's law with θ ≈ m/n, come out the same bits every time, and refused parameters that name
// their field.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "synthetic_land.hpp"
#include "terrain/erosion.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/geomorphometry.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"

namespace terrain {
namespace {

using testing::rough_land;

ElevationGrid grid_of(const std::vector<float>& z, int side) {
  return {side, side, 4000.0 / (side - 1), z, std::nullopt, {}};
}

std::vector<float> erode_or_die(const ElevationGrid& grid, const ErosionParams& params = {}) {
  Result<std::vector<float>> out = erode(grid, params);
  EXPECT_TRUE(out.ok()) << (out ? "" : out.error().pointer + ": " + out.error().message);
  return out ? *out : std::vector<float>{};
}

TEST(Erosion, LeavesNoPitsAndNoClosedDepressions) {
  const int side = 128;
  const std::vector<float> before = rough_land(side);
  const Geomorphometry raw = *analyze(grid_of(before, side));
  ASSERT_GT(raw.pits, 0) << "the input should have pits for this test to mean anything";
  const std::vector<float> after = erode_or_die(grid_of(before, side));
  const Geomorphometry g = *analyze(grid_of(after, side));
  EXPECT_EQ(g.pits, 0);
  EXPECT_EQ(g.depression_cells, 0);
}

TEST(Erosion, ChannelsFollowFlintsLawWithTheConcavityAsked) {
  const int side = 256;
  const std::vector<float> before = rough_land(side);
  for (const double concavity : {0.4, 0.55}) {
    ErosionParams params;
    params.concavity = concavity;
    params.uplift = 0.3;
    const std::vector<float> after = erode_or_die(grid_of(before, side), params);
    const Geomorphometry g = *analyze(grid_of(after, side));
    ASSERT_TRUE(g.flint.has_value());
    EXPECT_NEAR(g.flint->theta, concavity, 0.08) << "m/n = " << concavity;
    EXPECT_GT(g.flint->r_squared, 0.6);
  }
}

TEST(Erosion, KeepsTheAuthoredReliefAndOutlets) {
  const int side = 96;
  const std::vector<float> before = rough_land(side);
  ErosionParams params;
  params.talus_angle = 85.0;  // a talus slope shaves one-cell summits: not what is tested here
  const std::vector<float> after = erode_or_die(grid_of(before, side), params);
  float lo = before[0], hi = before[0], out_hi = after[0];
  for (std::size_t c = 0; c < before.size(); ++c) {
    lo = std::min(lo, before[c]);
    hi = std::max(hi, before[c]);
    out_hi = std::max(out_hi, after[c]);
  }
  EXPECT_NEAR(out_hi, hi, 0.02 * (hi - lo));
  for (int i = 0; i < side; ++i) {  // the south and north edges are outlets: unchanged
    EXPECT_EQ(after[static_cast<std::size_t>(i)], before[static_cast<std::size_t>(i)]);
    const std::size_t top = static_cast<std::size_t>(side - 1) * side + static_cast<std::size_t>(i);
    EXPECT_EQ(after[top], before[top]);
  }
}

TEST(Erosion, SeaCellsStayAndDrainTheLand) {
  const int side = 96;
  std::vector<float> z = rough_land(side);
  ErosionParams params;
  params.sea_level = 450.0;
  const std::vector<float> after = erode_or_die(grid_of(z, side), params);
  ElevationGrid eroded = grid_of(after, side);
  eroded.sea_level = static_cast<float>(*params.sea_level);
  const Geomorphometry g = *analyze(eroded);
  EXPECT_EQ(g.pits, 0);
  for (std::size_t c = 0; c < z.size(); ++c) {
    if (z[c] <= 450.0f) {
      EXPECT_EQ(after[c], z[c]) << c;
    }
  }
}

TEST(Erosion, IsTheSameBitsEveryTimeAndOnEveryThread) {
  const int side = 128;
  const std::vector<float> before = rough_land(side);
  const std::vector<float> first = erode_or_die(grid_of(before, side));
  std::vector<float> second, on_thread;
  second = erode_or_die(grid_of(before, side));
  std::thread([&] { on_thread = erode_or_die(grid_of(before, side)); }).join();
  ASSERT_EQ(first.size(), second.size());
  EXPECT_EQ(0, std::memcmp(first.data(), second.data(), first.size() * sizeof(float)));
  EXPECT_EQ(0, std::memcmp(first.data(), on_thread.data(), first.size() * sizeof(float)));
}

// Plain D8 drains every cell of a plane sloping between east and north-east the same way, so its
// channels run in parallel along one grid direction (with D8's weights this test measured 7.9°
// on a 26.6° slope). Rho8 routing drains it down its aspect.
TEST(Erosion, ChannelsOnAPlaneRunDownItsSlopeNotAlongTheGrid) {
  const int side = 128;
  const auto at = [&](int i, int j) { return static_cast<std::size_t>(j) * side + i; };
  std::vector<float> plane(static_cast<std::size_t>(side) * side);
  for (int j = 0; j < side; ++j) {
    for (int i = 0; i < side; ++i) plane[at(i, j)] = static_cast<float>(1000.0 - 6.0 * (2 * i + j));
  }
  const double aspect_degrees = std::atan2(1.0, 2.0) * 180.0 / std::numbers::pi;
  ErosionParams params;
  params.uplift = 0.0;
  const std::vector<float> after = erode_or_die(grid_of(plane, side), params);
  // The mean steepest-descent direction of the result's interior cells.
  double sum_i = 0.0, sum_j = 0.0;
  for (int j = 1; j + 1 < side; ++j) {
    for (int i = 1; i + 1 < side; ++i) {
      double steepest = 0.0;
      int down_i = 0, down_j = 0;
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          const double slope = (after[at(i, j)] - after[at(i + di, j + dj)]) / std::hypot(di, dj);
          if ((di != 0 || dj != 0) && slope > steepest) {
            steepest = slope;
            down_i = di;
            down_j = dj;
          }
        }
      }
      if (steepest > 0.0) {
        sum_i += down_i / std::hypot(down_i, down_j);
        sum_j += down_j / std::hypot(down_i, down_j);
      }
    }
  }
  const double mean_degrees = std::atan2(sum_j, sum_i) * 180.0 / std::numbers::pi;
  EXPECT_NEAR(mean_degrees, aspect_degrees, 5.0);
}

TEST(Erosion, LevelsHalveTheGridAndSpendTheStepsWhereCellsAreFew) {
  const std::vector<ErosionLevel> levels = erosion_levels(1024, 1024, 24);
  ASSERT_EQ(levels.size(), 4u);
  EXPECT_EQ(levels[0].width, 1024);
  EXPECT_EQ(levels[3].width, 128);
  EXPECT_EQ(levels[3].steps, 24);
  EXPECT_EQ(levels[0].steps, 2);
  EXPECT_EQ(erosion_levels(40, 40, 5).size(), 1u);
  EXPECT_EQ(erosion_work(40, 40, 5, 0.0), 40 * 40 * 5);
  // Diffusion 1 runs in five sub-steps of 0.2, 32 of them charged as one cell-step.
  EXPECT_EQ(erosion_work(40, 40, 5, 1.0), 40 * 40 * 5 + 40 * 40 * 5 * 5 / 32);
}

TEST(Erosion, PortablePowAgreesWithLibm) {
  for (const double x : {1e-9, 0.003, 0.5, 1.0, 2.0, 1234.5, 4e6}) {
    for (const double y : {0.1, 0.45, 1.0, 2.5}) {
      EXPECT_NEAR(portable_pow(x, y), std::pow(x, y), 1e-13 * std::pow(x, y)) << x << "^" << y;
    }
  }
}

// Malformed input, together.

TEST(ErosionRefuses, ParametersOutOfRangeNamingTheField) {
  const std::vector<float> z = rough_land(32);
  const ElevationGrid grid = grid_of(z, 32);
  const auto refused = [&](ErosionParams p) {
    Result<std::vector<float>> out = erode(grid, p);
    return out ? std::string("accepted") : out.error().pointer;
  };
  ErosionParams p;
  p.iterations = 0;
  EXPECT_EQ(refused(p), "/iterations");
  p = {};
  p.strength = -1.0;
  EXPECT_EQ(refused(p), "/strength");
  p = {};
  p.concavity = 1.5;
  EXPECT_EQ(refused(p), "/concavity");
  p = {};
  p.uplift = std::nan("");
  EXPECT_EQ(refused(p), "/uplift");
  p = {};
  p.diffusion = kMaxDiffusion + 0.5;
  EXPECT_EQ(refused(p), "/diffusion");
  p = {};
  p.talus_angle = 90.0;
  EXPECT_EQ(refused(p), "/talus_angle");
  p = {};
  p.sea_level = INFINITY;
  EXPECT_EQ(refused(p), "/sea_level");
}

TEST(ErosionRefuses, GridsTooSmallTooLargeOrNotFinite) {
  std::vector<float> z(8 * 8, 1.0f);
  EXPECT_EQ(erode({8, 8, 1.0, z, std::nullopt, {}}, {}).error().pointer, "/width");
  std::vector<float> big(16 * 16, 1.0f);
  EXPECT_EQ(erode({16, 16, 0.0, big, std::nullopt, {}}, {}).error().pointer, "/cell_size");
  big[37] = NAN;
  EXPECT_EQ(erode({16, 16, 1.0, big, std::nullopt, {}}, {}).error().pointer, "/elevation");
  EXPECT_EQ(erode({4096, 16, 1.0, big, std::nullopt, {}}, {}).error().pointer, "/width");
}

// The node.

constexpr const char* kErodedScene = R"({"format": "terrain-scene/1", "seed": 5,
  "extent": {"min": [-1000, -1000], "max": [1000, 1000]},
  "root": {"type": "erosion", "id": "eroded", "resolution": 128, "center": [0, 0], "size": 2000,
    "children": [{"type": "disc", "center": [0, 0], "radius": 1400, "elevation": 400,
      "noise": {"kind": "ridged", "amplitude": 500, "wavelength": 900, "octaves": 6}}]}})";

TEST(ErosionNode, ServesAGridThatDrainsAtItsOwnSamples) {
  Result<Scene> scene = parse_scene_text(kErodedScene);
  ASSERT_TRUE(scene.ok()) << scene.error().pointer << ": " << scene.error().message;
  Result<Program> program = compile(*scene);
  ASSERT_TRUE(program.ok());
  // The node's grid: 128 samples over the 2 km square; sample the program there.
  GridSpec spec{-1000.0, -1000.0, 2000.0 / 127, 128, 128, -1.0f};
  const GridResult grid = evaluate_grid(*program, spec, 1);
  const Geomorphometry g = *analyze({128, 128, spec.step, grid.elevation, std::nullopt, {}});
  EXPECT_EQ(g.pits, 0);
  EXPECT_EQ(g.depression_cells, 0);
}

TEST(ErosionNode, CanonicalFormListsEveryParameter) {
  Result<Scene> scene = parse_scene_text(kErodedScene);
  ASSERT_TRUE(scene.ok());
  const nlohmann::json& root = scene->canonical["root"];
  for (const char* key : {"resolution", "iterations", "strength", "concavity", "uplift",
                          "diffusion", "talus_angle", "margin", "center", "size"}) {
    EXPECT_TRUE(root.contains(key)) << key;
  }
}

TEST(ErosionNodeRefuses, WorkBeyondTheLimitAsUnsupportedNamingTheResolution) {
  ParseOptions options;
  options.limits.max_erosion_work = 100000;
  Result<Scene> scene = parse_scene_text(kErodedScene, options);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.error().pointer, "/root/resolution");
  EXPECT_EQ(scene.error().kind, ErrorKind::unsupported);
}

TEST(ErosionNodeRefuses, ResolutionAndIterationsOutOfRange) {
  for (const auto& [field, value] :
       std::vector<std::pair<std::string, std::string>>{{"resolution", "8"},
                                                        {"resolution", "4096"},
                                                        {"iterations", "0"},
                                                        {"strength", "-2"},
                                                        {"concavity", "3"},
                                                        {"talus_angle", "95"},
                                                        {"uplift", "2"}}) {
    std::string text = R"({"format": "terrain-scene/1", "root": {"type": "erosion", ")" + field +
                       R"(": )" + value +
                       R"(, "children": [{"type": "disc", "center": [0, 0], "radius": 100}]}})";
    Result<Scene> scene = parse_scene_text(text);
    ASSERT_FALSE(scene.ok()) << field << " = " << value;
    EXPECT_EQ(scene.error().pointer, "/root/" + field);
  }
}

}  // namespace
}  // namespace terrain

namespace terrain {
namespace {

TEST(BakeCache, MakesAGridOnceWhileManyThreadsAskForIt) {
  BakeCache cache(1 << 20);
  std::atomic<int> made{0};
  const auto make = [&] {
    ++made;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    return std::make_shared<const std::vector<float>>(std::vector<float>(16, 1.0f));
  };
  std::vector<BakeCache::Grid> got(4);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < got.size(); ++t) {
    threads.emplace_back([&, t] { got[t] = cache.get_or_make("k", make); });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(made.load(), 1);
  for (const BakeCache::Grid& g : got) EXPECT_EQ(g, got[0]);
}

TEST(BakeCache, KeepsWithinItsBytesDroppingTheLeastRecentlyUsed) {
  BakeCache cache(3 * 100 * sizeof(float));
  int made = 0;
  const auto grid = [&] {
    ++made;
    return std::make_shared<const std::vector<float>>(std::vector<float>(100, 0.0f));
  };
  (void)cache.get_or_make("a", grid);
  (void)cache.get_or_make("b", grid);
  (void)cache.get_or_make("c", grid);
  (void)cache.get_or_make("a", grid);  // used again: b is now the oldest
  (void)cache.get_or_make("d", grid);  // b goes
  EXPECT_EQ(made, 4);
  EXPECT_LE(cache.bytes(), 3 * 100 * sizeof(float));
  (void)cache.get_or_make("a", grid);
  EXPECT_EQ(made, 4);
  (void)cache.get_or_make("b", grid);
  EXPECT_EQ(made, 5);
  // A failure is not kept: the next caller makes it again.
  EXPECT_EQ(cache.get_or_make("e", [] { return BakeCache::Grid{}; }), nullptr);
  (void)cache.get_or_make("e", grid);
  EXPECT_EQ(made, 6);
}

TEST(ErosionNode, ParsedAgainWithTheCacheGivesTheSameGridWithoutErodingAgain) {
  BakeCache cache(64 << 20);
  ParseOptions options;
  options.bake_cache = &cache;
  Result<Scene> first = parse_scene_text(kErodedScene, options);
  ASSERT_TRUE(first.ok());
  const std::size_t kept = cache.bytes();
  EXPECT_GT(kept, 128u * 128u * sizeof(float));
  Result<Scene> second = parse_scene_text(first->canonical_text(), options);
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(cache.bytes(), kept);  // found, not made again
  EXPECT_EQ(first->root->params.pool, second->root->params.pool);
  Result<Scene> uncached = parse_scene_text(kErodedScene);
  ASSERT_TRUE(uncached.ok());
  EXPECT_EQ(first->root->params.pool, uncached->root->params.pool);
}

TEST(BakeCache, FindsInItsSharedStoresWhatAnotherProcessMade) {
  // Two processes' caches over one shared store (a stand-in for the disk cache and Redis).
  std::map<std::string, std::vector<float>> store;
  const auto sharing = [&store] {
    BakeCache::Shared shared;
    shared.find = [&store](const std::string& key) -> std::optional<std::vector<float>> {
      auto it = store.find(key);
      if (it == store.end()) return std::nullopt;
      return it->second;
    };
    shared.insert = [&store](const std::string& key, const std::vector<float>& grid) {
      store[key] = grid;
    };
    return shared;
  };
  BakeCache first(64 << 20), second(64 << 20);
  first.share_with(sharing());
  second.share_with(sharing());
  ParseOptions options;
  options.bake_cache = &first;
  Result<Scene> made = parse_scene_text(kErodedScene, options);
  ASSERT_TRUE(made.ok());
  EXPECT_EQ(first.made(), 1);
  EXPECT_EQ(store.size(), 1u);
  options.bake_cache = &second;
  Result<Scene> found = parse_scene_text(kErodedScene, options);
  ASSERT_TRUE(found.ok());
  EXPECT_EQ(second.made(), 0);
  EXPECT_EQ(second.shared_hits(), 1);
  EXPECT_EQ(made->root->params.pool, found->root->params.pool);
}

TEST(ErosionNode, ParsedWithoutBakingHasItsHashButDoesNotCompile) {
  ParseOptions options;
  options.bake = false;
  Result<Scene> unbaked = parse_scene_text(kErodedScene, options);
  ASSERT_TRUE(unbaked.ok());
  Result<Scene> baked = parse_scene_text(kErodedScene);
  ASSERT_TRUE(baked.ok());
  EXPECT_FALSE(unbaked->baked);
  EXPECT_TRUE(baked->baked);
  EXPECT_EQ(unbaked->hash, baked->hash);
  EXPECT_EQ(unbaked->canonical_text(), baked->canonical_text());
  Result<Program> program = compile(*unbaked);
  ASSERT_FALSE(program.ok());
  EXPECT_EQ(program.error().kind, ErrorKind::internal);
}

}  // namespace
}  // namespace terrain
