// The smooth ground of dry land (issue 20 item 4): the Clough–Tocher cubic reproduces quadratics,
// meets its neighbours with the same slope, and the planet's dry land shows neither flat facets
// nor creases along triangle edges.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "default_definition.hpp"
#include "planet/planet.hpp"
#include "planet/smooth_surface.hpp"

namespace planet {
namespace {

// Triangles in the plane z = 1, with radius 1: gnomonic coordinates are the plane's own there,
// and a slope without z is tangent to it, so the cubic's algebra is checked exactly.
struct Quadratic {
  double c, gx, gy, xx, xy, yy;
  double at(double x, double y) const {
    return c + gx * x + gy * y + xx * x * x + xy * x * y + yy * y * y;
  }
  Vertex vertex(double x, double y) const {
    Vertex v;
    v.p = {x, y, 1.0};
    v.ground = at(x, y);
    ground_slope(v) = {static_cast<float>(gx + 2 * xx * x + xy * y),
                       static_cast<float>(gy + xy * x + 2 * yy * y), 0.0f};
    return v;
  }
};

double height(const std::array<const Vertex*, 3>& corner, double x, double y) {
  const Vec3d p{x, y, 1.0};
  return clough_tocher(corner, barycentric(corner[0]->p, corner[1]->p, corner[2]->p, p), 1.0);
}

Vertex random_vertex(std::mt19937& random, double x, double y) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vertex v;
  v.p = {x, y, 1.0};
  v.ground = 100.0 * u(random);
  ground_slope(v) = {static_cast<float>(u(random)), static_cast<float>(u(random)), 0.0f};
  return v;
}

// How much a line's slope changes across the point t·d from o: the one-sided slopes' difference
// at step h. A crease keeps it as h shrinks; a C1 surface's shrinks with h.
template <typename F>
double slope_jump(const F& f, double t, double h) {
  return std::abs((f(t + h) - f(t)) / h - (f(t) - f(t - h)) / h);
}

// clamp01 replaced std::clamp(x, 0, 1) where loops vectorise (the drainage floors): every
// product's bytes rest on the two giving the same bits, NaN and the signed zeros included.
TEST(Clamp01, GivesStdClampsBitsForEveryKindOfValue) {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> values = {0.0,
                                -0.0,
                                1.0,
                                -1.0,
                                0.5,
                                1.0 + 1e-16,
                                std::nextafter(1.0, 2.0),
                                std::nextafter(0.0, -1.0),
                                std::numeric_limits<double>::denorm_min(),
                                inf,
                                -inf,
                                std::numeric_limits<double>::quiet_NaN(),
                                -std::numeric_limits<double>::quiet_NaN()};
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> wide(-3.0, 3.0);
  for (int i = 0; i < 1000; ++i) values.push_back(wide(random));
  for (const double x : values) {
    EXPECT_EQ(std::bit_cast<std::uint64_t>(clamp01(x)),
              std::bit_cast<std::uint64_t>(std::clamp(x, 0.0, 1.0)))
        << x;
  }
}

TEST(CloughTocher, ReproducesQuadratics) {
  // Whose normal derivative along an edge is linear, as the reduced cubic assumes: exact there.
  const Quadratic q{3.0, 0.4, -0.7, 0.9, -1.3, 0.5};
  const Vertex a = q.vertex(0.1, 0.2), b = q.vertex(0.9, 0.1), c = q.vertex(0.4, 0.8);
  std::mt19937 random(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    double s = u(random), t = u(random);
    if (s + t > 1.0) s = 1.0 - s, t = 1.0 - t;
    const double x = a.p[0] + s * (b.p[0] - a.p[0]) + t * (c.p[0] - a.p[0]);
    const double y = a.p[1] + s * (b.p[1] - a.p[1]) + t * (c.p[1] - a.p[1]);
    // Slopes are floats: exact to their rounding.
    EXPECT_NEAR(height({&a, &b, &c}, x, y), q.at(x, y), 1e-7) << x << ", " << y;
  }
}

TEST(CloughTocher, MeetsItsNeighbourWithTheSameHeightAndSlope) {
  std::mt19937 random(11);
  const Vertex a = random_vertex(random, 0.0, 0.0), b = random_vertex(random, 1.0, 0.1);
  const Vertex c = random_vertex(random, 0.3, 0.9), d = random_vertex(random, 0.6, -0.8);
  // Across the shared edge (a, b), perpendicular to it, from (a, b, c) into (b, a, d).
  const double ex = b.p[0] - a.p[0], ey = b.p[1] - a.p[1];
  const double length = std::hypot(ex, ey);
  const double nx = ey / length, ny = -ex / length;  // towards d
  for (double s : {0.1, 0.3, 0.5, 0.7, 0.9}) {
    const double ox = a.p[0] + s * ex, oy = a.p[1] + s * ey;
    auto along = [&](double t) {
      const double x = ox + t * nx, y = oy + t * ny;
      return t < 0.0 ? height({&a, &b, &c}, x, y) : height({&b, &a, &d}, x, y);
    };
    EXPECT_NEAR(height({&a, &b, &c}, ox, oy), height({&b, &a, &d}, ox, oy), 1e-9);
    const double coarse = slope_jump(along, 0.0, 1e-3), fine = slope_jump(along, 0.0, 1e-4);
    EXPECT_LT(fine, 0.15 * coarse + 1e-6) << "a crease at s = " << s;
  }
  // And inside, across the spokes between the three patches of a triangle: along lines through
  // the centroid, where every spoke meets.
  const double cx = (a.p[0] + b.p[0] + c.p[0]) / 3.0, cy = (a.p[1] + b.p[1] + c.p[1]) / 3.0;
  for (double angle = 0.1; angle < 6.28; angle += 0.7) {
    auto along = [&](double t) {
      return height({&a, &b, &c}, cx + t * std::cos(angle), cy + t * std::sin(angle));
    };
    EXPECT_LT(slope_jump(along, 0.0, 1e-4), 0.15 * slope_jump(along, 0.0, 1e-3) + 1e-6);
  }
}

TEST(CloughTocher, FanSlopeIsThePlanesGradient) {
  // Four neighbours on a plane: the fan's slope is that plane's gradient.
  const Quadratic plane{2.0, 0.3, -0.8, 0.0, 0.0, 0.0};
  const Vertex m = plane.vertex(0.0, 0.0);
  const Vertex east = plane.vertex(0.5, 0.0), north = plane.vertex(0.1, 0.6);
  const Vertex west = plane.vertex(-0.7, 0.1), south = plane.vertex(0.0, -0.4);
  const std::array<float, 3> slope = fan_slope(m, {&east, &north, &west, &south}, 1.0);
  EXPECT_NEAR(slope[0], 0.3, 1e-6);
  EXPECT_NEAR(slope[1], -0.8, 1e-6);
}

// The default planet's land around 5° N 175° W (bench/planet_realism.sh's square) at a level of
// ~1 km edges, without the fractal detail: the mesh's own surface, with either relief model (the
// drainage model's floors included).
class DryLand : public ::testing::TestWithParam<ReliefModel> {
 protected:
  // One planet per relief model, built once for every test that asks.
  static const std::shared_ptr<const Planet>& planet() {
    static const std::shared_ptr<const Planet> displacement = [] {
      PlanetDefinition d = test::default_definition();
      d.relief_model = ReliefModel::displacement;
      return Planet::create(d);
    }();
    static const std::shared_ptr<const Planet> drainage =
        Planet::create(test::default_definition());
    return GetParam() == ReliefModel::drainage ? drainage : displacement;
  }

  int level() const {
    int level = planet()->rules().mesh_level;
    while (planet()->rules().edge_length(level) > 1200.0) ++level;
    return level;
  }
  // A point `east`, `north` metres from the square's centre (on the tangent plane, lifted).
  Vec3d point(double east, double north) const {
    const Vec3d centre = planet()->geodesy().direction(5.0, -175.0);
    const Vec3d e = normalize(cross({0.0, 0.0, 1.0}, centre));
    const Vec3d n = cross(centre, e);
    const double r = planet()->definition().radius;
    return normalize(add(centre, add(scale(e, east / r), scale(n, north / r))));
  }
  // A land triangle whose corners are all dry.
  static bool dry(const Hierarchy& h, std::int32_t t) {
    const Tri& tri = h.tris[static_cast<std::size_t>(t)];
    return tri.face == FaceType::land &&
           all_dry({&h.vertices[tri.v[0]], &h.vertices[tri.v[1]], &h.vertices[tri.v[2]]});
  }
  // A land triangle with a wet corner: a valley's floor and side.
  static bool beside_water(const Hierarchy& h, std::int32_t t) {
    return h.tris[static_cast<std::size_t>(t)].face == FaceType::land && !dry(h, t);
  }
  // The corners two triangles share, and how many of those are wet.
  struct Shared {
    int corners = 0;
    int wet = 0;
  };
  static Shared shared_corners(const Hierarchy& h, std::int32_t a, std::int32_t b) {
    Shared shared;
    for (std::uint32_t u : h.tris[static_cast<std::size_t>(a)].v) {
      for (std::uint32_t v : h.tris[static_cast<std::size_t>(b)].v) {
        if (u != v) continue;
        ++shared.corners;
        if (wet(h.vertices[u])) ++shared.wet;
      }
    }
    return shared;
  }
  // Lines across river valleys from 20 to 40 km east of the square's centre, 500 m apart, 34–46 km
  // south of it (generation 19's continents: 45 and 242 crossings of the kinds below).
  static std::vector<double> valley_lines() {
    std::vector<double> norths;
    for (int line = 0; line < 24; ++line) norths.push_back(-46000.0 + 500.0 * line);
    return norths;
  }
  static constexpr double kValleyFrom = 20000.0, kValleyTo = 40000.0;
  // Along eastward lines (`north` metres from the centre, east from `from` to `to`), every
  // crossing from one triangle into another that `selected(h, before, after)` picks: the slope's
  // change across it must shrink with the step (C1), where a crease would keep it. Returns how
  // many crossings it checked.
  // `allowance`: a slope change (m/m) that may remain at the finest step.
  template <typename Selected>
  int check_crossings(const std::vector<double>& norths, double from, double to,
                      const Selected& selected, double allowance = 1e-5) const {
    Sampler sampler(planet());
    Hierarchy h = planet()->base_mesh().hierarchy;
    const double step = 20.0;
    int crossings = 0;
    for (const double north : norths) {
      auto ground = [&](double east) {
        return sampler.at(point(east, north), level(), 0.0).ground;
      };
      auto leaf = [&](double east) { return h.locate(point(east, north), level()); };
      for (double east = from; east < to; east += step) {
        if (leaf(east) == leaf(east + step)) continue;
        double lo = east, hi = east + step;  // the crossing, to a millimetre
        while (hi - lo > 1e-3) {
          const double mid = 0.5 * (lo + hi);
          (leaf(mid) == leaf(lo) ? lo : hi) = mid;
        }
        const double at = 0.5 * (lo + hi);
        const std::int32_t before = leaf(at - 2.0), after = leaf(at + 2.0);
        if (before == after || !selected(h, before, after)) continue;  // past a corner, or not one
        // Over 0.2 m and 0.02 m: a floor's curvature changes within a few metres (its ease is
        // half a sample wide), so over 2 m the change may be smaller than over 0.2 m on a C1
        // surface too (generation 18's default planet had a crossing at 1.3e-3 over 2 m and
        // 3.2e-4 over 0.2 m, falling tenfold with each tenfold step below that).
        const double coarse = slope_jump(ground, at, 0.2), fine = slope_jump(ground, at, 0.02);
        EXPECT_LT(fine, 0.2 * coarse + allowance)
            << "a crease at " << at << " m east, " << north << " m north: slope change " << coarse
            << " over 0.2 m, " << fine << " over 0.02 m";
        ++crossings;
      }
    }
    return crossings;
  }
};

// The valleys beside the rivers: the displacement model's (the drainage model's floors follow
// its drains, not these lines).
class DryLandBesideRivers : public DryLand {};

TEST_P(DryLand, HasNoFlatFacets) {
  // The share of samples whose four neighbours 50 m away average to their own height: every
  // sample inside a flat facet does. On the piecewise-linear surface this was most of them.
  Sampler sampler(planet());
  const int n = 64;
  std::vector<double> ground(n * n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      ground[i * n + j] = sampler.at(point(50.0 * j, 50.0 * i), level(), 0.0).ground;
    }
  }
  int flat = 0, samples = 0;
  for (int i = 1; i + 1 < n; ++i) {
    for (int j = 1; j + 1 < n; ++j) {
      const double laplacian = ground[(i - 1) * n + j] + ground[(i + 1) * n + j] +
                               ground[i * n + j - 1] + ground[i * n + j + 1] -
                               4 * ground[i * n + j];
      flat += std::abs(laplacian) < 1e-6 ? 1 : 0;
      ++samples;
    }
  }
  EXPECT_LT(flat, samples / 100) << flat << " of " << samples << " samples lie in flat facets";
}

TEST_P(DryLand, HasNoCreasesAcrossTriangleEdges) {
  // Along lines over the square, every crossing from one dry triangle into another: the slope's
  // change across it shrinks with the step (C1), where a crease would keep it.
  std::vector<double> norths;
  for (int line = 0; line < 6; ++line) norths.push_back(900.0 * line);
  const int crossings = check_crossings(
      norths, 0.0, 6000.0, [this](Hierarchy& h, std::int32_t before, std::int32_t after) {
        return dry(h, before) && dry(h, after);  // not beside water (valley floors)
      });
  EXPECT_GT(crossings, 40);
}

TEST_P(DryLandBesideRivers, ValleySidesMeetTheDryLandWithoutACrease) {
  // Lines across river valleys (valley_lines): every crossing from a triangle beside the water (a
  // valley's floor and side) into a dry one over an edge with two dry ends. The valley side reaches
  // the smooth surface with its slope there (C1), where the floors of generation 12 climbed to it
  // linearly and left a crease.
  const int crossings = check_crossings(valley_lines(), kValleyFrom, kValleyTo,
                                        [](Hierarchy& h, std::int32_t before, std::int32_t after) {
                                          if (!(beside_water(h, before) && dry(h, after)) &&
                                              !(dry(h, before) && beside_water(h, after))) {
                                            return false;
                                          }
                                          // The edge between them: their two shared corners, both
                                          // dry.
                                          const Shared shared = shared_corners(h, before, after);
                                          return shared.corners == 2 && shared.wet == 0;
                                        });
  EXPECT_GT(crossings, 20);
}

TEST_P(DryLandBesideRivers, SpokesFromWetCornersHaveNoCrease) {
  // The same lines: every crossing between two triangles beside the water over an edge with one
  // wet end and one dry end (a spoke from a river vertex). The valley side blends into its floor
  // by a dryness that is C1 across every edge; until generation 15 the blend's weight was the
  // dry corners' barycentric weight, and the slope changed by up to 0.32 across these spokes.
  // Between two triangles with one river corner each nothing remains. The floor's own level does
  // remain where a triangle with two river corners meets one with one: level in the one, following
  // the river in the other, it bends there by a few times the river's slope (up to 0.036 on these
  // lines), hence the allowance.
  const int crossings = check_crossings(
      valley_lines(), kValleyFrom, kValleyTo,
      [](Hierarchy& h, std::int32_t before, std::int32_t after) {
        if (!beside_water(h, before) || !beside_water(h, after)) return false;
        const Shared shared = shared_corners(h, before, after);
        return shared.corners == 2 && shared.wet == 1;
      },
      0.05);
  EXPECT_GT(crossings, 20);
}

TEST_P(DryLand, SplitsGiveTheSameVertexFromEitherTriangleOfTheirDiamond) {
  // A split is computed by whichever of the diamond's two triangles a descent reaches first; the
  // smooth prediction and the fan's slope must not depend on which, to the bit.
  Hierarchy h = planet()->base_mesh().hierarchy;
  int dry = 0;
  for (int k = 0; k < 1000; ++k) {
    const std::int32_t t = h.locate(point(7.0 * k, 5.0 * k), level() - 1);
    h.ensure_partner(t);
    const SplitResult one = h.compute_split(t);
    const SplitResult other = h.compute_split(h.tris[static_cast<std::size_t>(t)].nb[0]);
    EXPECT_EQ(one.m.p, other.m.p);
    EXPECT_EQ(one.m.ground, other.m.ground);
    EXPECT_EQ(one.m.tangent, other.m.tangent);
    dry += wet(one.m) ? 0 : 1;
  }
  EXPECT_GT(dry, 500);
}

std::string model_name(const ::testing::TestParamInfo<ReliefModel>& info) {
  return std::string(relief_model_name(info.param));
}
INSTANTIATE_TEST_SUITE_P(ReliefModels, DryLand,
                         ::testing::Values(ReliefModel::displacement, ReliefModel::drainage),
                         model_name);
INSTANTIATE_TEST_SUITE_P(Displacement, DryLandBesideRivers,
                         ::testing::Values(ReliefModel::displacement), model_name);

}  // namespace
}  // namespace planet
