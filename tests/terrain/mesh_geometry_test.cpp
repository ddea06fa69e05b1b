// Tile meshes resolved to scene coordinates, and skirts.
#include "terrain/mesh_geometry.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <utility>

#include "synthetic_tiles.hpp"

namespace terrain {
namespace {

using test_tiles::synthetic_tile;

TEST(MeshGeometry, VerticesTakeTheirSamplesPositionElevationAndNormal) {
  const HeightTile tile = synthetic_tile(2, 1, 2, 4);
  const Result<MeshGeometry> g = mesh_geometry(tile, triangulate_grid(tile.width));
  ASSERT_TRUE(g.ok()) << g.error().message;
  ASSERT_EQ(g->positions.size(), 25u);
  EXPECT_EQ(g->surface_vertices, 25u);
  EXPECT_EQ(g->triangles, triangulate_grid(5).triangles);
  for (std::uint32_t v = 0; v < 25; ++v) {
    EXPECT_EQ(g->samples[v], v);
    EXPECT_EQ(g->positions[v][0], tile.scene_x[v]);
    EXPECT_EQ(g->positions[v][1], tile.scene_y[v]);
    EXPECT_EQ(g->positions[v][2], static_cast<double>(tile.elevation[v]));
    EXPECT_EQ(g->normals[v], normal_from_slopes(tile.slope_east[v], tile.slope_north[v]));
  }
}

TEST(MeshGeometry, NormalsPointUphillOppositeTheSlope) {
  EXPECT_EQ(normal_from_slopes(0.0f, 0.0f), (std::array<float, 3>{0.0f, 0.0f, 1.0f}));
  const std::array<float, 3> east = normal_from_slopes(1.0f, 0.0f);  // rising to the east
  EXPECT_FLOAT_EQ(east[0], -std::sqrt(0.5f));
  EXPECT_FLOAT_EQ(east[1], 0.0f);
  EXPECT_FLOAT_EQ(east[2], std::sqrt(0.5f));
  const std::array<float, 3> north = normal_from_slopes(0.0f, -2.0f);  // falling to the north
  EXPECT_FLOAT_EQ(north[1], 2.0f / std::sqrt(5.0f));
  EXPECT_FLOAT_EQ(north[2], 1.0f / std::sqrt(5.0f));
}

TEST(Skirts, HangBelowEveryBoundaryVertexWithItsNormalAndFaceOutward) {
  const HeightTile tile = synthetic_tile(1, 0, 1, 4);
  Result<MeshGeometry> g = mesh_geometry(tile, triangulate_grid(tile.width));
  ASSERT_TRUE(g.ok()) << g.error().message;
  ASSERT_TRUE(add_skirts(*g, 40.0).ok());
  const int n = tile.width;
  const std::size_t boundary = 4 * static_cast<std::size_t>(n - 1);
  ASSERT_EQ(g->positions.size(), static_cast<std::size_t>(n * n) + boundary);
  EXPECT_EQ(g->surface_vertices, static_cast<std::uint32_t>(n * n));
  ASSERT_EQ(g->triangles.size(),
            3 * (2 * static_cast<std::size_t>((n - 1) * (n - 1)) + 2 * boundary));

  std::set<std::uint32_t> skirted;
  for (std::uint32_t v = g->surface_vertices; v < g->positions.size(); ++v) {
    const std::uint32_t top = g->samples[v];  // triangulate_grid: vertex index = sample index
    const int row = static_cast<int>(top) / n, column = static_cast<int>(top) % n;
    EXPECT_TRUE(row == 0 || row == n - 1 || column == 0 || column == n - 1) << top;
    EXPECT_TRUE(skirted.insert(top).second) << "sample " << top << " has two skirt copies";
    EXPECT_EQ(g->positions[v][0], g->positions[top][0]);
    EXPECT_EQ(g->positions[v][1], g->positions[top][1]);
    EXPECT_EQ(g->positions[v][2], g->positions[top][2] - 40.0);
    EXPECT_EQ(g->normals[v], g->normals[top]);
  }
  EXPECT_EQ(skirted.size(), boundary);

  // Every wall has a horizontal normal pointing away from the tile's centre.
  const double cx = (tile.bounds.west + tile.bounds.east) / 2;
  const double cy = (tile.bounds.south + tile.bounds.north) / 2;
  for (std::size_t t = 3 * 2 * static_cast<std::size_t>((n - 1) * (n - 1)); t < g->triangles.size();
       t += 3) {
    const auto& a = g->positions[g->triangles[t]];
    const auto& b = g->positions[g->triangles[t + 1]];
    const auto& c = g->positions[g->triangles[t + 2]];
    const std::array<double, 3> u{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const std::array<double, 3> w{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const std::array<double, 3> normal{u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                                       u[0] * w[1] - u[1] * w[0]};
    const double mx = (a[0] + b[0] + c[0]) / 3 - cx, my = (a[1] + b[1] + c[1]) / 3 - cy;
    EXPECT_GT(normal[0] * mx + normal[1] * my, 0.0) << "wall " << t / 3 << " faces inward";
    EXPECT_EQ(normal[2], 0.0) << "wall " << t / 3 << " is not vertical";
  }

  // With walls, the only edges used once are the skirt's bottom edges.
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (std::size_t i = 0; i < g->triangles.size(); ++i) {
    const std::uint32_t a = g->triangles[i], b = g->triangles[i - i % 3 + (i + 1) % 3];
    ++uses[{std::min(a, b), std::max(a, b)}];
  }
  for (const auto& [e, count] : uses) {
    if (count == 1) {
      EXPECT_GE(e.first, g->surface_vertices);
      EXPECT_GE(e.second, g->surface_vertices);
    }
  }
}

TEST(Skirts, OfZeroHeightAddNothing) {
  const HeightTile tile = synthetic_tile(0, 0, 0, 2);
  Result<MeshGeometry> g = mesh_geometry(tile, triangulate_grid(tile.width));
  ASSERT_TRUE(g.ok());
  const MeshGeometry before = *g;
  ASSERT_TRUE(add_skirts(*g, 0.0).ok());
  EXPECT_EQ(g->positions, before.positions);
  EXPECT_EQ(g->triangles, before.triangles);
}

TEST(Skirts, RefuseBadHeightsAndInconsistentOrientation) {
  const HeightTile tile = synthetic_tile(0, 0, 0, 2);
  Result<MeshGeometry> g = mesh_geometry(tile, triangulate_grid(tile.width));
  ASSERT_TRUE(g.ok());
  for (double bad : {-1.0, std::nan(""), HUGE_VAL}) {
    MeshGeometry copy = *g;
    const Status s = add_skirts(copy, bad);
    ASSERT_FALSE(s.ok()) << bad;
    EXPECT_EQ(s.error().pointer, "/skirt_height");
  }
  MeshGeometry flipped = *g;
  std::swap(flipped.triangles[4], flipped.triangles[5]);  // second triangle now clockwise
  const Status s = add_skirts(flipped, 10.0);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("consistently oriented"), std::string::npos);
}

}  // namespace
}  // namespace terrain
