// Seeded planets end to end: reproducible base meshes, continents at the requested land fraction,
// rivers that drain to the sea and never cross, heights independent of evaluation order, tiles
// identical in any order, thread and process, exact shared edges and centimetre precision.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <thread>

#include "../terrain/quantized_mesh_dip.hpp"
#include "default_definition.hpp"
#include "planet/picture.hpp"
#include "planet/planet.hpp"
#include "planet/tiles.hpp"
#include "river_walk.hpp"
#include "terrain/gzip.hpp"
#include "terrain/quantized_mesh.hpp"

namespace planet {
namespace {

using terrain::TileAddress;
using terrain::TileFormat;

using test::default_definition;
using test::follow_river;

const std::shared_ptr<const Planet>& shared_planet() {
  return test::default_planet();
}

// A direction inside the base triangle t (its centroid).
Vec3d centroid(const Hierarchy& h, std::int32_t t) {
  const Tri& tri = h.tris[static_cast<std::size_t>(t)];
  return normalize(
      add(add(h.vertices[tri.v[0]].p, h.vertices[tri.v[1]].p), h.vertices[tri.v[2]].p));
}

// The first base-mesh leaf whose three vertices all have `flags`.
std::int32_t leaf_with(const BaseMesh& mesh, std::uint8_t flags) {
  for (std::int32_t t : mesh.leaves) {
    const Tri& tri = mesh.hierarchy.tris[static_cast<std::size_t>(t)];
    bool all = true;
    for (std::uint32_t v : tri.v) all = all && (mesh.hierarchy.vertices[v].flags & flags) != 0;
    if (all) return t;
  }
  return -1;
}

// ---------------------------------------------------------------------------------------------
// Base mesh

TEST(PlanetBaseMesh, IsIdenticalAcrossRunsAndThreadCounts) {
  const PlanetDefinition d = default_definition(99);
  const std::string one = build_base_mesh(d, {1})->hash();
  EXPECT_EQ(one, build_base_mesh(d, {1})->hash());
  EXPECT_EQ(one, build_base_mesh(d, {2})->hash());
  EXPECT_EQ(one, build_base_mesh(d, {4})->hash());
  EXPECT_NE(one, build_base_mesh(default_definition(100), {1})->hash());
}

TEST(PlanetBaseMesh, HashIsIdenticalInAnotherProcess) {
  // The CLI is another process with its own address space and allocation order.
  const std::string out = testing::TempDir() + "/planet_mesh.json";
  const std::string command = std::string(PLANET_CLI) + " mesh " + TERRAIN_SOURCE_DIR +
                              "/config/planets/default.json --threads 2 > " + out;
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream in(out);
  const nlohmann::json report = nlohmann::json::parse(in);
  Result<PlanetDefinition> d = load_planet_file(TERRAIN_SOURCE_DIR "/config/planets/default.json");
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(report.at("hash").get<std::string>(), build_base_mesh(*d)->hash());
  EXPECT_EQ(report.at("id").get<std::string>(), planet_id(*d));
}

TEST(PlanetBaseMesh, LandFractionIsWithinTwoPercentOfTheRequest) {
  for (double land : {0.2, 0.35, 0.5}) {
    for (std::uint64_t seed : {1u, 2u, 3u}) {
      const auto mesh = build_base_mesh(default_definition(seed, land));
      EXPECT_NEAR(mesh->stats.land_fraction, land, 0.02) << "seed " << seed;
    }
  }
}

TEST(PlanetBaseMesh, FacesBesideTheConePointsAreSeaOnEveryPlanet) {
  // The four equatorial vertices of the octahedron, and nothing else (the poles are regular).
  for (const Vec3d& cone : {Vec3d{1, 0, 0}, Vec3d{-1, 0, 0}, Vec3d{0, 1, 0}, Vec3d{0, -1, 0}}) {
    EXPECT_TRUE(near_cone_point(cone));
    EXPECT_TRUE(near_cone_point(normalize(add(cone, {0.0, 0.0, 0.9 * kConePointSea}))));
    EXPECT_FALSE(near_cone_point(normalize(add(cone, {0.0, 0.0, 1.1 * kConePointSea}))));
  }
  EXPECT_FALSE(near_cone_point({0, 0, 1}));
  EXPECT_FALSE(near_cone_point(normalize({1, 1, 0})));
  // Seven tenths land: without the rule, continents cover cone points on every one of these seeds.
  for (std::uint64_t seed : {1u, 2u, 3u, 4u}) {
    const auto mesh = build_base_mesh(default_definition(seed, 0.7));
    int beside = 0;
    for (std::int32_t t : mesh->river_faces) {
      const Tri& tri = mesh->hierarchy.tris[static_cast<std::size_t>(t)];
      if (!touches_cone_point(mesh->hierarchy, tri)) continue;
      ++beside;
      EXPECT_NE(tri.face, FaceType::land) << "seed " << seed << " face " << t;
    }
    EXPECT_GE(beside, 4) << "seed " << seed;
    EXPECT_NEAR(mesh->stats.land_fraction, 0.7, 0.02) << "seed " << seed;
  }
}

TEST(PlanetBaseMesh, EveryRiverFallsMonotonicallyToTheSea) {
  const BaseMesh& mesh = shared_planet()->base_mesh();
  const auto& vertices = mesh.hierarchy.vertices;
  int rivers = 0;
  for (std::size_t v = 0; v < mesh.downstream.size(); ++v) {
    if ((vertices[v].flags & kLand) == 0) continue;
    ASSERT_NE(vertices[v].flags & kRiver, 0) << "every continental vertex is on a river (§4.2)";
    ++rivers;
    const std::size_t at = follow_river(mesh, v);
    // The end is a mouth on the coast at sea level, a lake (PlanetLakes.* check where lakes
    // lead), or an allowed endorheic basin.
    if ((vertices[at].flags & kLake) != 0) continue;
    if ((vertices[at].flags & kCoast) != 0) {
      EXPECT_EQ(vertices[at].water, mesh.rules.def.sea_level);
      EXPECT_LT(vertices[at].ground, vertices[at].water);
    } else {
      EXPECT_GT(mesh.stats.endorheic, 0);
    }
  }
  EXPECT_GT(rivers, 100);
  EXPECT_GT(mesh.stats.mouths, 20);
}

TEST(PlanetBaseMesh, EveryRiverVertexDrainsItsShareAndEverythingUpstream) {
  const BaseMesh& mesh = shared_planet()->base_mesh();
  const auto& vertices = mesh.hierarchy.vertices;
  const std::size_t count = mesh.downstream.size();
  const double radius = mesh.rules.radius;
  const double share = 4.0 * std::numbers::pi * radius * radius / static_cast<double>(count);
  std::vector<double> inflow(count, 0.0);
  for (std::size_t v = 0; v < count; ++v) {
    if (mesh.downstream[v] >= 0) {
      inflow[static_cast<std::size_t>(mesh.downstream[v])] += vertices[v].drainage_area;
    }
  }
  double largest = 0.0;
  int rivers = 0;
  // Lakes give their vertices their outlet's area (PlanetLakes.*): the network's sums hold where
  // no lake vertex drains in.
  std::vector<bool> lake_inflow(count, false);
  for (std::size_t v = 0; v < count; ++v) {
    if (mesh.downstream[v] >= 0 && (vertices[v].flags & kLake) != 0) {
      lake_inflow[static_cast<std::size_t>(mesh.downstream[v])] = true;
    }
  }
  for (std::size_t v = 0; v < count; ++v) {
    if ((vertices[v].flags & kRiver) == 0 || !(vertices[v].water > vertices[v].ground)) continue;
    if ((vertices[v].flags & kLake) != 0 || lake_inflow[v]) continue;
    ++rivers;
    EXPECT_NEAR(vertices[v].drainage_area, share + inflow[v], 1e-6 * (share + inflow[v])) << v;
    largest = std::max(largest, static_cast<double>(vertices[v].drainage_area));
  }
  EXPECT_GT(rivers, 100);
  // The largest river drains many base cells: trunks and headwaters differ.
  EXPECT_NEAR(mesh.stats.largest_drainage_area, largest, 1e-6 * largest);
  EXPECT_GT(largest, 10.0 * share);
}

/// Flint's law over a base network's river edges: the least-squares θ of log S against log A,
/// S the water's fall along the edge over its length and A what its upper end drains (edges at
/// lakes left out: a lake's level is its spill's). Also checks every edge falls at least the
/// least river slope for its area.
double base_river_concavity(const BaseMesh& mesh) {
  const PlanetDefinition& def = mesh.rules.def;
  const auto& vertices = mesh.hierarchy.vertices;
  std::vector<double> log_area, log_slope;
  for (std::size_t v = 0; v < mesh.downstream.size(); ++v) {
    const Vertex& x = vertices[v];
    if ((x.flags & kLand) == 0 || (x.flags & kLake) != 0 || mesh.downstream[v] < 0) continue;
    const Vertex& y = vertices[static_cast<std::size_t>(mesh.downstream[v])];
    if ((y.flags & kLake) != 0) continue;
    const double length = angle(x.p, y.p) * mesh.rules.radius;
    const double slope = (x.water - y.water) / length;
    const double area = x.drainage_area;
    const double least = def.min_river_slope *
                         std::min(1.0, std::pow(area / def.river_slope_area, -def.river_concavity));
    EXPECT_GE(slope, least * (1.0 - 1e-6)) << v;
    log_area.push_back(std::log10(area));
    log_slope.push_back(std::log10(slope));
  }
  EXPECT_GT(log_area.size(), 100u);
  const auto n = static_cast<double>(log_area.size());
  double ma = 0.0, ms = 0.0;
  for (std::size_t k = 0; k < log_area.size(); ++k) ma += log_area[k] / n, ms += log_slope[k] / n;
  double saa = 0.0, sas = 0.0;
  for (std::size_t k = 0; k < log_area.size(); ++k) {
    saa += (log_area[k] - ma) * (log_area[k] - ma);
    sas += (log_area[k] - ma) * (log_slope[k] - ms);
  }
  return -sas / saa;
}

TEST(PlanetBaseMesh, RiverProfilesAreConcaveByFlintsLaw) {
  // The default river_concavity: rivers that drain more fall more gently, and the land stands
  // lower. Straight profiles (river_concavity 0, the paper's) rise at s_r or the same share of
  // the way to the spring along the whole river.
  // The displacement model's rivers (the drainage model's climb at their least slope and with
  // the uplift, tested with the relief regions).
  PlanetDefinition def = default_definition();
  def.relief_model = ReliefModel::displacement;
  const std::shared_ptr<const BaseMesh> concave_mesh = build_base_mesh(def, {1});
  const BaseMesh& concave = *concave_mesh;
  def.river_concavity = 0.0;
  const std::shared_ptr<const BaseMesh> straight = build_base_mesh(def, {1});
  // Measured: θ 0.32 (the random share of each rise and the least slope's floor keep it below
  // river_concavity) and 0.00; mean river levels 885 and 1 561 m.
  EXPECT_GT(base_river_concavity(concave), 0.25);
  EXPECT_LT(base_river_concavity(concave), default_definition().river_concavity + 0.1);
  EXPECT_NEAR(base_river_concavity(*straight), 0.0, 0.05);
  const auto mean_river_level = [](const BaseMesh& mesh) {
    double sum = 0.0;
    int count = 0;
    for (const Vertex& x : mesh.hierarchy.vertices) {
      if ((x.flags & kLand) != 0 && (x.flags & kRiver) != 0) sum += x.water, ++count;
    }
    return sum / count;
  };
  EXPECT_LT(mean_river_level(concave), 0.7 * mean_river_level(*straight));
}

// ---------------------------------------------------------------------------------------------
// Refinement

// A hierarchy refined around `count` random points of a base triangle to `extra` levels deeper.
Hierarchy refined_patch(const BaseMesh& mesh, std::int32_t base, int extra, int count,
                        std::uint64_t seed) {
  Hierarchy h = mesh.hierarchy;
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Tri& tri = mesh.hierarchy.tris[static_cast<std::size_t>(base)];
  for (int i = 0; i < count; ++i) {
    double a = u(random), b = u(random);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const Vec3d p = normalize(
        add(add(scale(h.vertices[tri.v[0]].p, 1 - a - b), scale(h.vertices[tri.v[1]].p, a)),
            scale(h.vertices[tri.v[2]].p, b)));
    h.locate(p, mesh.rules.mesh_level + extra);
  }
  return h;
}

TEST(PlanetRefinement, HeightsDoNotDependOnWhatWasEvaluatedBefore) {
  const auto& world = shared_planet();
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> lat(-80, 80), lon(-180, 180);
  std::vector<std::pair<double, double>> points;
  for (int i = 0; i < 300; ++i) points.emplace_back(lat(random), lon(random));
  Sampler first(world), second(world);
  std::vector<PointSample> a;
  for (auto [phi, lambda] : points) a.push_back(first.sample(phi, lambda, 30.0));
  // Another sampler that refined elsewhere first and then asks in reverse order.
  for (int i = 0; i < 200; ++i) second.sample(lat(random), lon(random), 5.0);
  for (std::size_t i = points.size(); i-- > 0;) {
    const PointSample b = second.sample(points[i].first, points[i].second, 30.0);
    EXPECT_EQ(a[i].ground, b.ground);
    EXPECT_EQ(a[i].water, b.water);
    EXPECT_EQ(a[i].type, b.type);
  }
}

// The sample route keeps a sampler per planet and thread: random samples at full detail, as a
// hostile client might send, must not grow it past its bound, and it must trim on its own.
TEST(PlanetRefinement, ASamplersCacheStaysBoundedUnderRandomFullDetailSamples) {
  const auto& world = shared_planet();
  std::mt19937_64 random(23);
  std::uniform_real_distribution<double> lat(-90, 90), lon(-180, 180);
  Sampler sampler(world);
  std::size_t most = 0, held = sampler.cached_triangles();
  bool trimmed = false;
  for (int i = 0; i < 20000 && !trimmed; ++i) {
    (void)sampler.sample(lat(random), lon(random));
    trimmed = sampler.cached_triangles() < held;
    held = sampler.cached_triangles();
    most = std::max(most, held);
  }
  EXPECT_TRUE(trimmed) << "no trim in 20 000 samples, " << held << " triangles held";
  // One sample past the bound adds at most a few hundred triangles before the next one trims.
  EXPECT_LE(most, Sampler::kTrimTriangles + 4096);
}

// Tiles start each sample's descent at a triangle shared by a block of samples (DescentStart),
// or walk to it from the last sample's leaf, or start from the last descent's path. Whatever the
// block — tiny or wide, deep or shallow, astride the octahedron's edges and the antimeridian —
// every sample must land where a lone descent from the root lands: same ground, water, type
// and river distance, bit for bit.
TEST(PlanetRefinement, DescentStartsGiveTheSamplesOfADescentFromTheRoot) {
  const auto& world = shared_planet();
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int started = 0, total = 0;
  for (int trial = 0; trial < 60; ++trial) {
    // Centres anywhere, and some exactly on octahedron edges (the equator, lon 0, ±90, 180).
    double lat = -89.0 + 178.0 * unit(random), lon = -180.0 + 360.0 * unit(random);
    if (trial % 4 == 1) lat = 0.0;
    if (trial % 4 == 2) lon = 90.0 * std::floor(unit(random) * 4.0) - 180.0;
    const double extent = std::ldexp(30.0, -static_cast<int>(unit(random) * 20.0));  // degrees
    const int level = world->rules().mesh_level + static_cast<int>(unit(random) * 28.0);
    const double octaves = 3.0 * unit(random);
    auto direction = [&](double i, double j) {
      double la = std::clamp(lat + extent * (i - 0.5), -90.0, 90.0);
      double lo = lon + extent * (j - 0.5);
      if (lo >= 180.0) lo -= 360.0;
      if (lo < -180.0) lo += 360.0;
      return world->geodesy().direction(la, lo);
    };
    constexpr int kSide = 9;
    std::vector<Vec3d> outline;
    for (int k = 0; k < kSide; ++k) {
      const double f = k / (kSide - 1.0);
      for (const Vec3d& p : {direction(0, f), direction(1, f), direction(f, 0), direction(f, 1)}) {
        outline.push_back(p);
      }
    }
    Sampler blocked(world), lone(world);
    const DescentStart start = blocked.descent_start(direction(0.5, 0.5), outline, level);
    for (int i = 0; i < kSide; ++i) {
      for (int j = 0; j < kSide; ++j) {
        const Vec3d p = direction(i / (kSide - 1.0), j / (kSide - 1.0));
        started += start.holds(p) ? 1 : 0;
        ++total;
        const PointSample a = blocked.at(p, level, octaves, start);
        const PointSample b = lone.at_from_root(p, level, octaves);
        ASSERT_EQ(a.ground, b.ground) << lat << ", " << lon << " extent " << extent;
        ASSERT_EQ(a.water, b.water);
        ASSERT_EQ(a.type, b.type);
        ASSERT_EQ(a.river_distance, b.river_distance);
      }
    }
  }
  // Most samples did use a start (else this would test nothing).
  EXPECT_GT(started, total / 2);
}

// Tiles add the detail noise to many samples at once, four lanes at a time where the CPU has
// AVX2: every sum must be the one a lone direction gets, bit for bit, whatever the octave count
// (fractional ones fade their last octave in) and however many directions (a tail of one to
// three runs one by one).
TEST(PlanetDetail, ManyDirectionsAtOnceGiveTheDetailOfEach) {
  const auto& world = shared_planet();
  std::mt19937_64 random(13);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const double octaves : {0.0, 14.5, 17.0, 19.3, 23.75, 31.0, 40.0}) {
    for (const std::size_t n : {std::size_t{1}, std::size_t{3}, std::size_t{4}, std::size_t{257}}) {
      std::vector<Vec3d> directions;
      for (std::size_t i = 0; i < n; ++i) {
        directions.push_back(normalize({unit(random), unit(random), unit(random)}));
      }
      std::vector<double> together(n);
      world->detail(directions, octaves, together);
      for (std::size_t i = 0; i < n; ++i) {
        const double alone = world->detail(directions[i], octaves);
        ASSERT_EQ(std::bit_cast<std::uint64_t>(together[i]), std::bit_cast<std::uint64_t>(alone))
            << "octaves " << octaves << ", direction " << i << " of " << n;
      }
    }
  }
  // The octaves below finest_edge do carry detail (else this would compare zeros).
  EXPECT_GT(world->detail(normalize({0.3, 0.5, 0.8}), 20.0), 0.0);
}

// Samples a tile's row apart walk from leaf to leaf, or start from the last descent's path.
// At the finest level (10 m edges) and at levels whose edges are a few samples long, in rows as
// tiles take them, one by one or a row at once (the detail noise of the row computed together),
// every sample is the one a lone descent from the root gives, bit for bit.
TEST(PlanetRefinement, SamplesWalkingFromTheLastLeafGiveTheSamplesOfADescentFromTheRoot) {
  const auto& world = shared_planet();
  std::mt19937_64 random(12);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 24; ++trial) {
    double lat = -89.0 + 178.0 * unit(random), lon = -180.0 + 360.0 * unit(random);
    if (trial % 6 == 1) lat = 0.0;  // astride an octahedron edge
    const int level = trial % 2 == 0
                          ? world->rules().max_level
                          : world->rules().mesh_level + static_cast<int>(unit(random) * 20.0);
    // Samples from a fifth to twice an edge apart.
    const double spacing = world->rules().edge_length(level) * (0.2 + 1.8 * unit(random));
    const double step = spacing / world->definition().radius * 180.0 / std::numbers::pi;
    Sampler walking(world), batch(world), lone(world);
    constexpr int kSide = 24;
    std::vector<Vec3d> row;
    std::vector<PointSample> batched(kSide);
    // Octaves beyond finest_edge's, so that the detail noise is part of what is compared.
    const double octaves = trial % 3 == 0 ? 0.0 : world->octaves_for_spacing(spacing);
    for (int i = 0; i < kSide; ++i) {
      row.clear();
      for (int j = 0; j < kSide; ++j) {
        double lo = lon + step * (j - kSide / 2);
        if (lo >= 180.0) lo -= 360.0;
        row.push_back(
            world->geodesy().direction(std::clamp(lat - step * (i - kSide / 2), -90.0, 90.0), lo));
      }
      batch.at(row, level, octaves, DescentStart{}, batched);
      for (int j = 0; j < kSide; ++j) {
        const Vec3d& p = row[static_cast<std::size_t>(j)];
        const PointSample b = lone.at_from_root(p, level, octaves);
        for (const PointSample& a :
             {walking.at(p, level, octaves), batched[static_cast<std::size_t>(j)]}) {
          ASSERT_EQ(a.ground, b.ground) << lat << ", " << lon << " level " << level;
          ASSERT_EQ(a.water, b.water);
          ASSERT_EQ(a.type, b.type);
          ASSERT_EQ(a.river_distance, b.river_distance);
        }
      }
    }
  }
}

TEST(PlanetRefinement, TrianglesStayPositivelyOrientedSoRiversCannotCross) {
  const BaseMesh& mesh = shared_planet()->base_mesh();
  const std::int32_t base = leaf_with(mesh, kRiver);
  ASSERT_GE(base, 0);
  const Hierarchy h = refined_patch(mesh, base, 10, 400, 11);
  for (const Tri& t : h.tris) {
    if (t.child[0] >= 0 || t.level < mesh.rules.mesh_level) continue;
    EXPECT_GT(det(h.vertices[t.v[0]].p, h.vertices[t.v[1]].p, h.vertices[t.v[2]].p), 0.0);
  }
  // River edges of the refined leaves: no two cross (they may only meet at vertices).
  std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (const Tri& t : h.tris) {
    if (t.child[0] >= 0) continue;
    for (std::size_t k = 0; k < 3; ++k) {
      if (t.edge[k] != EdgeType::river) continue;
      const std::uint32_t a = t.v[k], b = t.v[(k + 1) % 3];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  }
  ASSERT_GT(edges.size(), 20u);
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> list(edges.begin(), edges.end());
  for (std::size_t i = 0; i < list.size(); ++i) {
    for (std::size_t j = i + 1; j < list.size(); ++j) {
      const auto [a, b] = list[i];
      const auto [c, d] = list[j];
      if (a == c || a == d || b == c || b == d) continue;
      const Vec3d &pa = h.vertices[a].p, &pb = h.vertices[b].p, &pc = h.vertices[c].p,
                  &pd = h.vertices[d].p;
      const bool cross = det(pa, pb, pc) * det(pa, pb, pd) < 0 &&
                         det(pc, pd, pa) * det(pc, pd, pb) < 0 && dot(add(pa, pb), add(pc, pd)) > 0;
      EXPECT_FALSE(cross) << "river edges " << i << " and " << j << " cross";
    }
  }
}

TEST(PlanetRefinement, RefinedRiversStillDrainDownhill) {
  const BaseMesh& mesh = shared_planet()->base_mesh();
  const std::int32_t base = leaf_with(mesh, kRiver);
  const Hierarchy h = refined_patch(mesh, base, 12, 400, 17);
  // Every river vertex on a refined leaf has a river edge to a vertex with lower water (or is
  // a mouth on the coast): following the lowest such edge reaches the sea.
  std::map<std::uint32_t, double> lowest;  // river vertex → lowest water of its river neighbours
  for (const Tri& t : h.tris) {
    if (t.child[0] >= 0) continue;
    for (std::size_t k = 0; k < 3; ++k) {
      if (t.edge[k] != EdgeType::river) continue;
      const std::uint32_t a = t.v[k], b = t.v[(k + 1) % 3];
      for (auto [x, y] : {std::pair{a, b}, std::pair{b, a}}) {
        auto [it, inserted] = lowest.emplace(x, h.vertices[y].water);
        if (!inserted) it->second = std::min(it->second, h.vertices[y].water);
      }
    }
  }
  ASSERT_GT(lowest.size(), 20u);
  // Downstream along every refined river edge, the drainage area never shrinks.
  for (const Tri& t : h.tris) {
    if (t.level < mesh.rules.mesh_level) continue;
    for (std::size_t k = 0; k < 3; ++k) {
      if (t.edge[k] != EdgeType::river) continue;
      const Vertex& a = h.vertices[t.v[k]];
      const Vertex& b = h.vertices[t.v[(k + 1) % 3]];
      const Vertex& down = a.water < b.water ? a : b;
      const Vertex& up = a.water < b.water ? b : a;
      EXPECT_GE(down.drainage_area, up.drainage_area);
    }
  }
  int checked = 0;
  for (auto [v, low] : lowest) {
    const Vertex& x = h.vertices[v];
    if ((x.flags & (kCoast | kLake)) != 0) continue;  // a mouth into the sea or a lake
    EXPECT_LT(low, x.water) << "river vertex " << v << " has no way down";
    ++checked;
  }
  EXPECT_GT(checked, 20);
}

TEST(PlanetRefinement, EveryDryVertexDrainsToALowerNeighbourAtEveryLevel) {
  // Drain edges (refine.cpp): a land vertex stands above the corner it drains to, and a split of
  // that edge puts its vertex between the two, so at every level each dry vertex keeps a strictly
  // lower neighbour and the piecewise-linear surface has no pits.
  const BaseMesh& mesh = shared_planet()->base_mesh();
  const std::int32_t base = leaf_with(mesh, kRiver);
  const Hierarchy h = refined_patch(mesh, base, 12, 400, 23);
  const auto outflow = [](const Vertex& v) {
    const bool wet = (v.flags & (kRiver | kCoast | kSea)) != 0;
    return wet ? std::max(v.water, v.ground) : v.ground;
  };
  int checked = 0;
  for (int level = mesh.rules.mesh_level + 1; level <= mesh.rules.mesh_level + 12; ++level) {
    // A vertex's star at this level is whole where its triangles' angles at it add up to 2π.
    std::map<std::uint32_t, double> angle_sum;
    std::set<std::uint32_t> drains_down;
    for (const Tri& t : h.tris) {
      if (t.level != level) continue;
      for (std::size_t k = 0; k < 3; ++k) {
        const Vec3d& v = h.vertices[t.v[k]].p;
        angle_sum[t.v[k]] +=
            angle(sub(h.vertices[t.v[(k + 1) % 3]].p, v), sub(h.vertices[t.v[(k + 2) % 3]].p, v));
        if (t.edge[k] != EdgeType::drain) continue;
        const std::uint32_t a = t.v[k], b = t.v[(k + 1) % 3];
        ASSERT_NE(outflow(h.vertices[a]), outflow(h.vertices[b])) << "a level drain edge";
        drains_down.insert(outflow(h.vertices[a]) > outflow(h.vertices[b]) ? a : b);
      }
    }
    for (const auto& [v, sum] : angle_sum) {
      const Vertex& x = h.vertices[v];
      if ((x.flags & (kRiver | kCoast | kSea)) != 0 || std::abs(sum - 2 * std::numbers::pi) > 1e-6)
        continue;
      EXPECT_TRUE(drains_down.contains(v)) << "dry vertex " << v << " is a pit at level " << level;
      ++checked;
    }
  }
  EXPECT_GT(checked, 200);
}

// ---------------------------------------------------------------------------------------------
// Samples

TEST(PlanetSample, ReportsSeaLandAndRivers) {
  const auto& world = shared_planet();
  const BaseMesh& mesh = world->base_mesh();
  Sampler sampler(world);
  double lat = 0, lon = 0;
  world->geodesy().direction_to_geographic(centroid(mesh.hierarchy, leaf_with(mesh, kSea)), lat,
                                           lon);
  const PointSample sea = sampler.sample(lat, lon);
  EXPECT_EQ(sea.type, SurfaceType::sea);
  EXPECT_EQ(sea.water, world->definition().sea_level);
  EXPECT_LT(sea.ground, sea.water);
  // The deepest river vertex away from the coast: the river is there.
  const auto& vertices = mesh.hierarchy.vertices;
  std::size_t river = vertices.size();
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    if ((vertices[v].flags & (kLand | kCoast)) != kLand) continue;
    const double depth = vertices[v].water - vertices[v].ground;
    if (river == vertices.size() || depth > vertices[river].water - vertices[river].ground) {
      river = v;
    }
  }
  ASSERT_LT(river, vertices.size());
  ASSERT_GT(vertices[river].water, vertices[river].ground + 50);
  world->geodesy().direction_to_geographic(vertices[river].p, lat, lon);
  const PointSample wet = sampler.sample(lat, lon);
  EXPECT_EQ(wet.type, SurfaceType::river);
  EXPECT_GT(wet.water, wet.ground);
  // Land: the highest base vertex.
  const auto top = std::max_element(vertices.begin(), vertices.end(),
                                    [](auto& a, auto& b) { return a.ground < b.ground; });
  world->geodesy().direction_to_geographic(top->p, lat, lon);
  const PointSample high = sampler.sample(lat, lon);
  EXPECT_EQ(high.type, SurfaceType::land);
  EXPECT_GT(high.ground, 1000.0);
  EXPECT_EQ(high.water, high.ground);
  const nlohmann::json body = sample_json(lat, lon, high);
  EXPECT_EQ(body.at("type"), "land");
}

TEST(PlanetSample, GroundIsContinuousBesideRivers) {
  // Valley floors (planet.cpp) bend the ground inside triangles with river or coast corners;
  // both triangles along a shared edge must still agree. Lines from inland river vertices cross
  // the fans of triangles around them: a seam would show as one step between close samples
  // larger than the steps on either side of it that does not shrink when the samples close in
  // (a step of a continuous surface can outgrow its neighbours a little where the slope peaks,
  // at an inflection, but shrinks with the spacing).
  const auto& world = shared_planet();
  const BaseMesh& mesh = world->base_mesh();
  const int level = mesh.rules.mesh_level + 20;
  const double step = 4.0 * mesh.rules.edge_length(level) / 20000.0;  // across about four fans
  const double radius = world->definition().radius;
  Sampler sampler(world);
  int lines = 0;
  int candidates = 0;
  for (std::int32_t t : mesh.leaves) {
    const Tri& tri = mesh.hierarchy.tris[static_cast<std::size_t>(t)];
    const Vertex& river = mesh.hierarchy.vertices[tri.v[0]];
    if ((river.flags & kRiver) == 0 || (river.flags & kCoast) != 0 || tri.face != FaceType::land)
      continue;
    // Towards a point beside the triangle's centroid, across the fan rather than along an edge.
    const Vec3d towards = centroid(mesh.hierarchy, t);
    const Vec3d direction = normalize(sub(towards, scale(river.p, dot(towards, river.p))));
    auto at = [&](double metres) {
      const double arc = metres / radius;
      return sampler
          .at(normalize(add(scale(river.p, std::cos(arc)), scale(direction, std::sin(arc)))), level,
              0.0)
          .ground;
    };
    std::vector<double> ground;
    for (int i = 0; i <= 20000; ++i) ground.push_back(at(i * step));
    for (std::size_t i = 2; i + 1 < ground.size(); ++i) {
      const double before = std::abs(ground[i - 1] - ground[i - 2]);
      const double here = std::abs(ground[i] - ground[i - 1]);
      const double after = std::abs(ground[i + 1] - ground[i]);
      if (here <= std::max(before, after) + 1e-4) continue;
      // Somewhere in this step: a tenth of it, at each of its ten places.
      ++candidates;
      double largest = 0.0;
      for (int k = 0; k < 10; ++k) {
        const double from = (static_cast<double>(i) - 1.0 + 0.1 * k) * step;
        largest = std::max(largest, std::abs(at(from + 0.1 * step) - at(from)));
      }
      ASSERT_LT(largest, 0.5 * here)
          << "a seam " << static_cast<double>(i) * step << " m from a river: a step of " << here
          << " m keeps " << largest << " m at a tenth of the spacing";
    }
    if (++lines == 8) break;
  }
  EXPECT_EQ(lines, 8);
  RecordProperty("candidates", candidates);
}

TEST(PlanetSample, ReportsTheAreaTheNearestRiverDrains) {
  const auto& world = shared_planet();
  const auto& vertices = world->base_mesh().hierarchy.vertices;
  const auto mouth = std::max_element(vertices.begin(), vertices.end(), [](auto& a, auto& b) {
    return a.drainage_area < b.drainage_area;
  });
  double lat = 0, lon = 0;
  world->geodesy().direction_to_geographic(mouth->p, lat, lon);
  Sampler sampler(world);
  const PointSample at_mouth = sampler.sample(lat, lon, 10000.0);
  EXPECT_LT(at_mouth.river_distance, 1.0);
  EXPECT_EQ(at_mouth.river_drainage_area, mouth->drainage_area);
  // Far from any river (the open sea): none.
  world->geodesy().direction_to_geographic(
      centroid(world->base_mesh().hierarchy, leaf_with(world->base_mesh(), kSea)), lat, lon);
  EXPECT_EQ(sampler.sample(lat, lon, 10000.0).river_drainage_area, 0.0);
}

TEST(PlanetGeodesy, DirectionsAgreeWithGeographicLib) {
  for (double flattening : {0.0, 1.0 / 298.257223563}) {
    Geodesy g(6378137.0, flattening);
    for (double lat : {-89.0, -45.0, 0.0, 30.0, 89.9}) {
      for (double lon : {-179.0, 0.0, 77.0}) {
        const Vec3d d = g.direction(lat, lon);
        const Vec3d e = normalize(g.ecef(lat, lon, 0.0));
        for (int i = 0; i < 3; ++i)
          EXPECT_NEAR(d[static_cast<std::size_t>(i)], e[static_cast<std::size_t>(i)], 1e-15);
        double back_lat = 0, back_lon = 0;
        g.direction_to_geographic(d, back_lat, back_lon);
        EXPECT_NEAR(back_lat, lat, 1e-11);
        EXPECT_NEAR(back_lon, lon, 1e-11);
      }
    }
    // A degree of latitude at the equator: 110.57 km on WGS84, π·R/180 on the sphere.
    EXPECT_NEAR(g.distance(0, 0, 1, 0), flattening == 0 ? 111319.49 : 110574.39, 0.01);
  }
}

// ---------------------------------------------------------------------------------------------
// Tiles

std::vector<std::uint8_t> bytes_of(PlanetTiles& tiles, TileAddress a, TileFormat f,
                                   const terrain::ProductOptions& o = {}) {
  Result<terrain::Product> p = tiles.make(a, f, o);
  if (!p) throw std::runtime_error(p.error().pointer + ": " + p.error().message);
  return std::move(p->bytes);
}

terrain::HeightTile corners(PlanetTiles& tiles, TileAddress a, int grid = 65) {
  terrain::ProductOptions o;
  o.grid = grid;
  Result<terrain::HeightTile> t = tiles.height_tile(a, TileFormat::quantized_mesh, o);
  if (!t) throw std::runtime_error(t.error().pointer + ": " + t.error().message);
  return std::move(t).value();
}

TEST(PlanetTiles, AreIdenticalInAnyOrderThreadAndProcess) {
  const auto& world = shared_planet();
  std::vector<std::pair<TileAddress, TileFormat>> jobs = {
      {{0, 0, 0}, TileFormat::terrain_rgb},      {{3, 9, 5}, TileFormat::gray16},
      {{6, 70, 40}, TileFormat::quantized_mesh}, {{9, 600, 300}, TileFormat::terrarium},
      {{12, 4500, 2300}, TileFormat::glb},       {{3, 10, 5}, TileFormat::normal_map}};
  // And a tile over a lake's shore (PlanetLakes.*), with its water mask.
  const BaseMesh& mesh = world->base_mesh();
  for (std::int32_t t : mesh.leaves) {
    if (mesh.hierarchy.tris[static_cast<std::size_t>(t)].face != FaceType::lake) continue;
    const Vec3d shore =
        mesh.hierarchy.vertices[mesh.hierarchy.tris[static_cast<std::size_t>(t)].v[2]].p;
    double lat = 0.0, lon = 0.0;
    world->geodesy().direction_to_geographic(shore, lat, lon);
    const double size = 180.0 / (1 << 10);
    jobs.push_back({{10, static_cast<std::int64_t>((lon + 180.0) / size),
                     static_cast<std::int64_t>((lat + 90.0) / size)},
                    TileFormat::quantized_mesh});
    break;
  }
  ASSERT_EQ(jobs.size(), 7u);
  std::vector<std::vector<std::uint8_t>> forward;
  {
    PlanetTiles tiles(world);
    for (auto [a, f] : jobs) forward.push_back(bytes_of(tiles, a, f));
  }
  {
    PlanetTiles tiles(world);
    for (std::size_t i = jobs.size(); i-- > 0;) {
      EXPECT_EQ(bytes_of(tiles, jobs[i].first, jobs[i].second), forward[i]) << i;
    }
  }
  std::vector<std::vector<std::uint8_t>> threaded(jobs.size());
  std::vector<std::thread> pool;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    pool.emplace_back([&, i] {
      PlanetTiles tiles(world);
      threaded[i] = bytes_of(tiles, jobs[i].first, jobs[i].second);
    });
  }
  for (auto& t : pool) t.join();
  EXPECT_EQ(threaded, forward);
  // Another process: the CLI writes tile 3/9/5 as gray16.
  const std::string out = testing::TempDir() + "/planet_tile.png";
  const std::string command = std::string(PLANET_CLI) + " tile " + TERRAIN_SOURCE_DIR +
                              "/config/planets/default.json 3 9 5 --encoding gray16 -o " + out +
                              " > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream in(out, std::ios::binary);
  const std::vector<std::uint8_t> file((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(file, forward[1]);
}

// A tile thread trims its refinement back to the base mesh every few tiles while a user pans
// (PlanetTiles::kTrimTriangles); what a tile holds must not depend on it.
TEST(PlanetTiles, AreIdenticalAfterTheirRefinementIsTrimmed) {
  const auto& world = shared_planet();
  PlanetTiles tiles(world);
  const TileAddress first{10, 1000, 600};
  const std::vector<std::uint8_t> before = bytes_of(tiles, first, TileFormat::terrain_rgb);
  // Tiles east of it until the refinement has grown past the bound and been trimmed: the sampler
  // then holds fewer triangles than after the tile before. The tile made first after the trim
  // is the one that could see what the sampler kept from before it.
  std::size_t held = tiles.cached_triangles(), most = held;
  bool trimmed = false;
  for (std::int64_t x = first.x + 1; x < first.x + 60 && !trimmed; ++x) {
    const TileAddress a{first.z, x, first.y};
    const std::vector<std::uint8_t> bytes = bytes_of(tiles, a, TileFormat::terrain_rgb);
    trimmed = tiles.cached_triangles() < held;
    held = tiles.cached_triangles();
    most = std::max(most, held);
    if (trimmed) {
      PlanetTiles fresh(world);
      EXPECT_EQ(bytes, bytes_of(fresh, a, TileFormat::terrain_rgb)) << "tile x = " << x;
    }
  }
  ASSERT_TRUE(trimmed) << "no trim within 60 tiles of " << PlanetTiles::kTrimTriangles;
  // The tiles' own bound, not a lone sampler's (2^20): one tile past it (here about 60 000
  // triangles past it: the tile that crosses it starts below it).
  EXPECT_LE(most, PlanetTiles::kTrimTriangles + (std::size_t{1} << 17));
  EXPECT_EQ(bytes_of(tiles, first, TileFormat::terrain_rgb), before);
}

TEST(PlanetTiles, NeighboursShareEdgesExactly) {
  PlanetTiles tiles(shared_planet());
  for (TileAddress a :
       {TileAddress{2, 3, 1}, TileAddress{9, 601, 300}, TileAddress{15, 38000, 20000}}) {
    const terrain::HeightTile t = corners(tiles, a);
    const terrain::HeightTile east = corners(tiles, {a.z, a.x + 1, a.y});
    const terrain::HeightTile north = corners(tiles, {a.z, a.x, a.y + 1});
    const int n = t.width;
    for (int i = 0; i < n; ++i) {
      EXPECT_EQ(t.elevation[t.index(n - 1, i)], east.elevation[east.index(0, i)]) << a.z;
      EXPECT_EQ(t.slope_east[t.index(n - 1, i)], east.slope_east[east.index(0, i)]) << a.z;
      EXPECT_EQ(t.elevation[t.index(i, 0)], north.elevation[north.index(i, n - 1)]) << a.z;
    }
  }
}

// CesiumJS draws flat triangles between ECEF vertices: over the sea, a large triangle of a coarse
// tile cuts under the globe and its outline becomes a polygon. The default planet's tiles, adaptive
// and full grid, must dip under the curved surface by at most the error the tileset declares.
TEST(PlanetTiles, QuantizedMeshDipsUnderTheCurvedSurfaceByAtMostTheDeclaredError) {
  PlanetTiles tiles(
      Planet::create(load_planet_file(TERRAIN_SOURCE_DIR "/config/planets/default.json").value()));
  for (const bool regular : {false, true}) {
    terrain::ProductOptions options;
    options.regular = regular;
    for (int z = 0; z <= 6; ++z) {
      double worst = 0.0;
      std::size_t vertices = 0;
      // Also a tile over the central continent (about 20° N, 20° E), not only sea and ice.
      const std::int64_t land_x = static_cast<std::int64_t>((200.0 / 180.0) * std::ldexp(1.0, z));
      const std::int64_t land_y = static_cast<std::int64_t>((110.0 / 180.0) * std::ldexp(1.0, z));
      const auto probes = terrain::testing::curvature_probe_tiles(z, {{z, land_x, land_y}});
      for (const TileAddress& a : probes) {
        const auto raw = terrain::gzip_decompress(
            bytes_of(tiles, a, TileFormat::quantized_mesh, options), 1u << 26);
        ASSERT_TRUE(raw.ok());
        Result<terrain::QuantizedMesh> qm = terrain::decode_quantized_mesh(*raw);
        ASSERT_TRUE(qm.ok()) << qm.error().message;
        const double dip = terrain::testing::max_dip_below_surface(
            *qm, terrain::testing::geographic_tile_bounds(a), regular ? 4 : 8);
        EXPECT_LE(dip, terrain::testing::cesium_level_maximum_geometric_error(z))
            << (regular ? "regular " : "adaptive ") << a.z << "/" << a.x << "/" << a.y;
        worst = std::max(worst, dip);
        vertices += qm->u.size();
      }
      std::printf("%s zoom %d: %.1f vertices per tile, largest dip %.0f m, declared error %.0f m\n",
                  regular ? "regular" : "adaptive", z, double(vertices) / double(probes.size()),
                  worst, terrain::testing::cesium_level_maximum_geometric_error(z));
    }
  }
}

TEST(PlanetTiles, KeepCentimetrePrecisionAtZoom22) {
  PlanetTiles tiles(shared_planet());
  // A zoom-22 tile (about 8 m across) and its parent: the child's even samples are the parent's
  // samples of the same quadrant, and only detail finer than 15 cm separates them.
  const TileAddress child{22, 2400001, 1300003};
  const TileAddress parent{21, child.x / 2, child.y / 2};
  const terrain::HeightTile c = corners(tiles, child);
  const terrain::HeightTile p = corners(tiles, parent);
  const int half = 32;
  const int col0 = static_cast<int>(child.x % 2) * half;
  const int row0 = static_cast<int>(1 - child.y % 2) * half;  // TMS: y grows north, rows south
  double worst = 0.0;
  for (int r = 0; r <= 64; r += 2) {
    for (int k = 0; k <= 64; k += 2) {
      const double diff =
          c.elevation[c.index(k, r)] - p.elevation[p.index(col0 + k / 2, row0 + r / 2)];
      worst = std::max(worst, std::abs(diff));
    }
  }
  EXPECT_LT(worst, 0.01);
  // And the heights vary smoothly at the centimetre scale: no float staircase of half metres
  // (the distinct heights lie within a centimetre of each other).
  std::set<float> distinct(c.elevation.begin(), c.elevation.end());
  EXPECT_GT(distinct.size(), 100u);
  float widest_step = 0.0f;
  for (auto it = distinct.begin(); std::next(it) != distinct.end(); ++it) {
    widest_step = std::max(widest_step, *std::next(it) - *it);
  }
  // The slope spaces the 12.5 cm samples' heights: up to 0.12 here, so a step of 1.5 cm.
  EXPECT_LT(widest_step, 0.02f);
  for (int r = 0; r < 65; ++r) {
    for (int k = 1; k < 65; ++k) {
      EXPECT_LT(std::abs(c.elevation[c.index(k, r)] - c.elevation[c.index(k - 1, r)]), 0.5f);
    }
  }
}

TEST(PlanetTiles, QuantizedMeshCarriesHeightsAndAWaterMask) {
  PlanetTiles tiles(shared_planet());
  // A zoom-2 tile holding both sea and land (the planet has both; one of the 32 tiles must).
  TileAddress a{2, 0, 0};
  std::size_t most_mixed = 0;
  for (std::int64_t x = 0; x < 8; ++x) {
    for (std::int64_t y = 0; y < 4; ++y) {
      Result<std::vector<std::uint8_t>> mask = tiles.water_mask({2, x, y});
      ASSERT_TRUE(mask.ok());
      if (mask->size() == 1) continue;
      const auto wet = static_cast<std::size_t>(std::count(mask->begin(), mask->end(), 255));
      const std::size_t mixed = std::min(wet, mask->size() - wet);
      if (mixed > most_mixed) most_mixed = mixed, a = {2, x, y};
    }
  }
  const terrain::HeightTile t = corners(tiles, a);
  Result<std::vector<std::uint8_t>> raw =
      terrain::gzip_decompress(bytes_of(tiles, a, TileFormat::quantized_mesh), 1u << 26);
  ASSERT_TRUE(raw.ok());
  Result<terrain::QuantizedMesh> qm = terrain::decode_quantized_mesh(*raw);
  ASSERT_TRUE(qm.ok()) << qm.error().message;
  const double quantum = std::max((qm->header.maximum_height - qm->header.minimum_height) / 32767.0,
                                  tiles.constants_at(2).edge_quantum);
  for (std::size_t k = 0; k < qm->vertex_count(); ++k) {
    const int col = static_cast<int>(std::lround(qm->u[k] / 32767.0 * 64));
    const int row = 64 - static_cast<int>(std::lround(qm->v[k] / 32767.0 * 64));
    EXPECT_NEAR(qm->height_metres(k), t.elevation[t.index(col, row)], quantum / 2 + 1e-6);
  }
  ASSERT_TRUE(qm->water_mask.has_value());
  ASSERT_EQ(qm->water_mask->size(), 65536u);
  const auto wet = std::count(qm->water_mask->begin(), qm->water_mask->end(), 255);
  EXPECT_GT(wet, 6500);  // at least a tenth each of water and land
  EXPECT_LT(wet, 65536 - 6500);
  const nlohmann::json layer = tiles.layer_json({});
  EXPECT_EQ(layer.at("projection"), "EPSG:4326");
  EXPECT_EQ(layer.at("available").size(), static_cast<std::size_t>(PlanetTiles::max_zoom() + 1));
}

TEST(PlanetTiles, BadRequestsAreRefusedNamingTheField) {
  PlanetTiles tiles(shared_planet());
  terrain::ProductOptions big;
  big.size = 100;
  const struct {
    TileAddress address;
    TileFormat format;
    terrain::ProductOptions options;
    const char* pointer;
  } cases[] = {
      {{30, 0, 0}, TileFormat::terrain_rgb, {}, "/z"},
      {{1, 4, 0}, TileFormat::terrain_rgb, {}, "/x"},
      {{1, 0, 2}, TileFormat::terrain_rgb, {}, "/y"},
      {{1, 0, 0}, TileFormat::terrain_rgb, big, "/size"},
  };
  for (const auto& c : cases) {
    Result<terrain::Product> p = tiles.make(c.address, c.format, c.options);
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.error().pointer, c.pointer);
  }
  Result<terrain::HeightTile> local = tiles.height_tile(terrain::TileRequest{
      terrain::TileScheme::local, {0, 0, 0}, terrain::SampleLayout::cell_centres, 256, 0});
  ASSERT_FALSE(local.ok());
  EXPECT_EQ(local.error().pointer, "/scheme");
  // Meshes are Cesium's: geographic only.
  Result<terrain::Product> mesh =
      tiles.make(terrain::TileScheme::webmercator, {1, 0, 0}, TileFormat::quantized_mesh);
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.error().pointer, "/scheme");
}

// glTF and Draco tiles on a planet's lattice (a quantum of metres at zoom 0): skirts at least a
// quantum deep however small max_error is, shortened to fit however large it is (both were
// refused), and a small planet's deep zooms refused naming the zoom where samples would be
// closer than the lattice.
TEST(PlanetTiles, MeshesFitThePositionLatticeOrAreRefusedNamingTheZoom) {
  PlanetTiles tiles(shared_planet());
  terrain::ProductOptions exact, loosest;
  exact.max_error = 0.0;
  loosest.max_error = 1e6;
  for (const TileFormat format : {TileFormat::glb, TileFormat::draco}) {
    for (const TileAddress& address : {TileAddress{0, 0, 0}, TileAddress{7, 200, 90}}) {
      for (const terrain::ProductOptions& options : {exact, loosest}) {
        const Result<terrain::Product> p = tiles.make(address, format, options);
        EXPECT_TRUE(p.ok()) << "zoom " << address.z << ": " << p.error().message;
      }
    }
  }
  PlanetDefinition small_definition = default_definition();
  small_definition.radius = 1000.0;
  PlanetTiles small(Planet::create(small_definition));
  int deepest = 0;
  while (deepest < PlanetTiles::max_zoom() &&
         small.planet().ground_spacing(deepest + 1, 64) >=
             small.constants_at(deepest + 1).position_quantum) {
    ++deepest;
  }
  ASSERT_LT(deepest, PlanetTiles::max_zoom());
  const Result<terrain::Product> served = small.make({deepest, 0, 0}, TileFormat::glb);
  EXPECT_TRUE(served.ok()) << served.error().message;
  const Result<terrain::Product> deeper = small.make({deepest + 1, 0, 0}, TileFormat::glb);
  ASSERT_FALSE(deeper.ok());
  EXPECT_EQ(deeper.error().pointer, "/z") << deeper.error().message;
  EXPECT_EQ(deeper.error().kind, terrain::ErrorKind::invalid);
}

// MapLibre reads EPSG:3857 only: a Web Mercator tile's samples are the planet at their own
// longitude and latitude, at the level of detail of the tile's spacing, and neighbours agree on
// the ring of samples they share.
TEST(PlanetTiles, WebMercatorTilesSampleThePlanetWhereEPSG3857PutsThem) {
  PlanetTiles tiles(shared_planet());
  const terrain::TileAddress a{4, 9, 7};
  Result<terrain::HeightTile> t =
      tiles.height_tile(terrain::TileScheme::webmercator, a, TileFormat::terrain_rgb);
  ASSERT_TRUE(t.ok()) << t.error().message;
  EXPECT_DOUBLE_EQ(t->ground_spacing, 2.0 * shared_planet()->ground_spacing(a.z, 256));
  Sampler sampler(shared_planet());
  for (const auto& [col, row] : {std::pair{0, 0}, {17, 200}, {128, 128}, {255, 3}}) {
    const double lon = terrain::web_mercator_longitude(t->sample_crs_x(col));
    const double lat = terrain::web_mercator_latitude(t->sample_crs_y(row));
    const PointSample p = sampler.sample(lat, lon, t->ground_spacing);
    EXPECT_NEAR(t->elevation[t->index(col, row)], p.ground, 1e-3) << col << "," << row;
  }
  EXPECT_NE(t->slope_north[t->index(128, 128)], 0.0f);
  // The tile east of it, with a border, holds this tile's eastern column as its border.
  terrain::ProductOptions bordered;
  bordered.border = true;
  Result<terrain::HeightTile> east = tiles.height_tile(
      terrain::TileScheme::webmercator, {a.z, a.x + 1, a.y}, TileFormat::terrain_rgb, bordered);
  ASSERT_TRUE(east.ok()) << east.error().message;
  for (int row = 0; row < 256; row += 15) {
    EXPECT_EQ(east->elevation[east->index(0, row + 1)], t->elevation[t->index(255, row)]) << row;
  }
  const Result<terrain::Product> png =
      tiles.make(terrain::TileScheme::webmercator, a, TileFormat::terrain_rgb);
  ASSERT_TRUE(png.ok()) << png.error().message;
  EXPECT_EQ(png->media_type, "image/png");
}

// Pictures draw rivers in one colour (planet/src/picture.cpp).
bool is_river_pixel(const std::uint8_t* rgb) {
  return rgb[0] == 40 && rgb[1] == 90 && rgb[2] == 230;
}

TEST(PlanetPicture, ShowsLandSeaAndRiversAndIsThreadIndependent) {
  PictureOptions options;
  options.width = 256;
  const std::vector<std::uint8_t> one = planet_picture_rgb(shared_planet(), options);
  options.threads = 3;
  EXPECT_EQ(planet_picture_rgb(shared_planet(), options), one);
  int blue = 0, green_or_brown = 0, river = 0;
  for (std::size_t i = 0; i < one.size(); i += 3) {
    if (is_river_pixel(&one[i])) {
      ++river;
    } else if (one[i + 2] > one[i] && one[i + 2] > one[i + 1]) {
      ++blue;
    } else {
      ++green_or_brown;
    }
  }
  const double pixels = static_cast<double>(one.size() / 3);
  EXPECT_GT(blue / pixels, 0.4);
  EXPECT_GT(green_or_brown / pixels, 0.15);
  EXPECT_GT(river, 50);
}

TEST(PlanetPicture, DrawsTrunksWiderThanHeadwaters) {
  // Strokes are wide where rivers drain much: the 3 × 3 pixels around the base network's
  // trunk vertices (draining over a quarter of the largest river's area) hold more river pixels
  // than those around its headwaters (springs draining their own share), and those few. With
  // straight river profiles (river_concavity 0), on which these bounds were set: with the
  // default concave ones the same strokes leave 2.97 river pixels around a headwater on average
  // against 2.25, as the rivers and arms near the springs move, not the strokes' widths.
  PlanetDefinition straight = default_definition();
  straight.river_concavity = 0.0;
  const std::shared_ptr<const Planet> world = Planet::create(straight);
  const BaseMesh& mesh = world->base_mesh();
  PictureOptions options;
  options.width = 1024;
  const std::vector<std::uint8_t> rgb = planet_picture_rgb(world, options);
  const int width = options.width, height = width / 2;
  const auto river_pixels_around = [&](const Vertex& v) {
    double lat = 0, lon = 0;
    world->geodesy().direction_to_geographic(v.p, lat, lon);
    const int row = static_cast<int>((90.0 - lat) / 360.0 * width);
    const int col = static_cast<int>((lon + 180.0) / 360.0 * width);
    int count = 0;
    for (int r = std::max(0, row - 1); r <= std::min(height - 1, row + 1); ++r) {
      for (int c = std::max(0, col - 1); c <= std::min(width - 1, col + 1); ++c) {
        count += is_river_pixel(&rgb[(static_cast<std::size_t>(r) * width + c) * 3]) ? 1 : 0;
      }
    }
    return count;
  };
  const auto& vertices = mesh.hierarchy.vertices;
  double trunk = 0.0, headwater = 0.0;
  int trunks = 0, headwaters = 0;
  std::vector<int> inflows(mesh.downstream.size(), 0);
  for (std::int32_t d : mesh.downstream) {
    if (d >= 0) ++inflows[static_cast<std::size_t>(d)];
  }
  for (std::size_t v = 0; v < mesh.downstream.size(); ++v) {
    const Vertex& x = vertices[v];
    if ((x.flags & kLand) == 0 || (x.flags & kCoast) != 0) continue;  // inland river vertices
    if (x.drainage_area > 0.25 * mesh.stats.largest_drainage_area) {
      trunk += river_pixels_around(x), ++trunks;
    } else if (inflows[v] == 0) {
      headwater += river_pixels_around(x), ++headwaters;
    }
  }
  ASSERT_GT(trunks, 3);
  ASSERT_GT(headwaters, 20);
  // Uniform strokes of 0.6 pixels either side (before drainage areas) gave 5.7 and 3.2 pixels of
  // the 3 × 3 around them; strokes by drainage area 4.9 and 2.1.
  EXPECT_GT(trunk / trunks, 2.0 * headwater / headwaters);
  EXPECT_LT(headwater / headwaters, 2.6);
}

}  // namespace
}  // namespace planet
