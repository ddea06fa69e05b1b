// Bounds over boxes (Génevaux §7.2's local Lipschitz bounds): each operator and primitive bounds
// its slope from what holds over the box, not from its worst case anywhere, and stays sound.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "field_checks.hpp"
#include "terrain/node.hpp"
#include "terrain/sphere_trace.hpp"

namespace terrain {
namespace {

using testing::parse_or_die;

TEST(FalloffSlope, BoundOverADistanceRangeHoldsAndVanishesTowardsTheRim) {
  const float r = 500.0f;
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.2f * r);
  for (int k = 0; k < 2000; ++k) {
    float a = u(rng), b = u(rng);
    if (a > b) std::swap(a, b);
    const float bound = Falloff::lipschitz(Interval{a, b}, r);
    EXPECT_LE(bound, Falloff::lipschitz(r));
    for (int j = 0; j < 20; ++j) {
      const float d = a + (b - a) * static_cast<float>(j) / 19.0f;
      float g, dg;
      Falloff::eval(d, r, g, dg);
      ASSERT_LE(std::abs(dg), bound * 1.0001f + 1e-9f)
          << "d " << d << " in [" << a << ", " << b << "]";
    }
  }
  EXPECT_FLOAT_EQ(Falloff::lipschitz(Interval{0.0f, r}, r), Falloff::lipschitz(r));
  EXPECT_LT(Falloff::lipschitz(Interval{0.95f * r, r}, r), 0.05f * Falloff::lipschitz(r));
  EXPECT_LT(Falloff::lipschitz(Interval{r, 2.0f * r}, r), 1e-9f);
}

TEST(FalloffSlope, DistancesOfAWeightInvertTheFalloff) {
  const float r = 80.0f;
  for (float d = 0.5f; d < r; d += 3.7f) {
    float g, dg;
    Falloff::eval(d, r, g, dg);
    const Interval back = Falloff::distances_of(g, r);
    EXPECT_LE(back.lo, d);
    EXPECT_GE(back.hi, d);
    EXPECT_LT(back.width(), 0.05f) << "at distance " << d;
  }
  EXPECT_EQ(Falloff::distances_of(1.0f, r).lo, 0.0f);
  EXPECT_TRUE(std::isinf(Falloff::distances_of(0.0f, r).hi));
}

// A flat plain and, at its edge, a steep ridged disc: over a box at the steep disc's rim, where it
// has almost no weight, the blend's slope bound is a small part of the steep child's.
const char* kSteepAtTheRim = R"({"root": {"type": "blend", "children": [
  {"type": "disc", "center": [0, 0], "radius": 4000, "elevation": 100},
  {"type": "disc", "center": [1800, 0], "radius": 1000, "elevation": 300,
   "noise": {"kind": "ridged", "amplitude": 200, "wavelength": 400, "octaves": 6, "seed": 2}}]}})";

TEST(BlendBounds, ASteepChildWithLittleWeightAddsLittleSlope) {
  const Scene scene = parse_or_die(kSteepAtTheRim);
  const Program program = testing::compile_or_die(scene);
  Evaluator e(program);
  const Box2 steep_disc = Box2::around({1800, 0}, 1000);
  const float steep = e.bounds({steep_disc, 0.0f}).elevation_lipschitz;
  // 950 m from the steep disc's centre its weight is below 0.001.
  const float rim = e.bounds({Box2::around({850, 0}, 10), 0.0f}).elevation_lipschitz;
  EXPECT_LT(rim, 0.05f * steep) << "rim " << rim << ", steep child " << steep;
  testing::expect_bounds_hold(scene, 40, 30);
}

TEST(BlendBounds, RangeOfTheMeanIsFarNarrowerThanTheHullOfItsChildren) {
  // Two flat discs, 200 m apart in height, with nearly equal weights over the box.
  const Scene scene = parse_or_die(R"({"root": {"type": "blend", "children": [
    {"type": "disc", "center": [-500, 0], "radius": 3000, "elevation": 100},
    {"type": "disc", "center": [500, 0], "radius": 3000, "elevation": 300}]}})");
  const Program program = testing::compile_or_die(scene);
  Evaluator e(program);
  const NodeBounds b = e.bounds({Box2::around({0, 0}, 2), 0.0f});
  const float f = e.sample({0, 0}).elevation;
  EXPECT_LE(b.elevation.lo, f);
  EXPECT_GE(b.elevation.hi, f);
  EXPECT_LT(b.elevation.width(), 5.0f) << "[" << b.elevation.lo << ", " << b.elevation.hi << "]";
  testing::expect_bounds_hold(scene, 40, 30);
}

TEST(ReplaceBounds, ASteepReplacementWithLittleWeightAddsLittleSlope) {
  const Scene scene = parse_or_die(R"({"root": {"type": "replace", "children": [
    {"type": "disc", "center": [0, 0], "radius": 4000, "elevation": 100},
    {"type": "disc", "center": [1800, 0], "radius": 1000, "elevation": 100,
     "noise": {"kind": "fbm", "amplitude": 300, "wavelength": 300, "octaves": 6, "seed": 5}}]}})");
  const Program program = testing::compile_or_die(scene);
  Evaluator e(program);
  const float steep = e.bounds({Box2::around({1800, 0}, 1000), 0.0f}).elevation_lipschitz;
  const float rim = e.bounds({Box2::around({850, 0}, 10), 0.0f}).elevation_lipschitz;
  EXPECT_LT(rim, 0.05f * steep) << "rim " << rim << ", replacement " << steep;
  testing::expect_bounds_hold(scene, 40, 30);
}

Node parse_node(const std::string& json) {
  const Scene scene = parse_or_die(R"({"root": )" + json + "}");
  return *scene.root;
}

TEST(WarpBounds, ASmallBoxStaysSmallInTheChildFrame) {
  const Node warp = parse_node(R"({"type": "warp",
    "noise": {"kind": "fbm", "amplitude": 40, "wavelength": 1800, "octaves": 3, "seed": 4},
    "children": [{"type": "disc", "center": [0, 0], "radius": 900, "elevation": 250}]})");
  const NodeKernels& k = warp.type->kernels;
  const float* params = warp.params.pool.data();
  std::mt19937 rng(8);
  for (int i = 0; i < 300; ++i) {
    const Vec2 c = testing::random_point(rng, Box2::around({0, 0}, 1500));
    const Box2 box = Box2::around(c, 0.5f);
    // Full detail, and levels of detail that drop one and two of the three octaves.
    const float spacing = i % 3 == 0 ? 0.0f : i % 3 == 1 ? 300.0f : 700.0f;
    const Box2 moved = k.warp_box(params, {box, spacing});
    // Before: grown by the displacement's whole range, 2 × 70 m.
    EXPECT_LT(moved.size().x, 1.5f);
    EXPECT_LT(moved.size().y, 1.5f);
    // Sound: the warped points of the box, at that level of detail, lie in the moved box.
    PointBlock in;
    in.spacing = spacing;
    in.count = 16;
    for (int j = 0; j < 16; ++j) {
      const Vec2 p = testing::random_point(rng, box);
      in.x[j] = p.x;
      in.y[j] = p.y;
    }
    in.recompute_box();
    PointBlock out;
    WarpJacobian jacobian{};
    k.warp_points(params, in, out, jacobian);
    for (int j = 0; j < 16; ++j) {
      ASSERT_TRUE(moved.contains({out.x[j], out.y[j]}))
          << "warped point outside the moved box at spacing " << spacing;
    }
  }
  // The stretch over a small box is the displacement's slope there, below its worst case.
  NodeBounds child;
  child.elevation_lipschitz = 1.0f;
  child.weight_lipschitz = 1.0f;
  const float global_stretch = k.warp_bounds(params, {}, child).elevation_lipschitz;
  const float local_stretch =
      k.warp_bounds(params, {Box2::around({100, 200}, 1), 0.0f}, child).elevation_lipschitz;
  EXPECT_LT(local_stretch - 1.0f, 0.7f * (global_stretch - 1.0f));
}

// Over a box small beside the displacement's wavelength, the stretch is ‖I + ∇d‖ at the box
// centre, not 1 + ‖∇d‖_F (which counts every direction's stretch at once).
TEST(WarpBounds, StretchOverASmallBoxIsTheJacobiansOwnNorm) {
  const Node warp = parse_node(R"({"type": "warp",
    "noise": {"kind": "fbm", "amplitude": 40, "wavelength": 1800, "octaves": 3, "seed": 4},
    "children": [{"type": "disc", "center": [0, 0], "radius": 900, "elevation": 250}]})");
  const NodeKernels& k = warp.type->kernels;
  const float* params = warp.params.pool.data();
  NodeBounds child;
  child.elevation_lipschitz = 1.0f;
  child.weight_lipschitz = 1.0f;
  auto norm = [](const WarpJacobian& j, int i) {
    const double a = j.xx[i], b = j.xy[i], c = j.yx[i], d = j.yy[i];
    const double f = a * a + b * b + c * c + d * d, det = a * d - b * c;
    return std::sqrt(0.5 * (f + std::sqrt(std::max(0.0, f * f - 4.0 * det * det))));
  };
  std::mt19937 rng(12);
  double excess_sum = 0.0;
  for (int i = 0; i < 200; ++i) {
    const Vec2 c = testing::random_point(rng, Box2::around({0, 0}, 1500));
    const Box2 box = Box2::around(c, 5.0f);
    const float stretch = k.warp_bounds(params, {box, 0.0f}, child).elevation_lipschitz;
    PointBlock in;
    in.count = 16;
    for (int j = 0; j < 16; ++j) {
      const Vec2 p = j == 0 ? c : testing::random_point(rng, box);
      in.x[j] = p.x;
      in.y[j] = p.y;
    }
    in.recompute_box();
    PointBlock out;
    WarpJacobian jacobian{};
    k.warp_points(params, in, out, jacobian);
    for (int j = 0; j < 16; ++j) {
      ASSERT_LE(norm(jacobian, j), stretch * 1.00001) << "the stretch bound does not hold";
    }
    excess_sum += stretch - norm(jacobian, 0);
  }
  // 0.017 now; 0.054 with 1 + ‖∇d‖_F.
  EXPECT_LT(excess_sum / 200.0, 0.03)
      << "mean stretch bound above the norm at the centre: " << excess_sum / 200.0;
}

TEST(CurveBounds, WeightSlopeBeyondTheFalloffComesFromTheDistanceThere) {
  // A straight road along y = 0 with a 100 m fall-off: a box around y = 99 m, where the weight
  // is all but zero, gets a weight slope far below the fall-off's steepest.
  const Scene scene = parse_or_die(R"({"root": {"type": "replace", "children": [
    {"type": "disc", "center": [0, 0], "radius": 3000, "elevation": 200},
    {"type": "curve", "falloff": 100, "pieces": [[[-2000, 0, 150], [2000, 0, 150]]],
     "profiles": [{"at": 0, "preset": "road", "width": 10}]}]}})");
  const Program program = testing::compile_or_die(scene);
  Evaluator e(program);
  const float near = e.bounds({Box2::around({0, 99.5f}, 0.4f), 0.0f}).elevation_lipschitz;
  const float mid = e.bounds({Box2::around({0, 40.0f}, 0.4f), 0.0f}).elevation_lipschitz;
  EXPECT_LT(near, 0.05f * mid) << "near the rim " << near << ", mid-fall-off " << mid;
  testing::expect_bounds_hold(scene, 60, 30);
}

// Bounds over a box follow the slope there, which need not shrink with the level of detail: where
// two octaves' slopes cancel, dropping the finer one leaves a steeper field. A query over a band
// of spacings holds across it; the bound at the band's finest spacing alone does not.
TEST(BandOfSpacings, BoundsHoldAtEverySpacingOfTheBand) {
  const Scene scene = parse_or_die(R"({"root": {"type": "disc", "center": [0, 0],
    "radius": 5000, "elevation": 0, "noise": {"kind": "fbm", "amplitude": 1, "wavelength": 8,
    "octaves": 2, "hurst": 0.05, "seed": 3}}})");
  const Program program = testing::compile_or_die(scene);
  Evaluator e(program);
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> spacing_in_band(1.0f, 3.9f);
  int broken_by_the_finest_alone = 0;
  for (int k = 0; k < 4000; ++k) {
    const Box2 box = Box2::around(testing::random_point(rng, Box2::around({0, 0}, 200)), 0.05f);
    const float band = e.bounds({box, 1.0f, 3.9f}).elevation_lipschitz;
    const float finest = e.bounds({box, 1.0f}).elevation_lipschitz;
    const float spacing = spacing_in_band(rng);
    const float slope = length(e.sample(box.center(), spacing).elevation_gradient);
    ASSERT_LE(slope, band * 1.001f + 1e-5f) << "spacing " << spacing;
    if (slope > finest * 1.001f + 1e-5f) ++broken_by_the_finest_alone;
  }
  EXPECT_GT(broken_by_the_finest_alone, 0);
}

// Each level of a tracer's bounds grid serves a band of spacings (up to the next level's; the
// last, every coarser one), and its bounds must hold across the band: at random points and
// spacings of every example with level-of-detail nodes, warps and noise.
TEST(LipschitzGrid, EachLevelHoldsAcrossItsBandOfSpacings) {
  for (const char* name : {"butte", "mountain-range", "hills-river"}) {
    const Result<Scene> loaded =
        load_scene_file(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/" + name + ".json");
    ASSERT_TRUE(loaded.ok());
    const Scene& scene = *loaded;
    const Program program = testing::compile_or_die(scene);
    Evaluator e(program);
    const Box2 area = scene.area();
    const LipschitzGrid grid(e, area, 16);
    std::mt19937 rng(12);
    std::uniform_real_distribution<float> log_spacing(std::log(0.05f), std::log(400.0f));
    for (int k = 0; k < 3000; ++k) {
      const Vec2 p = testing::random_point(rng, area);
      const float spacing = std::exp(log_spacing(rng));
      const float bound = grid.bound(Box2::of_point(p), spacing, spacing);
      const FieldSample s = e.sample(p, spacing);
      ASSERT_LE(length(s.elevation_gradient), bound * 1.001f + 1e-4f)
          << name << " at (" << p.x << ", " << p.y << "), spacing " << spacing;
      ASSERT_LE(bound, grid.global());
    }
  }
}

// The warped kind's constants act on the height sum in units of the amplitude (Schneider's
// roughness is dimensionless): scaling the amplitude scales the relief and keeps its shape.
TEST(WarpedNoise, WarpsAlikeAtEveryAmplitude) {
  auto scene_with = [](double amplitude) {
    return parse_or_die(R"({"root": {"type": "disc", "center": [0, 0], "radius": 1000,
      "elevation": 0, "noise": {"kind": "warped", "amplitude": )" +
                        std::to_string(amplitude) + R"(, "wavelength": 1000}}})");
  };
  const Scene tall = scene_with(100.0), low = scene_with(10.0);
  std::mt19937 rng(4);
  for (int k = 0; k < 300; ++k) {
    const Vec2 p = testing::random_point(rng, Box2::around({0, 0}, 900));
    const float a = evaluate_tree(tall, p).elevation, b = evaluate_tree(low, p).elevation;
    ASSERT_NEAR(a, 10.0f * b, 1e-3f * (1.0f + std::abs(a))) << "at " << p.x << ", " << p.y;
  }
}

TEST(WarpedNoise, DefaultWarpHasAFiniteBoundNearItsSlope) {
  // Before the constants were made relative to the amplitude this reported 1.25e14.
  const Scene scene = parse_or_die(R"({"root": {"type": "disc", "center": [0, 0],
    "radius": 1000, "elevation": 0, "noise": {"kind": "warped", "amplitude": 100,
    "wavelength": 1000}}})");
  const Program program = testing::compile_or_die(scene);
  const GridResult grid = evaluate_grid(program, {-1000, -1000, 4.0, 501, 501, 0.0f}, 0);
  float steepest = 0.0f;
  for (std::size_t k = 0; k < grid.elevation.size(); ++k) {
    steepest = std::max(steepest, std::hypot(grid.gradient_x[k], grid.gradient_y[k]));
  }
  EXPECT_GE(program.bounds.elevation_lipschitz, steepest);
  EXPECT_LT(program.bounds.elevation_lipschitz, 30.0f * steepest);
  testing::expect_bounds_hold(scene, 40, 30);
}

}  // namespace
}  // namespace terrain
