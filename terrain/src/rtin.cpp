// Adaptive right-triangulated irregular network (RTIN) over a (2^k + 1)² grid, after Mapbox's
// Martini, with an exact error measure and full-resolution tile edges (see mesh.hpp).
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <numbers>
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

// The columns of row y inside or on the triangle: the three edge functions cross(p, ·, ·) ≤ 0
// are linear in the column. Empty (lo > hi) when the row misses it.
struct RowSpan {
  std::int64_t lo, hi;
};
RowSpan row_span(const Point (&corner)[3], int y, int n) {
  RowSpan span{0, n - 1};
  for (int i = 0; i < 3; ++i) {
    const Point p = corner[(i + 1) % 3], q = corner[(i + 2) % 3];
    const std::int64_t a = p.y - q.y;
    const std::int64_t c =
        static_cast<std::int64_t>(p.x) * (q.y - y) - static_cast<std::int64_t>(p.y - y) * q.x;
    if (a > 0) {
      span.hi = std::min(span.hi, floor_div(-c, a));
    } else if (a < 0) {
      span.lo = std::max(span.lo, ceil_div(c, -a));
    } else if (c > 0) {
      span.hi = span.lo - 1;  // the whole row is outside
    }
  }
  return span;
}

// The plane through the triangle's corner heights along row y, as height = slope·x + offset: the
// weight of corner i is the edge function of the opposite edge (j, k), A·x + C.
struct RowPlane {
  double slope = 0.0, offset = 0.0;
};
RowPlane row_plane(const Point (&corner)[3], const double (&h)[3], double area, int y) {
  RowPlane plane;
  for (int i = 0; i < 3; ++i) {
    const Point p = corner[(i + 1) % 3], q = corner[(i + 2) % 3];
    const std::int64_t a = p.y - q.y;
    const std::int64_t c =
        static_cast<std::int64_t>(p.x) * (q.y - y) - static_cast<std::int64_t>(p.y - y) * q.x;
    plane.slope += static_cast<double>(a) * h[i];
    plane.offset += static_cast<double>(c) * h[i];
  }
  plane.slope /= area;
  plane.offset /= area;
  return plane;
}

// Largest |height − plane| over every sample inside or on the triangle, row by row.
double flat_triangle_error(const Triangle& t, const float* heights, int n) {
  const double area = static_cast<double>(cross(t.a, t.b, t.c));  // negative, see Triangle
  const Point corner[3] = {t.a, t.b, t.c};
  double h[3];
  for (int i = 0; i < 3; ++i) h[i] = heights[grid_index(corner[i], n)];
  const int y0 = std::min({t.a.y, t.b.y, t.c.y}), y1 = std::max({t.a.y, t.b.y, t.c.y});
  double worst = 0.0;
  for (int y = y0; y <= y1; ++y) {
    const RowSpan span = row_span(corner, y, n);
    const RowPlane plane = row_plane(corner, h, area, y);
    const float* row = heights + static_cast<std::size_t>(y) * static_cast<std::size_t>(n);
    for (std::int64_t x = span.lo; x <= span.hi; ++x) {
      const double on_plane = static_cast<double>(x) * plane.slope + plane.offset;
      worst = std::max(worst, std::abs(static_cast<double>(row[x]) - on_plane));
    }
  }
  return worst;
}

// Where the samples lie on the WGS84 ellipsoid, per column and per row, so that a sample's
// Earth-centred position costs a few products: with N the prime vertical radius, the surface
// point is (N·cos φ·cos λ, N·cos φ·sin λ, N·(1 − e²)·sin φ) and the up direction
// (cos φ·cos λ, cos φ·sin λ, sin φ).
struct EllipsoidGrid {
  std::vector<double> cos_lon, sin_lon;                    // per column
  std::vector<double> cos_lat, sin_lat, rim, polar_reach;  // per row; rim = N·cos φ,
                                                           // polar_reach = N·(1 − e²)·sin φ

  EllipsoidGrid(int n, const TileBounds& degrees) {
    constexpr double kA = 6378137.0, kF = 1.0 / 298.257223563, kE2 = kF * (2.0 - kF);
    constexpr double kDegree = std::numbers::pi / 180.0;
    const auto size = static_cast<std::size_t>(n);
    cos_lon.resize(size);
    sin_lon.resize(size);
    cos_lat.resize(size);
    sin_lat.resize(size);
    rim.resize(size);
    polar_reach.resize(size);
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const double f = static_cast<double>(i) / static_cast<double>(n - 1);
      const double lon = (degrees.west + (degrees.east - degrees.west) * f) * kDegree;
      cos_lon[u] = std::cos(lon);
      sin_lon[u] = std::sin(lon);
      const double lat_degrees = degrees.north + (degrees.south - degrees.north) * f;
      // Exactly 0 at a pole, so that every sample there is the same point and triangles with
      // two corners at a pole come out exactly degenerate.
      cos_lat[u] = std::abs(lat_degrees) >= 90.0 ? 0.0 : std::cos(lat_degrees * kDegree);
      sin_lat[u] = std::sin(lat_degrees * kDegree);
      const double prime_vertical = kA / std::sqrt(1.0 - kE2 * sin_lat[u] * sin_lat[u]);
      rim[u] = prime_vertical * cos_lat[u];
      polar_reach[u] = prime_vertical * (1.0 - kE2) * sin_lat[u];
    }
  }

  std::array<double, 3> surface(int x, int y) const {
    const auto ux = static_cast<std::size_t>(x), uy = static_cast<std::size_t>(y);
    return {rim[uy] * cos_lon[ux], rim[uy] * sin_lon[ux], polar_reach[uy]};
  }
  std::array<double, 3> up(int x, int y) const {
    const auto ux = static_cast<std::size_t>(x), uy = static_cast<std::size_t>(y);
    return {cos_lat[uy] * cos_lon[ux], cos_lat[uy] * sin_lon[ux], sin_lat[uy]};
  }
  std::array<double, 3> position(Point p, double height) const {
    const std::array<double, 3> s = surface(p.x, p.y), u = up(p.x, p.y);
    return {s[0] + height * u[0], s[1] + height * u[1], s[2] + height * u[2]};
  }
};

std::array<double, 3> minus(const std::array<double, 3>& p, const std::array<double, 3>& q) {
  return {p[0] - q[0], p[1] - q[1], p[2] - q[2]};
}
double dot(const std::array<double, 3>& p, const std::array<double, 3>& q) {
  return p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
}
std::array<double, 3> cross3(const std::array<double, 3>& p, const std::array<double, 3>& q) {
  return {p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0]};
}

// The triangle drawn flat between its corners' Earth-centred positions, measured at every sample
// it covers along the sample's ellipsoid normal (on which longitude and latitude are constant,
// so the distance is a difference of geodetic heights): the larger of |height − drawn height|,
// the error against the surface itself, and (linear height − drawn height), how far the flat
// triangle cuts under the heights interpolated between its own corners. The second is the
// chordal sag alone; it keeps a triangle whose concave heights happen to offset the globe's
// curvature from hiding that sag. Infinite for triangles degenerate in space (two corners at a
// pole) or seen edge-on from a sample, which then split.
double ellipsoid_triangle_error(const Triangle& t, const float* heights, int n,
                                const EllipsoidGrid& grid) {
  const double area = static_cast<double>(cross(t.a, t.b, t.c));
  const Point corner[3] = {t.a, t.b, t.c};
  double h[3];
  for (int i = 0; i < 3; ++i) h[i] = heights[grid_index(corner[i], n)];
  const std::array<double, 3> pa = grid.position(t.a, h[0]);
  const std::array<double, 3> ab = minus(grid.position(t.b, h[1]), pa);
  const std::array<double, 3> ac = minus(grid.position(t.c, h[2]), pa);
  // Counter-clockwise seen from above, so the normal points away from the centre.
  const std::array<double, 3> normal = cross3(ab, ac);
  const double length = std::sqrt(dot(normal, normal));
  constexpr double kInfinite = std::numeric_limits<double>::infinity();
  if (!(length > 1e-9 * std::sqrt(dot(ab, ab) * dot(ac, ac)))) return kInfinite;
  const int y0 = std::min({t.a.y, t.b.y, t.c.y}), y1 = std::max({t.a.y, t.b.y, t.c.y});
  double worst = 0.0;
  for (int y = y0; y <= y1; ++y) {
    const RowSpan span = row_span(corner, y, n);
    const RowPlane linear = row_plane(corner, h, area, y);
    const float* row = heights + static_cast<std::size_t>(y) * static_cast<std::size_t>(n);
    for (std::int64_t x = span.lo; x <= span.hi; ++x) {
      const int column = static_cast<int>(x);
      const double facing = dot(grid.up(column, y), normal);
      if (!(facing > 1e-6 * length)) return kInfinite;
      const double drawn = dot(minus(pa, grid.surface(column, y)), normal) / facing;
      const double sample = static_cast<double>(row[x]);
      const double interpolated = static_cast<double>(x) * linear.slope + linear.offset;
      worst = std::max({worst, std::abs(sample - drawn), interpolated - drawn});
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

// The RTIN of mesh.hpp with the error of a triangle given by `triangle_error(t)`.
template <class TriangleError>
TileMesh build_rtin(int grid_size, float max_error, const TriangleError& triangle_error) {
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
      const double e = triangle_error(t);
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

}  // namespace

TileMesh triangulate_rtin(const float* heights, int grid_size, float max_error) {
  assert(heights != nullptr);
  return build_rtin(grid_size, max_error,
                    [&](const Triangle& t) { return flat_triangle_error(t, heights, grid_size); });
}

TileMesh triangulate_rtin_on_ellipsoid(const float* heights, int grid_size,
                                       const TileBounds& degrees, float max_error) {
  assert(heights != nullptr);
  const EllipsoidGrid grid(grid_size, degrees);
  return build_rtin(grid_size, max_error, [&](const Triangle& t) {
    return ellipsoid_triangle_error(t, heights, grid_size, grid);
  });
}

}  // namespace terrain
