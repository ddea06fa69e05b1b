// The open sea's floor (planet.md "The cone points"): refined to its finest level and no finer,
// the same for a tile's grid as for a lone sample, continuous where it meets sea that is refined
// further, and cheap beside the octahedron's cone points.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <utility>

#include "default_definition.hpp"
#include "planet/planet.hpp"
#include "planet/tiles.hpp"
#include "sample_grids.hpp"

namespace planet {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// A zoom-12 tile touching each of the four cone points on the equator (geographic TMS).
constexpr terrain::TileAddress kConePointTiles[] = {
    {12, 8191, 2048}, {12, 4095, 2048}, {12, 6144, 2047}, {12, 2047, 2047}};

double wrapped(double longitude) {
  return longitude >= 180.0   ? longitude - 360.0
         : longitude < -180.0 ? longitude + 360.0
                              : longitude;
}

// The first coast met going east along `latitude` from `longitude` in steps of 0.05°, sampled at
// the open sea's finest level: the longitude of its last sea sample (NaN if none within 60°).
double longitude_of_coast(const std::shared_ptr<const Planet>& world, double latitude,
                          double longitude) {
  Sampler sampler(world);
  const auto type = [&](double lon) {
    return sampler
        .at(world->geodesy().direction(latitude, wrapped(lon)), world->rules().sea_finest_level,
            0.0)
        .type;
  };
  for (double lon = longitude; lon < longitude + 60.0; lon += 0.05) {
    if (type(lon) == SurfaceType::sea && type(lon + 0.05) != SurfaceType::sea) return lon;
  }
  return std::nan("");
}

TEST(OpenSea, ATileBesideAConePointRefinesAboutAsLittleAsATileOnLand) {
  const auto& world = test::default_planet();
  const std::size_t base = world->base_mesh().hierarchy.tris.size();
  for (const terrain::TileAddress& address : kConePointTiles) {
    PlanetTiles tiles(world);
    ASSERT_TRUE(tiles.make(address, terrain::TileFormat::terrain_rgb).ok());
    // About 1 000 triangles beyond the base mesh; 1.44 million when the open sea was refined to
    // the level of the tile (its triangles there are twenty times smaller than elsewhere).
    EXPECT_LT(tiles.cached_triangles() - base, 20000U) << address.x << ", " << address.y;
  }
}

TEST(OpenSea, FinerLevelsGiveTheFloorOfItsFinestLevel) {
  const auto& world = test::default_planet();
  const Rules& rules = world->rules();
  ASSERT_LT(rules.sea_finest_level, rules.max_level);
  EXPECT_GE(rules.edge_length(rules.sea_finest_level), 2000.0);
  EXPECT_LT(rules.edge_length(rules.sea_finest_level + 1), 2000.0);
  Sampler sampler(world);
  // Around each cone point, open sea for hundreds of kilometres.
  for (const double lon : {-180.0, -90.0, 0.0, 90.0}) {
    for (int i = 0; i < 50; ++i) {
      const Vec3d p = world->geodesy().direction(-1.0 + 0.04 * i, wrapped(lon - 1.5 + 0.06 * i));
      const PointSample coarse = sampler.at(p, rules.sea_finest_level, 0.0);
      ASSERT_EQ(coarse.type, SurfaceType::sea);
      for (const int level : {rules.sea_finest_level + 1, rules.max_level}) {
        EXPECT_EQ(sampler.at(p, level, 0.0).ground, coarse.ground) << lon << " #" << i;
      }
    }
  }
}

TEST(OpenSea, GridSamplesAreTheSamplesOfALoneDescent) {
  const auto& world = test::default_planet();
  const Rules& rules = world->rules();
  const double coast = longitude_of_coast(world, 5.0, -179.0);
  ASSERT_FALSE(std::isnan(coast));
  int total = 0, floored = 0;
  // Astride the coast (open sea, sea beside the coast refined further, land) and at a cone
  // point, at the open sea's finest level and finer, samples from a fifth of an edge to two
  // edges apart.
  for (const auto& [lat, lon] : {std::pair{5.0, coast}, std::pair{0.0, 179.95}}) {
    for (int level = rules.sea_finest_level - 1; level <= rules.max_level; level += 3) {
      for (const double spacing : {0.2, 0.9, 2.0}) {
        const double step = spacing * rules.edge_length(level) / rules.radius / kDegree;
        test::expect_grid_is_lone_samples(world, test::grid_around(*world, lat, lon, step, 21, 24),
                                          level, total, floored);
        if (HasFatalFailure()) return;
      }
    }
  }
  EXPECT_GT(total, 10000);
}

TEST(OpenSea, FloorIsContinuousWhereItMeetsSeaRefinedFurther) {
  const auto& world = test::default_planet();
  const Rules& rules = world->rules();
  Sampler sampler(world), coarse(world);
  const double coast = longitude_of_coast(world, 5.0, -179.0);
  ASSERT_FALSE(std::isnan(coast));
  // From 10 km out to the coast, 0.5 m apart at the finest level. Triangles with a corner on the
  // coast are refined below the open sea's finest level, so the walk crosses where open-sea
  // triangles stop and refined ones begin (there the finest level's floor differs from the open
  // sea's finest level's). The floor's slope makes steps of about a centimetre; with the
  // roughness of the finer levels kept in the refined sea, its floor stood 17 cm off the open
  // sea's where they met.
  const double step = 0.5 / (rules.radius * std::cos(5.0 * kDegree)) / kDegree;
  const int count = static_cast<int>(10000.0 / 0.5);
  double last = std::nan(""), steepest = 0.0;
  int open = 0, refined = 0;
  for (int i = -count; i < 2 * count; ++i) {
    const Vec3d p = world->geodesy().direction(5.0, wrapped(coast + i * step));
    const PointSample s = sampler.at(p, rules.max_level, 0.0);
    if (s.type != SurfaceType::sea) break;
    if (!std::isnan(last)) steepest = std::max(steepest, std::abs(s.ground - last));
    last = s.ground;
    ++(coarse.at(p, rules.sea_finest_level, 0.0).ground == s.ground ? open : refined);
  }
  EXPECT_GT(open, count / 2);
  EXPECT_GT(refined, 10);
  EXPECT_LT(steepest, 0.05) << "a step in the sea floor";
}

}  // namespace
}  // namespace planet
