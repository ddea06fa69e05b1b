// Adaptive right-triangulated irregular network (RTIN) over a (2^k + 1)² grid, after Mapbox's
// Martini, with an exact error measure and full-resolution tile edges (see mesh.hpp).
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <utility>
#include <vector>

#include "terrain/mesh.hpp"

namespace terrain {

namespace {

struct Point {
  int x = 0;  // column
  int y = 0;  // row (0 north)
};

// A triangle of the hierarchy: a and b end its hypotenuse, c is the right-angle corner.
// Every triangle (a, b, c) is clockwise in (column, row) coordinates, i.e. counter-clockwise
// seen from above (east, north), because the roots are and both children keep the orientation.
struct Triangle {
  Point a, b, c;
  Point mid() const { return {(a.x + b.x) / 2, (a.y + b.y) / 2}; }
  Triangle first_child() const { return {c, a, mid()}; }
  Triangle second_child() const { return {b, c, mid()}; }
};

Triangle root(int which, int s) {
  return which == 0 ? Triangle{{0, 0}, {s, s}, {s, 0}} : Triangle{{s, s}, {0, 0}, {0, s}};
}

std::int64_t cross(Point o, Point p, Point q) {
  return static_cast<std::int64_t>(p.x - o.x) * (q.y - o.y) -
         static_cast<std::int64_t>(p.y - o.y) * (q.x - o.x);
}

std::size_t grid_index(Point p, int n) {
  return static_cast<std::size_t>(p.y) * static_cast<std::size_t>(n) +
         static_cast<std::size_t>(p.x);
}

// floor(p / q) and ceil(p / q) for q > 0 and any sign of p.
std::int64_t floor_div(std::int64_t p, std::int64_t q) {
  return p >= 0 ? p / q : -((-p + q - 1) / q);
}
std::int64_t ceil_div(std::int64_t p, std::int64_t q) {
  return -floor_div(-p, q);
}

// Largest |height − plane| over every sample inside or on the triangle. Each row is scanned
// over its exact span: the three edge functions cross(p, ·, ·) ≤ 0 are linear in the column.
double triangle_error(const Triangle& t, const float* heights, int n) {
  const double area = static_cast<double>(cross(t.a, t.b, t.c));  // negative, see Triangle
  const Point corner[3] = {t.a, t.b, t.c};
  double h[3];
  for (int i = 0; i < 3; ++i) h[i] = heights[grid_index(corner[i], n)];
  const int y0 = std::min({t.a.y, t.b.y, t.c.y}), y1 = std::max({t.a.y, t.b.y, t.c.y});
  double worst = 0.0;
  for (int y = y0; y <= y1; ++y) {
    std::int64_t lo = 0, hi = n - 1;
    double slope = 0.0, offset = 0.0;
    // The weight of corner i is the edge function of the opposite edge (j, k): A·x + C.
    for (int i = 0; i < 3; ++i) {
      const Point p = corner[(i + 1) % 3], q = corner[(i + 2) % 3];
      const std::int64_t a = p.y - q.y;
      const std::int64_t c =
          static_cast<std::int64_t>(p.x) * (q.y - y) - static_cast<std::int64_t>(p.y - y) * q.x;
      if (a > 0) {
        hi = std::min(hi, floor_div(-c, a));
      } else if (a < 0) {
        lo = std::max(lo, ceil_div(c, -a));
      } else if (c > 0) {
        hi = lo - 1;  // the whole row is outside
      }
      slope += static_cast<double>(a) * h[i];
      offset += static_cast<double>(c) * h[i];
    }
    const float* row = heights + static_cast<std::size_t>(y) * static_cast<std::size_t>(n);
    slope /= area;
    offset /= area;
    for (std::int64_t x = lo; x <= hi; ++x) {
      const double plane = static_cast<double>(x) * slope + offset;
      worst = std::max(worst, std::abs(static_cast<double>(row[x]) - plane));
    }
  }
  return worst;
}

bool on_same_boundary(Point a, Point b, int s) {
  return (a.x == b.x && (a.x == 0 || a.x == s)) || (a.y == b.y && (a.y == 0 || a.y == s));
}

struct Emitter {
  const std::vector<float>& errors;
  int n;
  int leaf_level;
  float max_error;
  std::vector<std::uint32_t>& corners;  // grid indices, 3 per triangle

  std::uint32_t index(Point p) const {
    return static_cast<std::uint32_t>(p.y) * static_cast<std::uint32_t>(n) +
           static_cast<std::uint32_t>(p.x);
  }

  void emit(const Triangle& t, int level) {
    if (level < leaf_level) {
      const Point m = t.mid();
      if (errors[index(m)] > max_error) {
        emit(t.first_child(), level + 1);
        emit(t.second_child(), level + 1);
        return;
      }
    }
    // push_back, not insert of an initializer list: GCC 12 at -O3 reports a false
    // stringop-overflow for the latter.
    corners.push_back(index(t.a));
    corners.push_back(index(t.b));
    corners.push_back(index(t.c));
  }
};

}  // namespace

TileMesh triangulate_rtin(const float* heights, int grid_size, float max_error) {
  assert(heights != nullptr);
  assert(grid_size >= 2 && grid_size <= (1 << 15) + 1);
  const int s = grid_size - 1;
  assert((s & (s - 1)) == 0 && "grid_size must be 2^k + 1");
  assert(std::isfinite(max_error) && max_error >= 0.0f);
  int k = 0;
  while ((1 << k) < s) ++k;

  // Triangles of levels 0 .. 2k−1 have a grid sample at their hypotenuse midpoint; level 2k
  // triangles are half cells, whose samples are all vertices.
  const int leaf_level = 2 * k;
  const std::size_t count = static_cast<std::size_t>(grid_size) * grid_size;
  std::vector<float> errors(count, 0.0f);
  constexpr float forced = std::numeric_limits<float>::infinity();

  // Pass 1, depth first: every triangle's exact error goes to its hypotenuse midpoint, which it
  // shares with its neighbour across the hypotenuse; a hypotenuse on the tile boundary always
  // splits, which keeps the boundary at full resolution.
  const auto measure = [&](const auto& self, const Triangle& t, int level) -> void {
    const std::size_t m = grid_index(t.mid(), grid_size);
    if (on_same_boundary(t.a, t.b, s)) {
      errors[m] = forced;
    } else {
      // Rounded up to float so that the stored error never understates the double one.
      const double e = triangle_error(t, heights, grid_size);
      float e_float = static_cast<float>(e);
      if (static_cast<double>(e_float) < e) e_float = std::nextafter(e_float, forced);
      errors[m] = std::max(errors[m], e_float);
    }
    if (level + 1 < leaf_level) {
      self(self, t.first_child(), level + 1);
      self(self, t.second_child(), level + 1);
    }
  };
  if (leaf_level > 0) {
    measure(measure, root(0, s), 0);
    measure(measure, root(1, s), 0);
  }

  // Pass 2, deepest level first: each midpoint takes the maximum of its children's midpoints
  // (the midpoints of the legs of the one or two triangles sharing it), so an ancestor splits
  // whenever a descendant does and the mesh stays conforming. The midpoints of a level form a
  // regular pattern: at level 2i, the centres of squares of side 2h (h = s / 2^(i+1)), whose
  // children midpoints are the centres of the sides; at level 2i + 1, the midpoints of those
  // sides, whose children midpoints lie diagonally at h/2.
  const auto raise = [&](int x, int y, int dx, int dy) {
    const int cx = x + dx, cy = y + dy;
    if (cx < 0 || cy < 0 || cx > s || cy > s) return;
    float& e = errors[grid_index({x, y}, grid_size)];
    e = std::max(e, errors[grid_index({cx, cy}, grid_size)]);
  };
  for (int level = leaf_level - 2; level >= 0; --level) {
    const int h = s >> (level / 2 + 1);
    if (level % 2 == 0) {
      for (int y = h; y < s; y += 2 * h) {
        for (int x = h; x < s; x += 2 * h) {
          for (const auto& [dx, dy] : {std::pair{-h, 0}, {h, 0}, {0, -h}, {0, h}})
            raise(x, y, dx, dy);
        }
      }
    } else {
      const int d = h / 2;
      for (int y = 0; y <= s; y += h) {
        for (int x = (y / h) % 2 == 0 ? h : 0; x <= s; x += 2 * h) {
          for (const auto& [dx, dy] : {std::pair{-d, -d}, {d, -d}, {-d, d}, {d, d}})
            raise(x, y, dx, dy);
        }
      }
    }
  }

  std::vector<std::uint32_t> corners;
  Emitter emitter{errors, grid_size, leaf_level, max_error, corners};
  emitter.emit(root(0, s), 0);
  emitter.emit(root(1, s), 0);

  // Vertices in grid order, then triangles rewritten as indices into that list.
  std::vector<std::uint32_t> slot(count, 0);
  for (std::uint32_t g : corners) slot[g] = 1;
  TileMesh mesh;
  mesh.grid_size = grid_size;
  for (std::size_t g = 0; g < count; ++g) {
    if (slot[g] != 0) {
      slot[g] = static_cast<std::uint32_t>(mesh.vertices.size());
      mesh.vertices.push_back(static_cast<std::uint32_t>(g));
    }
  }
  mesh.triangles.reserve(corners.size());
  for (std::uint32_t g : corners) mesh.triangles.push_back(slot[g]);
  return mesh;
}

}  // namespace terrain
