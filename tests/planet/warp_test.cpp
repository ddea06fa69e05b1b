// Domain warping (planet.md "Winding valleys"): off by default, bounded, smooth, and the same for
// a tile's grid as for a lone sample; a warped square still drains.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <string>

#include "default_definition.hpp"
#include "issue20_targets.hpp"
#include "planet/planet.hpp"
#include "sample_grids.hpp"

namespace planet {
namespace {

std::shared_ptr<const Planet> planet_with_warp(double warp) {
  PlanetDefinition d = test::default_definition();
  d.warp = warp;
  return Planet::create(d);
}

// The default planet warped as strongly as a definition may: a share of 0.12 and the longest
// wavelength, 100 km.
const std::shared_ptr<const Planet>& strongly_warped() {
  static const std::shared_ptr<const Planet> planet = [] {
    PlanetDefinition d = test::default_definition();
    d.warp = 0.12;
    d.warp_wavelength = 100000.0;
    return Planet::create(d);
  }();
  return planet;
}

Vec3d random_direction(std::mt19937_64& random) {
  std::normal_distribution<double> normal;
  return normalize(Vec3d{normal(random), normal(random), normal(random)});
}

// The warp's 2 × 2 Jacobian at p in metres per metre, by central differences `step` metres wide
// along east and north: {∂e/∂e, ∂n/∂e, ∂e/∂n, ∂n/∂n}.
std::array<double, 4> jacobian(const Planet& world, const Vec3d& p, int level, double step) {
  const double radius = world.definition().radius;
  const Vec3d east = normalize(Vec3d{-p[1], p[0], 0.0});
  const Vec3d north = cross(p, east);
  const Vec3d centre = world.warp(p, level);
  std::array<double, 4> j{};
  std::size_t k = 0;
  for (const Vec3d& axis : {east, north}) {
    const double h = step / radius;
    const Vec3d ahead = world.warp(normalize(add(p, scale(axis, h))), level);
    const Vec3d behind = world.warp(normalize(sub(p, scale(axis, h))), level);
    const Vec3d d = sub(ahead, behind);
    // Measured in the frame at the warped point, which is the frame at p to within the warp's
    // displacement (a few kilometres: a tilt of 1e-3).
    const Vec3d e = normalize(Vec3d{-centre[1], centre[0], 0.0});
    const Vec3d n = cross(centre, e);
    j[k++] = dot(d, e) / (2.0 * h);
    j[k++] = dot(d, n) / (2.0 * h);
  }
  return j;
}

TEST(PlanetWarp, IsOffByDefaultAndLeavesTheIdAlone) {
  const auto& world = test::default_planet();
  EXPECT_EQ(world->definition().warp, 0.0);
  EXPECT_EQ(canonical_text(world->definition()).find("warp"), std::string::npos);
  std::mt19937_64 random(31);
  const Rules& rules = world->rules();
  for (const int level : {rules.mesh_level, rules.mesh_level + 10, rules.max_level}) {
    EXPECT_FALSE(world->warps(level));
    for (int i = 0; i < 100; ++i) {
      const Vec3d p = random_direction(random);
      const Vec3d q = world->warp(p, level);
      EXPECT_TRUE(q[0] == p[0] && q[1] == p[1] && q[2] == p[2]);
    }
  }
  // A warped definition is another planet, with another id.
  EXPECT_NE(strongly_warped()->id(), world->id());
  EXPECT_NE(canonical_text(strongly_warped()->definition()).find("\"warp\":0.12"),
            std::string::npos);
}

TEST(PlanetWarp, MovesPointsNoFartherThanItsOctavesReach) {
  // Octave k moves a point by at most share·λ·4^−k in each of three components (its noise is
  // clamped to [−1, 1]), and the first octave alone moves points by kilometres. Levels whose
  // edges are longer than a quarter of the longest wavelength are not warped (the stored
  // mesh's, and the continents and rivers seen from afar).
  const auto& world = strongly_warped();
  const PlanetDefinition& d = world->definition();
  double reach = 0.0;
  for (int k = 0; k < 6; ++k) reach += d.warp * d.warp_wavelength * std::pow(0.25, k);
  reach *= std::sqrt(3.0);
  EXPECT_FALSE(world->warps(world->rules().mesh_level));
  std::mt19937_64 random(32);
  double farthest = 0.0;
  for (int i = 0; i < 2000; ++i) {
    const Vec3d p = random_direction(random);
    const int level = world->level_for_spacing(world->ground_spacing(8 + i % 7, 256));
    ASSERT_TRUE(world->warps(level)) << level;
    const Vec3d moved = sub(world->warp(p, level), p);
    const double metres = std::sqrt(dot(moved, moved)) * d.radius;
    EXPECT_LE(metres, reach);
    farthest = std::max(farthest, metres);
  }
  EXPECT_GT(farthest, 0.25 * reach);
}

TEST(PlanetWarp, IsSmoothAndNeverFoldsTheGround) {
  // Smooth: its Jacobian by differences 2 m and 0.2 m wide agrees (a crease would not), so a C1
  // surface stays C1 through it. Never folded: at the strongest warp a definition may ask for,
  // at the finest level (the most octaves), every point's Jacobian has a positive determinant,
  // so no ground is turned over onto other ground. A share of 0.2 folded it (determinants down
  // to −0.28), and so did eight octaves at 0.12: the range stops at 0.12 and the octaves at six.
  const auto& world = strongly_warped();
  std::mt19937_64 random(33);
  const int coarse = world->level_for_spacing(world->ground_spacing(8, 256));
  const int finest = world->rules().max_level;
  double bend = 0.0, least_determinant = 1.0;
  for (int i = 0; i < 1500; ++i) {
    const Vec3d p = random_direction(random);
    if (std::abs(p[2]) > 0.95) continue;  // the east–north frame turns fast beside the poles
    for (const int level : {coarse, finest}) {
      const auto wide = jacobian(*world, p, level, 2.0);
      const auto narrow = jacobian(*world, p, level, 0.2);
      for (std::size_t k = 0; k < 4; ++k) EXPECT_NEAR(wide[k], narrow[k], 1e-3) << level;
      bend = std::max({bend, std::abs(narrow[0] - 1.0), std::abs(narrow[1]), std::abs(narrow[2]),
                       std::abs(narrow[3] - 1.0)});
      least_determinant =
          std::min(least_determinant, narrow[0] * narrow[3] - narrow[1] * narrow[2]);
    }
  }
  EXPECT_GT(bend, 0.3);  // it does bend
  EXPECT_GT(least_determinant, 0.1);
}

TEST(PlanetWarp, GridSamplesAreTheSamplesOfALoneDescent) {
  // A warped band's samples are binned by where the warp put them instead of found by rows and
  // columns (sample_grid.cpp): anywhere, at levels from the stored mesh to a few metres, every
  // sample of a grid is what a lone sample's walk to its floors gives.
  test::expect_grids_anywhere_are_lone_samples(strongly_warped(), 34, 30);
}

TEST(PlanetWarp, AWarpedSquareStillDrainsAtZoom11) {
  // Issue 20's targets on the zoom-11 square of DrainageModel.LandDrainsWithFlintsLawAtZoom11,
  // warped by 0.1: a warp moves the valleys and bends them, and makes no pits of them.
  test::expect_square_meets_issue20_targets(planet_with_warp(0.1), 5.0, -175.0, 11);
}

}  // namespace
}  // namespace planet
