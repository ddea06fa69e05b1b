// Continental shelves (issue 20 item 3; docs/planet.md "Continental shelves").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "default_definition.hpp"
#include "planet/planet.hpp"

namespace planet {
namespace {

// Depths of the sea floor (metres below sea level) on lines from every tenth coast vertex of the
// base mesh towards its nearest sea vertex, at the given distances (metres) from the coast vertex,
// where the sample is sea.
std::vector<std::vector<double>> depths_off_the_coasts(const std::shared_ptr<const Planet>& world,
                                                       const std::vector<double>& distances) {
  const BaseMesh& mesh = world->base_mesh();
  const auto& vertices = mesh.hierarchy.vertices;
  const double radius = world->definition().radius;
  Sampler sampler(world);
  std::vector<std::vector<double>> out(distances.size());
  int coast = 0;
  for (const Vertex& c : vertices) {
    if (c.flags != kCoast || ++coast % 10 != 0) continue;
    const Vertex* sea = nullptr;
    for (const Vertex& s : vertices) {
      if (s.flags == kSea && (sea == nullptr || angle(c.p, s.p) < angle(c.p, sea->p))) sea = &s;
    }
    const Vec3d towards = normalize(sub(sea->p, scale(c.p, dot(sea->p, c.p))));
    for (std::size_t i = 0; i < distances.size(); ++i) {
      const double arc = distances[i] / radius;
      const Vec3d p = normalize(add(scale(c.p, std::cos(arc)), scale(towards, std::sin(arc))));
      const PointSample s = sampler.at(p, mesh.rules.mesh_level + 12, 0.0);
      if (s.type == SurfaceType::sea) out[i].push_back(world->definition().sea_level - s.ground);
    }
  }
  return out;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

TEST(PlanetShelves, TheSeaFloorIsShallowOnTheShelfAndFallsBeyondIt) {
  // Off every tenth coast vertex: on the shelf (20 and 50 km out) within its depth; past its
  // edge (80 km) down the continental slope to the ocean floor, where without shelves the floor
  // still rose gently towards the coast from the base mesh's sea vertices hundreds of km out.
  const std::vector<double> distances = {20000.0, 50000.0, 150000.0, 400000.0};
  PlanetDefinition d = test::default_definition();
  const auto with = depths_off_the_coasts(Planet::create(d), distances);
  d.shelf_width = 0.0;
  const auto without = depths_off_the_coasts(Planet::create(d), distances);
  for (std::size_t i = 0; i < distances.size(); ++i) {
    ASSERT_GT(with[i].size(), 20u);
    ASSERT_GT(without[i].size(), 20u);
  }
  EXPECT_LE(median(with[0]), d.shelf_depth);
  EXPECT_LE(median(with[1]), d.shelf_depth);
  EXPECT_GT(median(with[2]), 2000.0);
  EXPECT_LT(median(without[2]), 1000.0);
  EXPECT_GT(median(with[3]), 2000.0);
}

}  // namespace
}  // namespace planet
