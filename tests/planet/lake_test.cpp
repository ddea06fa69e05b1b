// Lakes (issue 20 item 2; planet/src/lakes.hpp, docs/planet.md "Lakes").
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <set>
#include <vector>

#include "default_definition.hpp"
#include "planet/planet.hpp"
#include "planet/tiles.hpp"

namespace planet {
namespace {

using test::default_definition;

const std::shared_ptr<const Planet>& shared_planet() {
  return test::default_planet();
}

// A lake of the base mesh: its two triangles and its water level.
struct Lake {
  std::array<std::int32_t, 2> tris{};
  double level = 0.0;
};

// Every lake, found by its inner edge (the one edge both of its triangles share).
std::vector<Lake> lakes_of(const BaseMesh& mesh) {
  std::vector<Lake> lakes;
  for (std::int32_t t : mesh.leaves) {
    const Tri& tri = mesh.hierarchy.tris[static_cast<std::size_t>(t)];
    for (std::size_t k = 0; k < 3; ++k) {
      if (tri.edge[k] != EdgeType::lake || tri.nb[k] < t) continue;
      Lake lake;
      lake.tris = {t, tri.nb[k]};
      lake.level = mesh.hierarchy.vertices[tri.v[0]].water;
      lakes.push_back(lake);
    }
  }
  return lakes;
}

// A point inside triangle t, by barycentric weights (a, b, 1 − a − b).
Vec3d inside(const Hierarchy& h, std::int32_t t, double a, double b) {
  const Tri& tri = h.tris[static_cast<std::size_t>(t)];
  return normalize(add(add(scale(h.vertices[tri.v[0]].p, a), scale(h.vertices[tri.v[1]].p, b)),
                       scale(h.vertices[tri.v[2]].p, 1.0 - a - b)));
}

TEST(PlanetLakes, TheDefaultPlanetHasOpenAndClosedLakes) {
  const BaseMesh& mesh = shared_planet()->base_mesh();
  // Up to `lakes` where river edges qualify: the default planet's lifted rivers leave sites for
  // 22 of its 24 (every candidate is tried).
  EXPECT_LE(mesh.stats.lakes, shared_planet()->definition().lakes);
  EXPECT_GE(mesh.stats.lakes, shared_planet()->definition().lakes * 3 / 4);
  EXPECT_GT(mesh.stats.closed_lakes, 0);
  EXPECT_LT(mesh.stats.closed_lakes, mesh.stats.lakes);
  const std::vector<Lake> lakes = lakes_of(mesh);
  ASSERT_EQ(static_cast<int>(lakes.size()), mesh.stats.lakes);
  for (const Lake& lake : lakes) {
    for (std::int32_t t : lake.tris) {
      const Tri& tri = mesh.hierarchy.tris[static_cast<std::size_t>(t)];
      EXPECT_EQ(tri.face, FaceType::lake);
      for (std::uint32_t v : tri.v) {
        const Vertex& x = mesh.hierarchy.vertices[v];
        EXPECT_NE(x.flags & kLake, 0);
        EXPECT_EQ(x.water, lake.level) << "one level over the whole lake";
        EXPECT_LE(x.ground, x.water);
        EXPECT_GT(x.water, mesh.rules.def.sea_level - mesh.rules.def.sea_depth);
      }
    }
  }
}

TEST(PlanetLakes, WaterStandsLevelOverTheLakeFloorAtEveryLevel) {
  const auto& world = shared_planet();
  const BaseMesh& mesh = world->base_mesh();
  Sampler sampler(world);
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> u(0.05, 0.9);
  int lake_samples = 0, samples = 0, deep = 0;
  for (const Lake& lake : lakes_of(mesh)) {
    for (int level :
         {mesh.rules.mesh_level, mesh.rules.mesh_level + 6, mesh.rules.mesh_level + 14}) {
      for (std::int32_t t : lake.tris) {
        for (int i = 0; i < 12; ++i) {
          double a = u(random), b = u(random);
          if (a + b > 0.95) a *= 0.5, b *= 0.5;
          const PointSample s = sampler.at(inside(mesh.hierarchy, t, a, b), level, 0.0);
          ++samples;
          if (s.type != SurfaceType::lake) continue;  // the shore wiggles into the triangles
          ++lake_samples;
          EXPECT_NEAR(s.water, lake.level, 1e-9 * std::max(1.0, std::abs(lake.level)));
          EXPECT_LE(s.ground, s.water);
          if (level > mesh.rules.mesh_level && s.ground < s.water - 10.0) ++deep;
        }
      }
    }
  }
  // Most of a lake's triangles are water at every level, and refinement makes their floor.
  EXPECT_GT(lake_samples, samples * 7 / 10);
  EXPECT_GT(deep, lake_samples / 3);
}

TEST(PlanetLakes, OnlyAnOpenLakesOutletRiverLeavesIt) {
  // Refined around each lake, every vertex next to the lake stands above its water, but for those
  // of an open lake's outlet river, which leaves it downhill.
  const BaseMesh& mesh = shared_planet()->base_mesh();
  const int level = mesh.rules.mesh_level + 8;
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int open = 0, closed = 0;
  for (const Lake& lake : lakes_of(mesh)) {
    Hierarchy h = mesh.hierarchy;
    std::set<std::uint32_t> corners;
    for (std::int32_t t : lake.tris) {
      for (std::uint32_t v : h.tris[static_cast<std::size_t>(t)].v) corners.insert(v);
    }
    // The lake's triangles and every triangle touching it.
    std::vector<std::int32_t> around;
    for (std::int32_t t : mesh.leaves) {
      for (std::uint32_t v : h.tris[static_cast<std::size_t>(t)].v) {
        if (corners.contains(v)) {
          around.push_back(t);
          break;
        }
      }
    }
    for (std::int32_t t : around) {
      for (int i = 0; i < 60; ++i) {
        double a = u(random), b = u(random);
        if (a + b > 1) a = 1 - a, b = 1 - b;
        h.locate(inside(h, t, a, b), level);
      }
    }
    const auto in_lake = [&](const Vertex& v) {
      return (v.flags & kLake) != 0 && v.water == lake.level;
    };
    // An open lake keeps the river edge from its outlet down; a closed lake has none.
    bool is_open = false;
    for (std::int32_t t : around) {
      const Tri& tri = h.tris[static_cast<std::size_t>(t)];
      for (std::size_t k = 0; k < 3; ++k) {
        const std::uint32_t a = tri.v[k], b = tri.v[(k + 1) % 3];
        is_open = is_open || (tri.edge[k] == EdgeType::river &&
                              ((corners.contains(a) && h.vertices[b].water < lake.level) ||
                               (corners.contains(b) && h.vertices[a].water < lake.level)));
      }
    }
    int outlets = 0, rim = 0;
    for (const Tri& t : h.tris) {
      if (t.child[0] >= 0) continue;
      for (std::size_t k = 0; k < 3; ++k) {
        for (auto [from, to] :
             {std::pair{t.v[k], t.v[(k + 1) % 3]}, std::pair{t.v[(k + 1) % 3], t.v[k]}}) {
          const Vertex& x = h.vertices[from];
          const Vertex& y = h.vertices[to];
          if (!in_lake(x) || in_lake(y)) continue;
          if (outflow_level(y) > lake.level) {
            ++rim;
            continue;
          }
          EXPECT_TRUE(is_open) << "a closed lake at " << lake.level << " leaks";
          // The outlet river (beside an open lake's outlet its vertices may also touch the
          // shore next to it).
          EXPECT_NE(y.flags & kRiver, 0) << "water leaves a lake only by its outlet river";
          ++outlets;
        }
      }
    }
    EXPECT_GT(rim, 20);
    if (is_open) {
      EXPECT_GT(outlets, 0) << "an open lake at " << lake.level << " has no outlet";
      ++open;
    } else {
      ++closed;
    }
  }
  EXPECT_EQ(closed, mesh.stats.closed_lakes);
  EXPECT_EQ(open + closed, mesh.stats.lakes);
}

TEST(PlanetLakes, AridityDecidesWhichLakesAreClosed) {
  PlanetDefinition d = default_definition();
  d.aridity = 0.0;
  const auto humid = Planet::create(d);
  EXPECT_EQ(humid->base_mesh().stats.closed_lakes, 0);
  EXPECT_GT(humid->base_mesh().stats.lakes, 0);
  d.aridity = 1.0;
  const auto arid = Planet::create(d);
  EXPECT_EQ(arid->base_mesh().stats.closed_lakes, arid->base_mesh().stats.lakes);
  d.lakes = 0;
  const auto none = Planet::create(d);
  EXPECT_EQ(none->base_mesh().stats.lakes, 0);
  EXPECT_TRUE(lakes_of(none->base_mesh()).empty());
}

TEST(PlanetLakes, AreWaterInSamplesAndWaterMasks) {
  const auto& world = shared_planet();
  const BaseMesh& mesh = world->base_mesh();
  const Lake lake = lakes_of(mesh).front();
  double lat = 0.0, lon = 0.0;
  world->geodesy().direction_to_geographic(inside(mesh.hierarchy, lake.tris[0], 0.3, 0.3), lat,
                                           lon);
  Sampler sampler(world);
  const PointSample s = sampler.sample(lat, lon);
  EXPECT_EQ(s.type, SurfaceType::lake);
  EXPECT_EQ(sample_json(lat, lon, s).at("type"), "lake");
  // The zoom-6 tile holding that point has more water with the lakes than without them.
  const int zoom = 6;
  const double size = 180.0 / (1 << zoom);
  const terrain::TileAddress address{zoom, static_cast<std::int64_t>((lon + 180.0) / size),
                                     static_cast<std::int64_t>((lat + 90.0) / size)};
  PlanetDefinition dry = default_definition();
  dry.lakes = 0;
  const auto wet_pixels = [&](const std::shared_ptr<const Planet>& planet) {
    PlanetTiles tiles(planet);
    Result<std::vector<std::uint8_t>> mask = tiles.water_mask(address);
    EXPECT_TRUE(mask.ok());
    if (mask->size() == 1) return (*mask)[0] != 0 ? 65536L : 0L;
    return static_cast<long>(std::count(mask->begin(), mask->end(), 255));
  };
  EXPECT_GT(wet_pixels(world), wet_pixels(Planet::create(dry)) + 1000);
}

}  // namespace
}  // namespace planet
