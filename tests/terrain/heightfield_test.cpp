// Bilinear heightfields, their weights and bounds, and the convex quadrangle mapping.
#include "terrain/heightfield.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace terrain {
namespace {

Raster random_raster(int n, int m, std::mt19937& rng, float amplitude_u = 1.0f,
                     float amplitude_v = 1.0f, bool with_weight = false) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  // Anisotropic roughness: a random profile per column scaled by amplitude_u plus one per row
  // scaled by amplitude_v, plus a little noise, so neighbour differences differ per axis.
  std::vector<float> column(static_cast<std::size_t>(n)), row(static_cast<std::size_t>(m));
  for (float& c : column) c = unit(rng);
  for (float& r : row) r = unit(rng);
  Raster r;
  r.width = n;
  r.height = m;
  for (int j = 0; j < m; ++j) {
    for (int i = 0; i < n; ++i) {
      r.samples.push_back(amplitude_u * column[static_cast<std::size_t>(i)] +
                          amplitude_v * row[static_cast<std::size_t>(j)] + 0.1f * unit(rng));
      if (with_weight) r.weights.push_back(unit(rng) * 1.4f - 0.2f);  // spills past [0, 1]
    }
  }
  return r;
}

Heightfield make(const Raster& r, const HeightfieldParams& p = {}) {
  Result<Heightfield> hf = Heightfield::create(r, p);
  EXPECT_TRUE(hf.ok()) << (hf.ok() ? "" : hf.error().message);
  return std::move(hf).value();
}

QuadMap make_quad(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  Result<QuadMap> q = QuadMap::create(a, b, c, d);
  EXPECT_TRUE(q.ok()) << (q.ok() ? "" : q.error().message);
  return std::move(q).value();
}

double spectral_norm(Vec2 row0, Vec2 row1) {
  const double a = row0.x, b = row0.y, c = row1.x, d = row1.y;
  const double f2 = a * a + b * b + c * c + d * d;
  const double det = std::abs(a * d - b * c);
  return 0.5 * (std::sqrt(f2 + 2 * det) + std::sqrt(std::max(f2 - 2 * det, 0.0)));
}

TEST(HeightfieldBilinear, ValueAtSamplesEqualsSamples) {
  std::mt19937 rng(1);
  const Raster r = random_raster(7, 5, rng);
  const HeightfieldParams params{.offset = 100.0f, .scale = -3.5f};
  const Heightfield hf = make(r, params);
  for (int j = 0; j < 5; ++j) {
    for (int i = 0; i < 7; ++i) {
      const float u = static_cast<float>(i) / 6.0f;
      const float v = static_cast<float>(j) / 4.0f;
      EXPECT_NEAR(hf.height(u, v).value, 100.0f - 3.5f * r.at(i, j), 2e-5f) << i << "," << j;
    }
  }
}

TEST(HeightfieldBilinear, GradientMatchesCentralDifferencesInsideCells) {
  std::mt19937 rng(2);
  const Raster r = random_raster(9, 6, rng);
  const Heightfield hf = make(r, {.offset = 0.0f, .scale = 2.0f});
  std::uniform_real_distribution<float> frac(0.1f, 0.9f);
  std::uniform_int_distribution<int> ci(0, 7);
  std::uniform_int_distribution<int> cj(0, 4);
  const float eps = 1e-3f;
  for (int trial = 0; trial < 500; ++trial) {
    // A point well inside a cell so that both difference points stay in it.
    const float u = (static_cast<float>(ci(rng)) + frac(rng)) / 8.0f;
    const float v = (static_cast<float>(cj(rng)) + frac(rng)) / 5.0f;
    const UvSample s = hf.height(u, v);
    const double fd_u = (static_cast<double>(hf.height(u + eps / 8.0f, v).value) -
                         hf.height(u - eps / 8.0f, v).value) /
                        (2.0 * eps / 8.0);
    const double fd_v = (static_cast<double>(hf.height(u, v + eps / 5.0f).value) -
                         hf.height(u, v - eps / 5.0f).value) /
                        (2.0 * eps / 5.0);
    EXPECT_NEAR(s.du, fd_u, 2e-2 * (1.0 + std::abs(fd_u)));
    EXPECT_NEAR(s.dv, fd_v, 2e-2 * (1.0 + std::abs(fd_v)));
  }
}

TEST(HeightfieldBilinear, EdgesUseFloorCellAndOutsideIsConstant) {
  Raster r;
  r.width = 3;
  r.height = 2;
  r.samples = {0.0f, 1.0f, 5.0f,   // row 0 (v = 0)
               2.0f, 3.0f, 9.0f};  // row 1 (v = 1)
  const Heightfield hf = make(r);
  // u = 0.5 is the shared edge of cells 0 and 1: floor picks cell 1 (slope (5 − 1) · 2 at v = 0).
  EXPECT_FLOAT_EQ(hf.height(0.5f, 0.0f).du, 8.0f);
  // u = 1 clamps to the last cell.
  EXPECT_FLOAT_EQ(hf.height(1.0f, 0.0f).du, 8.0f);
  EXPECT_FLOAT_EQ(hf.height(1.0f, 1.0f).du, 12.0f);
  EXPECT_FLOAT_EQ(hf.height(0.25f, 1.0f).dv, 2.0f);
  // Outside the square: the value of the clamped point, no derivative across the clamp.
  const UvSample out = hf.height(1.7f, -0.4f);
  EXPECT_FLOAT_EQ(out.value, 5.0f);
  EXPECT_EQ(out.du, 0.0f);
  EXPECT_EQ(out.dv, 0.0f);
  const UvSample side = hf.height(-2.0f, 0.5f);
  EXPECT_FLOAT_EQ(side.value, 1.0f);
  EXPECT_EQ(side.du, 0.0f);
  EXPECT_FLOAT_EQ(side.dv, 2.0f);
  // NaN input stays in range (treated as 0) rather than indexing out of bounds.
  EXPECT_FLOAT_EQ(hf.height(std::nanf(""), 0.0f).value, 0.0f);
}

TEST(HeightfieldLipschitz, BoundHoldsOnRandomPairsForRandomRasters) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> coord(-0.3f, 1.3f);
  std::uniform_real_distribution<float> near(-0.02f, 0.02f);
  const int shapes[][2] = {{2, 2}, {5, 5}, {17, 4}, {3, 40}, {64, 64}};
  for (const auto& shape : shapes) {
    for (const float au : {0.0f, 1.0f, 10.0f}) {
      const Raster r = random_raster(shape[0], shape[1], rng, au, 1.0f);
      const Heightfield hf = make(r, {.offset = 5.0f, .scale = -7.0f});
      const double lambda = hf.lipschitz();
      for (int trial = 0; trial < 4000; ++trial) {
        const Vec2 p{coord(rng), coord(rng)};
        // Half the pairs are close, where the local slope dominates.
        const Vec2 q =
            trial % 2 == 0 ? Vec2{coord(rng), coord(rng)} : Vec2{p.x + near(rng), p.y + near(rng)};
        const double dh =
            std::abs(static_cast<double>(hf.height(p.x, p.y).value) - hf.height(q.x, q.y).value);
        const double dist = std::hypot(static_cast<double>(p.x - q.x), p.y - q.y);
        ASSERT_LE(dh, lambda * dist * (1 + 1e-4) + 1e-4)
            << shape[0] << "x" << shape[1] << " p=(" << p.x << "," << p.y << ") q=(" << q.x << ","
            << q.y << ")";
      }
    }
  }
}

TEST(HeightfieldLipschitz, PerAxisBoundsAreAttainedAndBeatThePaperBound) {
  std::mt19937 rng(4);
  const Raster r = random_raster(12, 7, rng, 5.0f, 0.5f);
  const Heightfield hf = make(r, {.offset = 0.0f, .scale = 1.5f});
  // Find the steepest neighbour pairs and evaluate the partials on them: the bound is exact.
  double best_u = 0.0, best_v = 0.0, max_diff = 0.0;
  float at_u[2] = {}, at_v[2] = {};
  for (int j = 0; j < 7; ++j) {
    for (int i = 0; i < 12; ++i) {
      if (i + 1 < 12) {
        const double d = std::abs(r.at(i + 1, j) - r.at(i, j));
        max_diff = std::max(max_diff, d);
        if (d > best_u) {
          best_u = d;
          at_u[0] = (static_cast<float>(i) + 0.5f) / 11.0f;
          at_u[1] = static_cast<float>(j) / 6.0f;
        }
      }
      if (j + 1 < 7) {
        const double d = std::abs(r.at(i, j + 1) - r.at(i, j));
        max_diff = std::max(max_diff, d);
        if (d > best_v) {
          best_v = d;
          at_v[0] = static_cast<float>(i) / 11.0f;
          at_v[1] = (static_cast<float>(j) + 0.5f) / 6.0f;
        }
      }
    }
  }
  EXPECT_NEAR(std::abs(hf.height(at_u[0], at_u[1]).du), hf.lipschitz_u(), 1e-3 * hf.lipschitz_u());
  EXPECT_NEAR(std::abs(hf.height(at_v[0], at_v[1]).dv), hf.lipschitz_v(), 1e-3 * hf.lipschitz_v());
  EXPECT_FLOAT_EQ(hf.lipschitz(), std::hypot(hf.lipschitz_u(), hf.lipschitz_v()));
  // §7.3.1 with the per-axis spacing: √2 · max(diff / spacing) over both axes.
  const double paper = std::sqrt(2.0) * 1.5 * std::max(best_u * 11.0, best_v * 6.0);
  EXPECT_LE(hf.lipschitz(), paper * (1 + 1e-5));
  EXPECT_LT(hf.lipschitz(), 0.9 * paper);  // anisotropic raster: strictly better
}

TEST(HeightfieldLipschitz, RangeContainsEveryValue) {
  std::mt19937 rng(5);
  const Raster r = random_raster(10, 10, rng);
  const Heightfield hf = make(r, {.offset = -20.0f, .scale = -4.0f});
  std::uniform_real_distribution<float> coord(-0.5f, 1.5f);
  const Interval range = hf.height_range();
  for (int trial = 0; trial < 2000; ++trial) {
    EXPECT_TRUE(range.contains(hf.height(coord(rng), coord(rng)).value));
  }
  const auto [lo, hi] = std::minmax_element(r.samples.begin(), r.samples.end());
  EXPECT_NEAR(range.lo, -20.0f - 4.0f * *hi, 1e-4f);
  EXPECT_NEAR(range.hi, -20.0f - 4.0f * *lo, 1e-4f);
}

TEST(WyvillRamp, ShapeAndMaximumSlope) {
  EXPECT_EQ(wyvill_ramp(0.0f), 0.0f);
  EXPECT_EQ(wyvill_ramp(1.0f), 1.0f);
  EXPECT_EQ(wyvill_ramp(-1.0f), 0.0f);
  EXPECT_EQ(wyvill_ramp(2.0f), 1.0f);
  EXPECT_EQ(wyvill_ramp_slope(0.0f), 0.0f);
  EXPECT_EQ(wyvill_ramp_slope(1.0f), 0.0f);
  const double exact = 96.0 / (25.0 * std::sqrt(5.0));
  EXPECT_NEAR(exact, 1.7173002067, 1e-9);
  EXPECT_GE(static_cast<double>(kWyvillRampMaxSlope), exact);
  EXPECT_LT(static_cast<double>(kWyvillRampMaxSlope) - exact, 1e-5);
  EXPECT_NEAR(wyvill_ramp_slope(static_cast<float>(1.0 / std::sqrt(5.0))), exact, 1e-6);
  float best = 0.0f;
  for (int k = 0; k <= 100000; ++k) {
    best = std::max(best, wyvill_ramp_slope(static_cast<float>(k) / 100000.0f));
  }
  EXPECT_LE(best, kWyvillRampMaxSlope);
  EXPECT_GT(best, kWyvillRampMaxSlope - 1e-5f);
}

TEST(HeightfieldWeight, BorderFallOffIsOneInsideZeroOutsideAndC1) {
  Raster r;
  r.width = 2;
  r.height = 2;
  r.samples = {0.0f, 0.0f, 0.0f, 0.0f};
  const Heightfield hf = make(r, {.margin_u = 0.1f, .margin_v = 0.2f});
  EXPECT_EQ(hf.weight(0.5f, 0.5f).value, 1.0f);
  EXPECT_EQ(hf.weight(0.11f, 0.21f).value, 1.0f);
  EXPECT_EQ(hf.weight(0.0f, 0.5f).value, 0.0f);
  EXPECT_EQ(hf.weight(0.5f, 1.0f).value, 0.0f);
  EXPECT_EQ(hf.weight(-0.5f, 0.5f).value, 0.0f);
  EXPECT_EQ(hf.weight(0.5f, 3.0f).value, 0.0f);
  // Away from the corners it is w(distance / margin).
  EXPECT_FLOAT_EQ(hf.weight(0.05f, 0.5f).value, wyvill_ramp(0.5f));
  EXPECT_FLOAT_EQ(hf.weight(0.5f, 0.9f).value, wyvill_ramp(0.5f));
  // C1 in the corner: no jump of the gradient across the diagonal (where min(u, v) would kink).
  for (const float t : {0.01f, 0.03f, 0.05f}) {
    const float eps = 1e-4f;
    const UvSample below = hf.weight(t + eps, 2.0f * t - eps);
    const UvSample above = hf.weight(t - eps, 2.0f * t + eps);
    EXPECT_NEAR(below.du, above.du, 0.05f);
    EXPECT_NEAR(below.dv, above.dv, 0.05f);
  }
  // Gradient against central differences (steps stay inside the square: the weight is C1 but
  // identically 0 outside, so a difference across the boundary is one-sided).
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> coord(0.002f, 0.998f);
  for (int trial = 0; trial < 1000; ++trial) {
    const float u = coord(rng), v = coord(rng);
    const float h = 1e-3f;
    const UvSample s = hf.weight(u, v);
    const float fd_u = (hf.weight(u + h, v).value - hf.weight(u - h, v).value) / (2 * h);
    const float fd_v = (hf.weight(u, v + h).value - hf.weight(u, v - h).value) / (2 * h);
    EXPECT_NEAR(s.du, fd_u, 2e-2f) << u << "," << v;
    EXPECT_NEAR(s.dv, fd_v, 2e-2f) << u << "," << v;
  }
  EXPECT_NEAR(hf.weight_lipschitz(), kWyvillRampMaxSlope / 0.1f, 1e-3f);
}

TEST(HeightfieldWeight, LipschitzBoundHoldsWithAndWithoutWeightChannel) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(-0.2f, 1.2f);
  std::uniform_real_distribution<float> near(-0.01f, 0.01f);
  for (const bool with_weight : {false, true}) {
    for (const float margin : {0.5f, 0.1f, 0.02f}) {
      const Raster r = random_raster(6, 9, rng, 1.0f, 1.0f, with_weight);
      const Heightfield hf = make(r, {.margin_u = margin, .margin_v = 0.5f * margin});
      EXPECT_EQ(hf.has_weight(), with_weight);
      const double lambda = hf.weight_lipschitz();
      double steepest = 0.0;
      for (int trial = 0; trial < 20000; ++trial) {
        const Vec2 p{coord(rng), coord(rng)};
        const Vec2 q =
            trial % 2 == 0 ? Vec2{coord(rng), coord(rng)} : Vec2{p.x + near(rng), p.y + near(rng)};
        const UvSample a = hf.weight(p.x, p.y);
        ASSERT_GE(a.value, 0.0f);
        ASSERT_LE(a.value, 1.0f);
        steepest = std::max(steepest, static_cast<double>(std::hypot(a.du, a.dv)));
        const double dw = std::abs(static_cast<double>(a.value) - hf.weight(q.x, q.y).value);
        const double dist = std::hypot(static_cast<double>(p.x - q.x), p.y - q.y);
        ASSERT_LE(dw, lambda * dist * (1 + 1e-4) + 1e-6);
      }
      EXPECT_LE(steepest, lambda);
    }
  }
}

TEST(HeightfieldWeight, ProductFallOffSlopeStaysBelowRampSlopeOnDenseGrid) {
  // |∇(w(s) w(t))| ≤ W' on [0, 1]² (see heightfield.cpp), checked on a dense grid.
  double best = 0.0;
  const int steps = 1500;
  for (int a = 0; a <= steps; ++a) {
    const float s = static_cast<float>(a) / steps;
    for (int b = 0; b <= steps; ++b) {
      const float t = static_cast<float>(b) / steps;
      const double gs = static_cast<double>(wyvill_ramp_slope(s)) * wyvill_ramp(t);
      const double gt = static_cast<double>(wyvill_ramp(s)) * wyvill_ramp_slope(t);
      best = std::max(best, std::hypot(gs, gt));
    }
  }
  EXPECT_LE(best, kWyvillRampMaxSlope);
  EXPECT_GT(best, kWyvillRampMaxSlope - 1e-4f);
}

TEST(HeightfieldWeight, WeightChannelIsClampedAndComposedWithRamp) {
  Raster r;
  r.width = 2;
  r.height = 2;
  r.samples = {0.0f, 0.0f, 0.0f, 0.0f};
  r.weights = {-0.5f, 0.5f, 1.5f, 0.25f};
  const Heightfield hf = make(r, {.margin_u = 0.01f, .margin_v = 0.01f});
  // At the centre the border factor is 1: α = w(bilinear ω) = w(0.4375).
  EXPECT_FLOAT_EQ(hf.weight(0.5f, 0.5f).value, wyvill_ramp(0.4375f));
  // Near the corner with ω < 0 the clamp gives 0, with ω > 1 it gives 1.
  EXPECT_EQ(hf.weight(0.02f, 0.02f).value, 0.0f);
  EXPECT_FLOAT_EQ(hf.weight(0.02f, 0.98f).value, 1.0f);
  EXPECT_EQ(hf.weight(0.02f, 0.98f).du, 0.0f);
  // Gradient against central differences where ω is strictly inside (0, 1).
  const float u = 0.6f, v = 0.4f, h = 1e-3f;
  const UvSample s = hf.weight(u, v);
  EXPECT_NEAR(s.du, (hf.weight(u + h, v).value - hf.weight(u - h, v).value) / (2 * h), 1e-3f);
  EXPECT_NEAR(s.dv, (hf.weight(u, v + h).value - hf.weight(u, v - h).value) / (2 * h), 1e-3f);
}

TEST(HeightfieldPacked, PackedEvaluationEqualsUnpacked) {
  std::mt19937 rng(8);
  const Heightfield plain = make(random_raster(5, 4, rng), {.offset = 1.0f, .scale = 2.0f});
  const Heightfield weighted = make(random_raster(3, 6, rng, 1.0f, 1.0f, true),
                                    {.offset = -1.0f, .scale = 0.5f, .margin_u = 0.2f});
  std::vector<float> pool = {42.0f, 43.0f, 44.0f};  // someone else's record first
  const std::size_t base_plain = pool.size();
  plain.pack(pool);
  const std::size_t base_weighted = pool.size();
  weighted.pack(pool);
  EXPECT_EQ(pool.size(), base_weighted + weighted.packed_size());
  EXPECT_EQ(plain.packed_size(), heightfield_layout::kHeader + 20);
  EXPECT_EQ(weighted.packed_size(), heightfield_layout::kHeader + 36);
  std::uniform_real_distribution<float> coord(-0.2f, 1.2f);
  for (int trial = 0; trial < 1000; ++trial) {
    const float u = coord(rng), v = coord(rng);
    for (const auto& [hf, base] :
         {std::pair{&plain, base_plain}, std::pair{&weighted, base_weighted}}) {
      const UvSample a = hf->height(u, v);
      const UvSample b = heightfield_height(pool.data(), base, u, v);
      EXPECT_EQ(a.value, b.value);
      EXPECT_EQ(a.du, b.du);
      EXPECT_EQ(a.dv, b.dv);
      const UvSample c = hf->weight(u, v);
      const UvSample d = heightfield_weight(pool.data(), base, u, v);
      EXPECT_EQ(c.value, d.value);
      EXPECT_EQ(c.du, d.du);
      EXPECT_EQ(c.dv, d.dv);
    }
  }
}

TEST(HeightfieldCreate, RefusesBadRastersAndParameters) {
  Raster thin;
  thin.width = 1;
  thin.height = 4;
  thin.samples.assign(4, 0.0f);
  EXPECT_FALSE(Heightfield::create(thin).ok());

  Raster r;
  r.width = 3;
  r.height = 2;
  r.samples.assign(6, 0.0f);
  EXPECT_TRUE(Heightfield::create(r).ok());
  EXPECT_FALSE(Heightfield::create(r, {.margin_u = 0.0f}).ok());
  EXPECT_FALSE(Heightfield::create(r, {.margin_v = 0.6f}).ok());
  EXPECT_FALSE(Heightfield::create(r, {.scale = std::nanf("")}).ok());

  Raster short_weights = r;
  short_weights.weights.assign(5, 1.0f);
  EXPECT_FALSE(Heightfield::create(short_weights).ok());

  Raster nan = r;
  nan.samples[4] = std::numeric_limits<float>::infinity();
  const Result<Heightfield> bad = Heightfield::create(nan);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("(x=1, y=1)"), std::string::npos) << bad.error().message;
}

// Quads: a square, a generic one, near-parallelograms, strongly tapered ones, far from the origin,
// in both orientations.
std::vector<std::array<Vec2, 4>> test_quads(std::mt19937& rng) {
  std::vector<std::array<Vec2, 4>> quads;
  quads.push_back({Vec2{0, 0}, Vec2{1, 0}, Vec2{1, 1}, Vec2{0, 1}});
  quads.push_back({Vec2{10, 5}, Vec2{110, 20}, Vec2{95, 130}, Vec2{-5, 90}});
  // Parallelogram and near-parallelograms (k2 → 0 in the quadratic).
  quads.push_back({Vec2{0, 0}, Vec2{100, 10}, Vec2{130, 90}, Vec2{30, 80}});
  quads.push_back({Vec2{0, 0}, Vec2{100, 10}, Vec2{130.001f, 90}, Vec2{30, 80}});
  quads.push_back({Vec2{0, 0}, Vec2{100, 10}, Vec2{130, 90.01f}, Vec2{30, 80}});
  // Trapezoids (one pair of sides parallel) and strong tapers.
  quads.push_back({Vec2{0, 0}, Vec2{100, 0}, Vec2{60, 50}, Vec2{40, 50}});
  quads.push_back({Vec2{0, 0}, Vec2{100, 0}, Vec2{50.5f, 100}, Vec2{49.5f, 100}});
  quads.push_back({Vec2{0, 0}, Vec2{1, 0}, Vec2{1, 100}, Vec2{0, 0.5f}});
  quads.push_back({Vec2{0, 0}, Vec2{200, 0}, Vec2{200, 3}, Vec2{0, 1}});
  // Far from the origin (scene metres).
  quads.push_back({Vec2{5000, -3000}, Vec2{5400, -2950}, Vec2{5350, -2500}, Vec2{4980, -2620}});
  // Random convex quads: four sorted angles on a jittered ellipse.
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (int k = 0; k < 40; ++k) {
    float angle[4];
    float gap = 0.0f;
    while (gap < 0.3f) {  // corners at least 0.3 rad apart on the ellipse
      for (float& a : angle) a = unit(rng) * 6.2831853f;
      std::sort(angle, angle + 4);
      gap = angle[0] + 6.2831853f - angle[3];
      for (int i = 0; i < 3; ++i) gap = std::min(gap, angle[i + 1] - angle[i]);
    }
    const float rx = 10.0f + 200.0f * unit(rng), ry = 10.0f + 200.0f * unit(rng);
    const Vec2 centre{1000.0f * unit(rng), 1000.0f * unit(rng)};
    std::array<Vec2, 4> q;
    for (int i = 0; i < 4; ++i) {
      q[static_cast<std::size_t>(i)] =
          centre + Vec2{rx * std::cos(angle[i]), ry * std::sin(angle[i])};
    }
    if (QuadMap::create(q[0], q[1], q[2], q[3]).ok()) quads.push_back(q);
  }
  // The same quads clockwise (a ↔ b and c ↔ d swap roles: reflect the order b, a, d, c).
  const std::size_t count = quads.size();
  for (std::size_t k = 0; k < count; ++k) {
    const auto& q = quads[k];
    quads.push_back({q[1], q[0], q[3], q[2]});
  }
  return quads;
}

TEST(QuadMapInverse, InvertsForwardOnRandomConvexQuads) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  int quads_checked = 0;
  for (const auto& q : test_quads(rng)) {
    const QuadMap quad = make_quad(q[0], q[1], q[2], q[3]);
    ++quads_checked;
    for (int trial = 0; trial < 400; ++trial) {
      // Include the corners and edges.
      float u = unit(rng), v = unit(rng);
      if (trial < 4) {
        u = static_cast<float>(trial & 1);
        v = static_cast<float>(trial >> 1);
      }
      if (trial >= 4 && trial < 8) u = static_cast<float>(trial & 1);
      const UvMap m = quad.inverse(quad.forward(u, v));
      ASSERT_NEAR(m.u, u, 1e-4f) << "quad " << quads_checked << " " << q[0].x << "," << q[0].y
                                 << " (" << u << "," << v << ")";
      ASSERT_NEAR(m.v, v, 1e-4f) << "quad " << quads_checked << " (" << u << "," << v << ")";
    }
  }
  EXPECT_GT(quads_checked, 60);
}

TEST(QuadMapInverse, JacobianMatchesFiniteDifferences) {
  std::mt19937 rng(10);
  std::uniform_real_distribution<float> unit(0.05f, 0.95f);
  int compared = 0;
  for (const auto& q : test_quads(rng)) {
    const QuadMap quad = make_quad(q[0], q[1], q[2], q[3]);
    for (int trial = 0; trial < 50; ++trial) {
      const Vec2 p = quad.forward(unit(rng), unit(rng));
      const UvMap m = quad.inverse(p);
      ASSERT_TRUE(m.inside);
      // A step that moves (u, v) by about 1e-3 keeps the truncation error of central differences
      // small even where the map is strongly curved (tapered quads), but no smaller than a few
      // hundred ulps of p so that rounding of p does not dominate.
      const double local = spectral_norm(m.du, m.dv);
      const double ulp = std::max(std::abs(p.x), std::abs(p.y)) * 1.2e-7;
      const auto h = static_cast<float>(std::max(1e-3 / local, 256.0 * ulp));
      const UvMap px = quad.inverse(p + Vec2{h, 0}), mx = quad.inverse(p - Vec2{h, 0});
      const UvMap py = quad.inverse(p + Vec2{0, h}), my = quad.inverse(p - Vec2{0, h});
      if (!px.inside || !mx.inside || !py.inside || !my.inside) continue;  // thin quads
      const double tol = 1e-2 * local + 8.0 * ulp * local / h;
      auto fd = [&](float plus, float minus) {
        return (static_cast<double>(plus) - static_cast<double>(minus)) / (2.0 * h);
      };
      EXPECT_NEAR(m.du.x, fd(px.u, mx.u), tol);
      EXPECT_NEAR(m.du.y, fd(py.u, my.u), tol);
      EXPECT_NEAR(m.dv.x, fd(px.v, mx.v), tol);
      EXPECT_NEAR(m.dv.y, fd(py.v, my.v), tol)
          << q[0].x << "," << q[0].y << " " << q[1].x << "," << q[1].y << " " << q[2].x << ","
          << q[2].y << " " << q[3].x << "," << q[3].y << " at " << m.u << "," << m.v;
      ++compared;
    }
  }
  EXPECT_GT(compared, 3000);
}

TEST(QuadMapInverse, JacobianIsInverseOfForwardJacobian) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (const auto& q : test_quads(rng)) {
    const QuadMap quad = make_quad(q[0], q[1], q[2], q[3]);
    for (int trial = 0; trial < 50; ++trial) {
      const float u = unit(rng), v = unit(rng);
      const UvMap m = quad.inverse(quad.forward(u, v));
      Vec2 pu, pv;
      quad.forward_jacobian(m.u, m.v, pu, pv);
      EXPECT_NEAR(dot(m.du, pu), 1.0f, 1e-3f);
      EXPECT_NEAR(dot(m.du, pv), 0.0f, 1e-3f);
      EXPECT_NEAR(dot(m.dv, pu), 0.0f, 1e-3f);
      EXPECT_NEAR(dot(m.dv, pv), 1.0f, 1e-3f);
    }
  }
}

TEST(QuadMapInverse, JacobianNormBoundHoldsOnDenseSamplesAndIsTight) {
  std::mt19937 rng(12);
  for (const auto& q : test_quads(rng)) {
    const QuadMap quad = make_quad(q[0], q[1], q[2], q[3]);
    const double bound = quad.inverse_jacobian_bound();
    double worst = 0.0;
    const int steps = 60;
    for (int a = 0; a <= steps; ++a) {
      for (int b = 0; b <= steps; ++b) {
        const float u = static_cast<float>(a) / steps, v = static_cast<float>(b) / steps;
        Vec2 pu, pv;
        quad.forward_jacobian(u, v, pu, pv);
        // ‖J⁻¹‖ from the exact forward Jacobian (double), independent of the inverse code.
        const double det = static_cast<double>(pu.x) * pv.y - static_cast<double>(pu.y) * pv.x;
        const double norm = spectral_norm(pu, pv) / std::abs(det);
        worst = std::max(worst, norm);
        ASSERT_LE(norm, bound * (1 + 1e-6)) << u << "," << v;
        // And from the inverse map itself (float).
        const UvMap m = quad.inverse(quad.forward(u, v));
        ASSERT_LE(spectral_norm(m.du, m.dv), bound * (1 + 1e-3));
      }
    }
    EXPECT_GE(worst, bound * (1 - 1e-4));  // attained at a corner
  }
}

TEST(QuadMapInverse, ExtendsContinuouslyOutsideWithTheSameBound) {
  std::mt19937 rng(13);
  for (const auto& q : test_quads(rng)) {
    const QuadMap quad = make_quad(q[0], q[1], q[2], q[3]);
    const Box2 box =
        quad.bounds().expanded(0.5f * std::max(quad.bounds().size().x, quad.bounds().size().y));
    std::uniform_real_distribution<float> x(box.lo.x, box.hi.x), y(box.lo.y, box.hi.y);
    const double bound = quad.inverse_jacobian_bound();
    const float step = 0.01f * (box.hi.x - box.lo.x);
    std::uniform_real_distribution<float> near(-step, step);
    for (int trial = 0; trial < 1000; ++trial) {
      const Vec2 p{x(rng), y(rng)};
      const Vec2 r = trial % 2 ? Vec2{x(rng), y(rng)} : p + Vec2{near(rng), near(rng)};
      const UvMap a = quad.inverse(p), b = quad.inverse(r);
      ASSERT_GE(a.u, 0.0f);
      ASSERT_LE(a.u, 1.0f);
      ASSERT_GE(a.v, 0.0f);
      ASSERT_LE(a.v, 1.0f);
      if (!a.inside) {
        // On the boundary of the square: the border weight is 0 there.
        ASSERT_TRUE(a.u == 0.0f || a.u == 1.0f || a.v == 0.0f || a.v == 1.0f);
        ASSERT_LE(spectral_norm(a.du, a.dv), bound);
      }
      const double duv = std::hypot(static_cast<double>(a.u - b.u), a.v - b.v);
      const double dist = std::hypot(static_cast<double>(p.x - r.x), p.y - r.y);
      ASSERT_LE(duv, bound * dist * (1 + 1e-3) + 2e-5);
    }
  }
}

TEST(QuadMapInverse, UnitSquareIsIdentityInsideAndClampOutside) {
  const QuadMap square = make_quad({0, 0}, {1, 0}, {1, 1}, {0, 1});
  EXPECT_EQ(square.orientation(), 1.0f);
  EXPECT_NEAR(square.inverse_jacobian_bound(), 1.0f, 1e-4f);
  const UvMap in = square.inverse({0.25f, 0.75f});
  EXPECT_TRUE(in.inside);
  EXPECT_FLOAT_EQ(in.u, 0.25f);
  EXPECT_FLOAT_EQ(in.v, 0.75f);
  EXPECT_FLOAT_EQ(in.du.x, 1.0f);
  EXPECT_FLOAT_EQ(in.dv.y, 1.0f);
  const UvMap side = square.inverse({1.5f, 0.4f});
  EXPECT_FALSE(side.inside);
  EXPECT_FLOAT_EQ(side.u, 1.0f);
  EXPECT_FLOAT_EQ(side.v, 0.4f);
  EXPECT_EQ(side.du.x, 0.0f);
  EXPECT_FLOAT_EQ(side.dv.y, 1.0f);
  const UvMap corner = square.inverse({-1.0f, 2.0f});
  EXPECT_FLOAT_EQ(corner.u, 0.0f);
  EXPECT_FLOAT_EQ(corner.v, 1.0f);
  EXPECT_EQ(corner.du.x, 0.0f);
  EXPECT_EQ(corner.dv.y, 0.0f);

  // Clockwise corners with a at the north-west: v grows southwards.
  const QuadMap upright = make_quad({0, 1}, {1, 1}, {1, 0}, {0, 0});
  EXPECT_EQ(upright.orientation(), -1.0f);
  const UvMap m = upright.inverse({0.25f, 0.9f});
  EXPECT_NEAR(m.u, 0.25f, 1e-6f);
  EXPECT_NEAR(m.v, 0.1f, 1e-6f);
  EXPECT_NEAR(m.dv.y, -1.0f, 1e-6f);
}

TEST(QuadMapInverse, PackedEqualsUnpacked) {
  const QuadMap quad = make_quad({10, 5}, {110, 20}, {95, 130}, {-5, 90});
  std::vector<float> pool = {1.0f, 2.0f};
  quad.pack(pool);
  ASSERT_EQ(pool.size(), 2 + quad_layout::kSize);
  std::mt19937 rng(14);
  std::uniform_real_distribution<float> coord(-50.0f, 200.0f);
  for (int trial = 0; trial < 1000; ++trial) {
    const Vec2 p{coord(rng), coord(rng)};
    const UvMap a = quad.inverse(p);
    const UvMap b = quad_inverse(pool.data(), 2, p);
    EXPECT_EQ(a.u, b.u);
    EXPECT_EQ(a.v, b.v);
    EXPECT_EQ(a.du, b.du);
    EXPECT_EQ(a.dv, b.dv);
    EXPECT_EQ(a.inside, b.inside);
  }
}

TEST(QuadMapInverse, ComposedHeightGradientMatchesFiniteDifferencesAndBound) {
  std::mt19937 rng(15);
  const Heightfield hf = make(random_raster(8, 8, rng), {.offset = 0.0f, .scale = 20.0f});
  const QuadMap quad = make_quad({0, 0}, {100, 10}, {90, 80}, {-10, 70});
  const double lambda = hf.lipschitz() * quad.inverse_jacobian_bound();
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_real_distribution<float> coord(-30.0f, 130.0f);
  auto world_height = [&](Vec2 p) {
    const UvMap m = quad.inverse(p);
    return hf.height(m.u, m.v).value;
  };
  for (int trial = 0; trial < 300; ++trial) {
    const Vec2 p = quad.forward(unit(rng), unit(rng));
    const UvMap m = quad.inverse(p);
    const Vec2 g = chain(hf.height(m.u, m.v), m);
    const float h = 1e-2f;
    const float fx = (world_height(p + Vec2{h, 0}) - world_height(p - Vec2{h, 0})) / (2 * h);
    const float fy = (world_height(p + Vec2{0, h}) - world_height(p - Vec2{0, h})) / (2 * h);
    // Bilinear cells have kinks; skip samples straddling one (the one-sided slopes differ).
    const float fxr = (world_height(p + Vec2{h, 0}) - world_height(p)) / h;
    const float fxl = (world_height(p) - world_height(p - Vec2{h, 0})) / h;
    const float fyr = (world_height(p + Vec2{0, h}) - world_height(p)) / h;
    const float fyl = (world_height(p) - world_height(p - Vec2{0, h})) / h;
    if (std::abs(fxr - fxl) > 0.05f || std::abs(fyr - fyl) > 0.05f) continue;
    EXPECT_NEAR(g.x, fx, 0.03f);
    EXPECT_NEAR(g.y, fy, 0.03f);
  }
  for (int trial = 0; trial < 3000; ++trial) {
    const Vec2 p{coord(rng), coord(rng)}, r{coord(rng), coord(rng)};
    const double dh = std::abs(static_cast<double>(world_height(p)) - world_height(r));
    ASSERT_LE(dh, lambda * length(p - r) * (1 + 1e-4) + 1e-4);
  }
}

}  // namespace
}  // namespace terrain

namespace terrain {
namespace {

// Catmull-Rom bicubic heights (HeightfieldParams::cubic), what the erosion node packs.

TEST(HeightfieldBicubic, PassesThroughTheSamples) {
  std::mt19937 rng(11);
  const Raster r = random_raster(9, 7, rng, 3.0f, 2.0f);
  const Heightfield hf = make(r, {.cubic = true});
  for (int j = 0; j < 7; ++j) {
    for (int i = 0; i < 9; ++i) {
      EXPECT_NEAR(hf.height(static_cast<float>(i) / 8.0f, static_cast<float>(j) / 6.0f).value,
                  r.at(i, j), 1e-5f);
    }
  }
}

TEST(HeightfieldBicubic, GradientMatchesCentralDifferencesAndIsContinuousAcrossCells) {
  std::mt19937 rng(12);
  const Raster r = random_raster(12, 10, rng, 2.0f, 1.0f);
  const Heightfield hf = make(r, {.cubic = true});
  std::uniform_real_distribution<float> coord(0.02f, 0.98f);
  const float h = 1e-3f;
  for (int trial = 0; trial < 500; ++trial) {
    const float u = coord(rng), v = coord(rng);
    const UvSample s = hf.height(u, v);
    const float du = (hf.height(u + h, v).value - hf.height(u - h, v).value) / (2 * h);
    const float dv = (hf.height(u, v + h).value - hf.height(u, v - h).value) / (2 * h);
    EXPECT_NEAR(s.du, du, 0.02f * (1.0f + std::abs(du))) << u << "," << v;
    EXPECT_NEAR(s.dv, dv, 0.02f * (1.0f + std::abs(dv))) << u << "," << v;
  }
  // C1: on both sides of every inner cell edge the derivatives agree.
  for (int i = 1; i < 11; ++i) {
    const float edge = static_cast<float>(i) / 11.0f;
    for (const float v : {0.13f, 0.5f, 0.77f}) {
      const UvSample left = hf.height(std::nextafter(edge, 0.0f), v);
      const UvSample right = hf.height(std::nextafter(edge, 1.0f), v);
      EXPECT_NEAR(left.du, right.du, 1e-3f * (1.0f + std::abs(left.du))) << i;
    }
  }
}

TEST(HeightfieldBicubic, LipschitzBoundAndRangeHold) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> coord(-0.2f, 1.2f);
  std::uniform_real_distribution<float> near(-0.01f, 0.01f);
  for (const auto& shape : {std::pair{4, 4}, std::pair{17, 5}, std::pair{40, 40}}) {
    const Raster r = random_raster(shape.first, shape.second, rng, 4.0f, 1.0f);
    const Heightfield hf = make(r, {.offset = 3.0f, .scale = -2.0f, .cubic = true});
    for (int trial = 0; trial < 4000; ++trial) {
      const Vec2 p{coord(rng), coord(rng)};
      const Vec2 q =
          trial % 2 == 0 ? Vec2{coord(rng), coord(rng)} : Vec2{p.x + near(rng), p.y + near(rng)};
      const double hp = hf.height(p.x, p.y).value, hq = hf.height(q.x, q.y).value;
      const double dist = std::hypot(static_cast<double>(p.x - q.x), p.y - q.y);
      ASSERT_LE(std::abs(hp - hq), hf.lipschitz() * dist * (1 + 1e-4) + 1e-4);
      ASSERT_GE(hp, hf.height_range().lo);
      ASSERT_LE(hp, hf.height_range().hi);
    }
  }
}

}  // namespace
}  // namespace terrain
