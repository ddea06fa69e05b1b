// Grids of samples laid out as tiles lay theirs out, and the check that a grid's samples are
// those of lone descents, bit for bit (the drainage model's and the warp's tests).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include "planet/planet.hpp"
#include "planet/smooth_surface.hpp"

namespace planet::test {

// A rows × cols grid around (lat, lon), `step` degrees apart, laid out as tiles lay theirs out:
// latitudes falling with the row, longitudes rising with the column (past ±180° where it
// crosses), directions from the wrapped longitude.
struct Grid {
  std::vector<double> latitude, longitude, sin_lat, cos_lat, sin_lon, cos_lon;
  std::vector<Vec3d> directions;
  SampleGrid view() const {
    return {static_cast<int>(latitude.size()),
            static_cast<int>(longitude.size()),
            latitude,
            longitude,
            sin_lat,
            cos_lat,
            sin_lon,
            cos_lon};
  }
};

inline Grid grid_around(const Planet& planet, double lat, double lon, double step, int rows,
                        int cols) {
  constexpr double kDegree = std::numbers::pi / 180.0;
  Grid g;
  for (int r = 0; r < rows; ++r) {
    g.latitude.push_back(std::clamp(lat + step * (rows / 2 - r), -90.0, 90.0));
    g.sin_lat.push_back(std::sin(g.latitude.back() * kDegree));
    g.cos_lat.push_back(std::cos(g.latitude.back() * kDegree));
  }
  for (int c = 0; c < cols; ++c) {
    g.longitude.push_back(lon + step * (c - cols / 2));
    double wrapped = g.longitude.back();
    if (wrapped >= 180.0) wrapped -= 360.0;
    if (wrapped < -180.0) wrapped += 360.0;
    g.sin_lon.push_back(std::sin(wrapped * kDegree));
    g.cos_lon.push_back(std::cos(wrapped * kDegree));
  }
  for (std::size_t r = 0; r < g.latitude.size(); ++r) {
    for (std::size_t c = 0; c < g.longitude.size(); ++c) {
      g.directions.push_back(
          planet.geodesy().direction(g.sin_lat[r], g.cos_lat[r], g.sin_lon[c], g.cos_lon[c]));
    }
  }
  return g;
}

// Samples `g` as a grid at `level` and each direction alone: the same bits (ground, water, type).
// Counts the samples and those a floor lowered below the cubic of their dry leaf.
inline void expect_grid_is_lone_samples(const std::shared_ptr<const Planet>& world, const Grid& g,
                                        int level, int& total, int& floored) {
  Sampler gridded(world), lone(world);
  std::vector<PointSample> out(g.directions.size());
  gridded.grid(g.view(), level, 0.0,
               [&](std::size_t i, const PointSample& sample) { out[i] = sample; });
  Hierarchy h = world->base_mesh().hierarchy;
  for (std::size_t i = 0; i < g.directions.size(); ++i) {
    const PointSample b = lone.at_from_root(g.directions[i], level, 0.0);
    ASSERT_EQ(out[i].ground, b.ground)
        << g.latitude[i / g.longitude.size()] << ", " << g.longitude[i % g.longitude.size()]
        << " level " << level << " #" << i;
    ASSERT_EQ(out[i].water, b.water);
    ASSERT_EQ(out[i].type, b.type);
    ++total;
    // Where the planet evaluates the sample: the direction its warp moves it to.
    const Vec3d p = world->warp(g.directions[i], level);
    const Tri tri = h.tris[static_cast<std::size_t>(h.locate(p, level))];
    const std::array<const Vertex*, 3> corner = {&h.vertices[tri.v[0]], &h.vertices[tri.v[1]],
                                                 &h.vertices[tri.v[2]]};
    if (tri.face != FaceType::land || !all_dry(corner)) continue;
    const double cubic =
        clough_tocher(corner, barycentric(corner[0]->p, corner[1]->p, corner[2]->p, p),
                      world->definition().radius);
    floored += out[i].ground < cubic - 1e-6 ? 1 : 0;
  }
}

// `trials` grids anywhere — on land, astride coasts, the antimeridian, the equator and near a
// pole — at levels from the stored mesh to a few metres, with samples from a fifth of an edge to
// two edges apart: every sample of each is what a lone sample's walk to its floors gives. Many
// samples must have been floored, else this compares the surface without its floors.
inline void expect_grids_anywhere_are_lone_samples(const std::shared_ptr<const Planet>& world,
                                                   std::uint64_t seed, int trials) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int floored = 0, total = 0;
  for (int trial = 0; trial < trials; ++trial) {
    double lat = -60.0 + 120.0 * unit(random), lon = -180.0 + 360.0 * unit(random);
    if (trial % 6 == 1) lon = 179.9;              // across the antimeridian
    if (trial % 6 == 2) lat = 0.0;                // the equator
    if (trial % 6 == 3) lat = 89.95;              // the pole in the grid's ring
    if (trial % 6 == 4) lat = 5.0, lon = -175.0;  // the realism square's land
    const int level = world->rules().mesh_level + static_cast<int>(unit(random) * 24.0);
    const double spacing = world->rules().edge_length(level) * (0.2 + 1.8 * unit(random));
    const double step = spacing / world->definition().radius * 180.0 / std::numbers::pi;
    const int rows = 20 + trial % 5, cols = 23;
    expect_grid_is_lone_samples(world, grid_around(*world, lat, lon, step, rows, cols), level,
                                total, floored);
    if (::testing::Test::HasFatalFailure()) return;
  }
  EXPECT_GT(floored, total / 20) << floored << " of " << total;
  EXPECT_GT(total, 10000);
}

}  // namespace planet::test
