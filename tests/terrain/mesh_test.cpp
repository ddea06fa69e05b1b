// Tile triangulations: the regular grid and the adaptive RTIN (error bound at every sample,
// conformity, full-resolution boundary, orientation, determinism).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "terrain/mesh.hpp"

namespace terrain {
namespace {

struct GridPoint {
  int column = 0;
  int row = 0;
};

GridPoint point_of(const TileMesh& mesh, std::uint32_t vertex) {
  const auto n = static_cast<std::uint32_t>(mesh.grid_size);
  const std::uint32_t g = mesh.vertices[vertex];
  return {static_cast<int>(g % n), static_cast<int>(g / n)};
}

// Twice the signed area in (east, north) = (column, −row): positive when counter-clockwise.
double signed_area(GridPoint a, GridPoint b, GridPoint c) {
  return static_cast<double>(b.column - a.column) * -(c.row - a.row) -
         static_cast<double>(-(b.row - a.row)) * (c.column - a.column);
}

// Largest |height − surface| over every grid sample, each checked against every triangle that
// contains it (so also those on shared edges); -1 when a sample lies in no triangle.
double largest_error(const TileMesh& mesh, const std::vector<float>& heights) {
  const int n = mesh.grid_size;
  std::vector<char> covered(heights.size(), 0);
  double worst = 0.0;
  for (std::size_t t = 0; t + 2 < mesh.triangles.size(); t += 3) {
    const GridPoint p[3] = {point_of(mesh, mesh.triangles[t]),
                            point_of(mesh, mesh.triangles[t + 1]),
                            point_of(mesh, mesh.triangles[t + 2])};
    double h[3];
    for (int i = 0; i < 3; ++i) {
      h[i] = heights[static_cast<std::size_t>(p[i].row * n + p[i].column)];
    }
    // Barycentric coordinates from the 2×2 system in (column, row).
    const double x0 = p[0].column, y0 = p[0].row;
    const double e1x = p[1].column - x0, e1y = p[1].row - y0;
    const double e2x = p[2].column - x0, e2y = p[2].row - y0;
    const double det = e1x * e2y - e2x * e1y;
    const int c0 = std::min({p[0].column, p[1].column, p[2].column});
    const int c1 = std::max({p[0].column, p[1].column, p[2].column});
    const int r0 = std::min({p[0].row, p[1].row, p[2].row});
    const int r1 = std::max({p[0].row, p[1].row, p[2].row});
    for (int row = r0; row <= r1; ++row) {
      for (int column = c0; column <= c1; ++column) {
        const double dx = column - x0, dy = row - y0;
        const double s = (dx * e2y - e2x * dy) / det;
        const double u = (e1x * dy - dx * e1y) / det;
        if (s < -1e-12 || u < -1e-12 || s + u > 1.0 + 1e-12) continue;
        const auto g = static_cast<std::size_t>(row * n + column);
        covered[g] = 1;
        const double surface = h[0] + s * (h[1] - h[0]) + u * (h[2] - h[0]);
        worst = std::max(worst, std::abs(heights[g] - surface));
      }
    }
  }
  for (char c : covered) {
    if (c == 0) return -1.0;
  }
  return worst;
}

std::vector<float> rough_grid(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(-100.0f, 100.0f);
  std::vector<float> h(static_cast<std::size_t>(n) * n);
  for (float& v : h) v = d(rng);
  return h;
}

// Smooth hills with a little noise: the interesting case for adaptivity.
std::vector<float> hilly_grid(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-0.3f, 0.3f);
  std::vector<float> h(static_cast<std::size_t>(n) * n);
  for (int row = 0; row < n; ++row) {
    for (int column = 0; column < n; ++column) {
      const double x = column / double(n - 1), y = row / double(n - 1);
      h[static_cast<std::size_t>(row * n + column)] =
          static_cast<float>(
              300.0 * std::sin(3.1 * x) * std::cos(2.3 * y) + 40.0 * std::sin(17.0 * x + 11.0 * y) +
              200.0 * std::exp(-40.0 * ((x - 0.6) * (x - 0.6) + (y - 0.3) * (y - 0.3)))) +
          noise(rng);
    }
  }
  return h;
}

bool on_boundary(GridPoint p, int n) {
  return p.column == 0 || p.row == 0 || p.column == n - 1 || p.row == n - 1;
}

TEST(TriangulateGrid, CoversEveryCellWithTwoCounterClockwiseTriangles) {
  const TileMesh mesh = triangulate_grid(5);
  EXPECT_EQ(mesh.vertices.size(), 25u);
  EXPECT_EQ(mesh.triangles.size(), 4u * 4u * 2u * 3u);
  for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
    EXPECT_GT(signed_area(point_of(mesh, mesh.triangles[t]), point_of(mesh, mesh.triangles[t + 1]),
                          point_of(mesh, mesh.triangles[t + 2])),
              0.0);
  }
}

TEST(Rtin, EverySampleLiesWithinMaxErrorOfTheSurface) {
  for (const int n : {3, 5, 17, 65, 129}) {
    for (const float max_error : {0.5f, 2.0f, 10.0f, 50.0f}) {
      for (const auto& heights : {hilly_grid(n, 7), rough_grid(n, 8)}) {
        const TileMesh mesh = triangulate_rtin(heights.data(), n, max_error);
        const double worst = largest_error(mesh, heights);
        EXPECT_GE(worst, 0.0) << "a sample lies outside every triangle, n = " << n;
        EXPECT_LE(worst, max_error + 1e-9) << "n = " << n << ", max_error = " << max_error;
      }
    }
  }
}

TEST(Rtin, AdaptsTheInteriorToTheRequestedError) {
  const int n = 129;
  const auto heights = hilly_grid(n, 3);
  std::size_t previous = SIZE_MAX;
  for (const float max_error : {0.0f, 0.5f, 2.0f, 8.0f, 32.0f, 128.0f}) {
    const TileMesh mesh = triangulate_rtin(heights.data(), n, max_error);
    EXPECT_LE(mesh.triangles.size(), previous) << "max_error " << max_error;
    previous = mesh.triangles.size();
  }
  // A coarse tolerance keeps a small fraction of the full grid.
  EXPECT_LT(previous, std::size_t{2} * 128 * 128 * 3 / 10);
}

TEST(Rtin, MeshIsConformingWithoutTJunctions) {
  for (const int n : {3, 9, 65, 129}) {
    for (const float max_error : {0.0f, 1.0f, 5.0f, 40.0f}) {
      const auto heights = hilly_grid(n, 11);
      const TileMesh mesh = triangulate_rtin(heights.data(), n, max_error);
      std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
      double area = 0.0;
      for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
        for (int i = 0; i < 3; ++i) {
          const std::uint32_t a = mesh.vertices[mesh.triangles[t + i]];
          const std::uint32_t b = mesh.vertices[mesh.triangles[t + (i + 1) % 3]];
          ++uses[{std::min(a, b), std::max(a, b)}];
        }
        area +=
            signed_area(point_of(mesh, mesh.triangles[t]), point_of(mesh, mesh.triangles[t + 1]),
                        point_of(mesh, mesh.triangles[t + 2])) /
            2.0;
      }
      const auto un = static_cast<std::uint32_t>(n);
      for (const auto& [edge, count] : uses) {
        const GridPoint a{static_cast<int>(edge.first % un), static_cast<int>(edge.first / un)};
        const GridPoint b{static_cast<int>(edge.second % un), static_cast<int>(edge.second / un)};
        const bool boundary = (a.column == b.column && (a.column == 0 || a.column == n - 1)) ||
                              (a.row == b.row && (a.row == 0 || a.row == n - 1));
        EXPECT_EQ(count, boundary ? 1 : 2)
            << "edge (" << a.column << "," << a.row << ")-(" << b.column << "," << b.row
            << "), n = " << n << ", max_error = " << max_error;
      }
      // Counter-clockwise triangles adding up to the tile: no overlap, no gap.
      EXPECT_DOUBLE_EQ(area, double(n - 1) * (n - 1));
    }
  }
}

TEST(Rtin, KeepsEveryBoundarySampleAsAVertex) {
  const int n = 65;
  const auto heights = hilly_grid(n, 5);
  const TileMesh mesh = triangulate_rtin(heights.data(), n, 1000.0f);
  int boundary = 0;
  for (std::uint32_t v = 0; v < mesh.vertices.size(); ++v) {
    if (on_boundary(point_of(mesh, v), n)) ++boundary;
  }
  EXPECT_EQ(boundary, 4 * (n - 1));
}

TEST(Rtin, FlatGridNeedsFewTriangles) {
  const int n = 257;
  const std::vector<float> flat(static_cast<std::size_t>(n) * n, 123.0f);
  const TileMesh mesh = triangulate_rtin(flat.data(), n, 0.0f);
  // Only the full-resolution boundary band refines: about 15·(n−1), against 2·(n−1)² for the
  // full grid.
  EXPECT_LT(mesh.triangles.size() / 3, std::size_t{20} * (n - 1));
  EXPECT_EQ(largest_error(mesh, flat), 0.0);
}

TEST(Rtin, TrianglesAreCounterClockwiseSeenFromAbove) {
  const int n = 65;
  const auto heights = rough_grid(n, 2);
  for (const float max_error : {0.0f, 30.0f, 150.0f}) {
    const TileMesh mesh = triangulate_rtin(heights.data(), n, max_error);
    for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
      EXPECT_GT(
          signed_area(point_of(mesh, mesh.triangles[t]), point_of(mesh, mesh.triangles[t + 1]),
                      point_of(mesh, mesh.triangles[t + 2])),
          0.0);
    }
  }
}

TEST(Rtin, ZeroErrorGivesTheFullGridSurface) {
  for (const int n : {2, 3, 33}) {
    const auto heights = rough_grid(n, 4);
    const TileMesh mesh = triangulate_rtin(heights.data(), n, 0.0f);
    EXPECT_EQ(largest_error(mesh, heights), 0.0);
    // Random heights have no coplanar samples: every sample is a vertex, every cell two halves.
    EXPECT_EQ(mesh.vertices.size(), std::size_t(n) * n);
    EXPECT_EQ(mesh.triangles.size(), std::size_t(n - 1) * (n - 1) * 2 * 3);
  }
}

TEST(Rtin, ListsEachVertexOnceInGridOrderAndIsDeterministic) {
  const int n = 129;
  const auto heights = hilly_grid(n, 9);
  const TileMesh a = triangulate_rtin(heights.data(), n, 3.0f);
  const TileMesh b = triangulate_rtin(heights.data(), n, 3.0f);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.grid_size, n);
  EXPECT_TRUE(std::is_sorted(a.vertices.begin(), a.vertices.end()));
  EXPECT_EQ(std::adjacent_find(a.vertices.begin(), a.vertices.end()), a.vertices.end());
  std::vector<char> used(a.vertices.size(), 0);
  for (std::uint32_t t : a.triangles) {
    ASSERT_LT(t, a.vertices.size());
    used[t] = 1;
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0);
}

}  // namespace
}  // namespace terrain
