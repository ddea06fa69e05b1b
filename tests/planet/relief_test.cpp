// Relief regions (issue 20 item 3): plains, hills and mountain belts from one seeded field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "default_definition.hpp"
#include "planet/planet.hpp"

namespace planet {
namespace {

PlanetDefinition with_contrast(double contrast) {
  PlanetDefinition d = test::default_definition();
  d.relief_contrast = contrast;
  return d;
}

// Directions spread over the sphere (a Fibonacci lattice).
std::vector<Vec3d> directions(int n) {
  std::vector<Vec3d> out;
  for (int i = 0; i < n; ++i) out.push_back(fibonacci_direction(i, n));
  return out;
}

TEST(ReliefRegions, RangeFromSmoothPlainsToRuggedBelts) {
  const Rules rules(with_contrast(1.0));
  std::vector<double> rugged;
  for (const Vec3d& p : directions(20000)) rugged.push_back(rules.region(p).ruggedness);
  std::sort(rugged.begin(), rugged.end());
  const double low = rugged[rugged.size() / 20], median = rugged[rugged.size() / 2];
  const double high = rugged[rugged.size() * 99 / 100];
  EXPECT_LT(low,
            0.6);  // plains: well under half the hills' roughness... at least a fifth of the land
  EXPECT_GT(high, 2.5);  // belts
  EXPECT_LT(high, rules.max_ruggedness() + 1e-12);
  EXPECT_GT(median, 0.5);
  EXPECT_LT(median, 1.5);
  EXPECT_GE(rugged.front(), 1.0 / rules.max_ruggedness() / 2.0);
}

TEST(ReliefRegions, ZeroContrastAndHeightGiveEveryContinentTheSameRelief) {
  PlanetDefinition d = with_contrast(0.0);
  d.belt_height = 0.0;
  d.plateau_height = 0.0;
  const Rules rules(d);
  for (const Vec3d& p : directions(1000)) {
    EXPECT_EQ(rules.region(p).ruggedness, 1.0);
    EXPECT_EQ(rules.region(p).uplift, 0.0);
  }
  EXPECT_EQ(rules.max_ruggedness(), 1.0);
}

TEST(ReliefRegions, BeltsLiftTheLandAlongThem) {
  // The land on belt crests stands higher with the belts' uplift than without (on average by a
  // fifth of belt_height at least: rivers keep their beds through the belts, so the samples
  // include their valleys); away from them (uplift under 5 % of it) it hardly moves.
  PlanetDefinition flat = with_contrast(0.0);
  flat.belt_height = 0.0;
  flat.plateau_height = 0.0;
  PlanetDefinition lifted = with_contrast(0.0);
  lifted.plateau_height = 0.0;
  const auto without = Planet::create(flat), with = Planet::create(lifted);
  Sampler a(without), b(with);
  double crest_rise = 0.0, far_rise = 0.0;
  int crests = 0, far = 0;
  for (const Vec3d& p : directions(6000)) {
    const double uplift = with->rules().region(p).uplift;
    const PointSample s0 = a.at(p, with->rules().mesh_level + 6, 0.0);
    const PointSample s1 = b.at(p, with->rules().mesh_level + 6, 0.0);
    if (s0.type != SurfaceType::land || s1.type != SurfaceType::land) continue;
    if (uplift > 0.8 * lifted.belt_height) crest_rise += s1.ground - s0.ground, ++crests;
    if (uplift < 0.05 * lifted.belt_height) far_rise += s1.ground - s0.ground, ++far;
  }
  ASSERT_GT(crests, 20);
  ASSERT_GT(far, 200);
  EXPECT_GT(crest_rise / crests, 0.2 * lifted.belt_height) << far_rise / far;
  EXPECT_LT(std::abs(far_rise / far), 0.02 * lifted.belt_height) << crest_rise / crests;
}

TEST(ReliefRegions, BeltsAreRougherThanPlainsOnTheGround) {
  // The ground's relief between neighbouring samples follows the region: over the most and the
  // least rugged land points of a coarse scan, the mean absolute step of 200 m samples.
  const auto planet = Planet::create(with_contrast(1.0));
  Sampler sampler(planet);
  struct Point {
    double rugged;
    Vec3d p;
  };
  std::vector<Point> land;
  for (const Vec3d& p : directions(4000)) {
    const PointSample s = sampler.at(p, planet->level_for_spacing(200.0), 0.0);
    if (s.type == SurfaceType::land) land.push_back({planet->rules().region(p).ruggedness, p});
  }
  ASSERT_GT(land.size(), 500u);
  std::sort(land.begin(), land.end(),
            [](const Point& a, const Point& b) { return a.rugged < b.rugged; });
  auto roughness = [&](std::size_t from, std::size_t to) {
    double sum = 0.0;
    int n = 0;
    for (std::size_t i = from; i < to; ++i) {
      const Vec3d& p = land[i].p;
      const Vec3d east = normalize(cross({0.0, 0.0, 1.0}, p));
      double previous = 0.0;
      for (int k = 0; k <= 16; ++k) {
        const Vec3d q = normalize(add(p, scale(east, 200.0 * k / planet->definition().radius)));
        const double g = sampler.at(q, planet->level_for_spacing(200.0), 0.0).ground;
        if (k > 0) sum += std::abs(g - previous), ++n;
        previous = g;
      }
    }
    return sum / n;
  };
  const std::size_t tenth = land.size() / 10;
  const double plains = roughness(0, tenth), belts = roughness(land.size() - tenth, land.size());
  EXPECT_GT(belts, 1.5 * plains) << "belts " << belts << " m, plains " << plains << " m per 200 m";
}

// Mean absolute step (m) between 17 samples 200 m apart eastwards from each point.
double ground_steps(const std::shared_ptr<const Planet>& planet, const std::vector<Vec3d>& points,
                    double spacing = 200.0) {
  Sampler sampler(planet);
  const int level = planet->level_for_spacing(spacing);
  double sum = 0.0;
  int n = 0;
  for (const Vec3d& p : points) {
    const Vec3d east = normalize(cross({0.0, 0.0, 1.0}, p));
    double previous = 0.0;
    for (int k = 0; k <= 16; ++k) {
      const Vec3d q = normalize(add(p, scale(east, spacing * k / planet->definition().radius)));
      const double g = sampler.at(q, level, 0.0).ground;
      if (k > 0) sum += std::abs(g - previous), ++n;
      previous = g;
    }
  }
  return sum / n;
}

TEST(ReliefRegions, PlateausLiftTablelandsBehindSteeperEscarpments) {
  // Without belts, a point's uplift is plateau_height times its plateau share.
  PlanetDefinition flat = with_contrast(1.0);
  flat.belt_height = 0.0;
  flat.plateau_height = 0.0;
  PlanetDefinition lifted = flat;
  lifted.plateau_height = test::default_definition().plateau_height;
  const auto without = Planet::create(flat), with = Planet::create(lifted);
  Sampler a(without), b(with);
  std::vector<Vec3d> tops, scarps;
  double top_rise = 0.0, far_rise = 0.0;
  int far = 0;
  for (const Vec3d& p : directions(8000)) {
    const double share = with->rules().region(p).uplift / lifted.plateau_height;
    const PointSample s0 = a.at(p, with->rules().mesh_level + 6, 0.0);
    const PointSample s1 = b.at(p, with->rules().mesh_level + 6, 0.0);
    if (s0.type != SurfaceType::land || s1.type != SurfaceType::land) continue;
    if (share > 0.99) tops.push_back(p), top_rise += s1.ground - s0.ground;
    if (share > 0.2 && share < 0.8) scarps.push_back(p);
    if (share == 0.0) far_rise += s1.ground - s0.ground, ++far;
  }
  ASSERT_GT(tops.size(), 40u);
  ASSERT_GT(scarps.size(), 40u);
  ASSERT_GT(far, 500);
  // Rivers keep their beds through the tablelands, so the samples include their canyons.
  EXPECT_GT(top_rise / static_cast<double>(tops.size()), 0.2 * lifted.plateau_height);
  EXPECT_LT(std::abs(far_rise / far), 0.02 * lifted.plateau_height);
  const double top_steps = ground_steps(with, tops), scarp_steps = ground_steps(with, scarps);
  // The escarpments drain as steeply as they are rugged; on the tops the drain rise, not the
  // roughness, sets the relief at this scale (planet.md "Relief regions").
  EXPECT_GT(scarp_steps, 1.15 * top_steps)
      << "escarpments " << scarp_steps << " m, tops " << top_steps << " m per 200 m";
}

TEST(ReliefRegions, CoastalPlainsAreSmootherThanTheSameLandWithout) {
  // Land within 40 km of the sea: its steps between 200 m samples, with and without coastal
  // plains (the same planet otherwise).
  PlanetDefinition none = test::default_definition();
  none.coastal_plain_width = 0.0;
  const auto& with = test::default_planet();
  const auto without = Planet::create(none);
  Sampler sampler(with);
  const double radius = none.radius;
  std::vector<Vec3d> near_coast;
  for (const Vec3d& p : directions(6000)) {
    if (sampler.at(p, with->level_for_spacing(200.0), 0.0).type != SurfaceType::land) continue;
    const Vec3d east = normalize(cross({0.0, 0.0, 1.0}, p)), north = normalize(cross(p, east));
    for (int k = 0; k < 8; ++k) {
      const double turn = k * std::acos(-1.0) / 4.0;
      const Vec3d way = add(scale(east, std::cos(turn)), scale(north, std::sin(turn)));
      const Vec3d q = normalize(add(p, scale(way, 40000.0 / radius)));
      const SurfaceType type = sampler.at(q, with->rules().mesh_level + 2, 0.0).type;
      if (type == SurfaceType::sea || type == SurfaceType::coast) {
        near_coast.push_back(p);
        break;
      }
    }
  }
  ASSERT_GT(near_coast.size(), 200u);
  const double smooth = ground_steps(with, near_coast), rough = ground_steps(without, near_coast);
  EXPECT_LT(smooth, 0.9 * rough) << smooth << " m against " << rough << " m per 200 m";
}

TEST(ReliefRegions, LandVerticesKnowHowFarTheCoastIs) {
  // The distance a land vertex carries runs along the mesh, so it is never shorter than the
  // great circle to the nearest coast vertex, less what its hectometres round off: up to 50 m
  // on the base level, and 50 m more at each level a split carries it down (the stored mesh is
  // two levels below the base).
  const auto& planet = test::default_planet();
  const std::vector<Vertex>& vertices = planet->base_mesh().hierarchy.vertices;
  std::vector<Vec3d> coast;
  for (const Vertex& v : vertices) {
    if ((v.flags & kCoast) != 0) coast.push_back(v.p);
  }
  ASSERT_GT(coast.size(), 100u);
  int land = 0;
  for (const Vertex& v : vertices) {
    if ((v.flags & kSea) != 0) continue;
    if ((v.flags & kCoast) != 0) {
      EXPECT_EQ(coast_distance(v), 0.0);
      continue;
    }
    double nearest = std::numeric_limits<double>::infinity();
    for (const Vec3d& c : coast) nearest = std::min(nearest, angle(v.p, c));
    EXPECT_GE(coast_distance(v) + 150.0, nearest * planet->definition().radius);
    EXPECT_GT(coast_distance(v), 0.0);
    ++land;
  }
  EXPECT_GT(land, 1000);
}

}  // namespace
}  // namespace planet
