// Bounds of the fractals over small regions (fractal_bounds_near) and the Hessian bounds of the
// bases they rest on (docs/noise.md, "Hessian bounds" and "Bounds over a region").
#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <random>
#include <string>
#include <vector>

#include "terrain/noise.hpp"

namespace {

using namespace terrain;
using namespace terrain::noise;

// The quintic fade s(t) = 6t⁵ − 15t⁴ + 10t³ and its first two derivatives.
double fade(double t) {
  return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}
double fade1(double t) {
  return 30.0 * t * t * (t - 1.0) * (t - 1.0);
}
double fade2(double t) {
  return 60.0 * t * (2.0 * t - 1.0) * (t - 1.0);
}

// The Hessian bound function of 2D gradient noise at cell position (x, y) (docs/noise.md): the
// sum over the corners of the largest ‖K_c(g)‖_F over unit gradients g, times the noise's √2.
double gradient_hessian_bound_function(double x, double y) {
  double total = 0.0;
  for (int cx = 0; cx < 2; ++cx) {
    for (int cy = 0; cy < 2; ++cy) {
      const double wx = cx ? fade(x) : 1.0 - fade(x), wx1 = cx ? fade1(x) : -fade1(x),
                   wx2 = cx ? fade2(x) : -fade2(x);
      const double wy = cy ? fade(y) : 1.0 - fade(y), wy1 = cy ? fade1(y) : -fade1(y),
                   wy2 = cy ? fade2(y) : -fade2(y);
      // A = ∇²w, b = ∇w, d = offset from the corner.
      const double a11 = wx2 * wy, a12 = wx1 * wy1, a22 = wx * wy2;
      const double b1 = wx1 * wy, b2 = wx * wy1;
      const double d1 = x - cx, d2 = y - cy;
      const double a_norm2 = a11 * a11 + 2.0 * a12 * a12 + a22 * a22;
      const double ab1 = a11 * b1 + a12 * b2, ab2 = a12 * b1 + a22 * b2;
      const double bb = b1 * b1 + b2 * b2;
      // ‖K(g)‖² = gᵀMg, M = ‖A‖²ddᵀ + 2(d(Ab)ᵀ + (Ab)dᵀ) + 2|b|²I + 2bbᵀ.
      const double m11 = a_norm2 * d1 * d1 + 4.0 * d1 * ab1 + 2.0 * bb + 2.0 * b1 * b1;
      const double m22 = a_norm2 * d2 * d2 + 4.0 * d2 * ab2 + 2.0 * bb + 2.0 * b2 * b2;
      const double m12 = a_norm2 * d1 * d2 + 2.0 * (d1 * ab2 + ab1 * d2) + 2.0 * b1 * b2;
      const double half_trace = 0.5 * (m11 + m22);
      const double det = m11 * m22 - m12 * m12;
      total += std::sqrt(half_trace + std::sqrt(std::max(half_trace * half_trace - det, 0.0)));
    }
  }
  return std::sqrt(2.0) * total;
}

double dense_maximum(int n) {
  double worst = 0.0;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= n; ++j) {
      worst = std::max(worst, gradient_hessian_bound_function(double(i) / n, double(j) / n));
    }
  }
  return worst;
}

TEST(NoiseHessian, GradientBoundFunctionPeaksWellBelowTheConstant) {
  // The function is a smooth polynomial expression: its grid maxima converge (18.1820), and the
  // constant leaves 10% above them.
  const double coarse = dense_maximum(256), fine = dense_maximum(1024);
  EXPECT_NEAR(coarse, fine, 1e-3);
  EXPECT_NEAR(fine, 18.182, 1e-3);
  EXPECT_LE(fine * 1.09, hessian_bound(Basis::gradient, 2));
}

TEST(NoiseHessian, SimplexVertexBoundTimesThreeStaysBelowTheConstant) {
  // One vertex: ‖K(g)‖_F ≤ √λmax(M) with d = (ρ, 0), t = ½ − ρ²; three vertices, scale 99.
  double worst = 0.0;
  for (int i = 0; i <= 200000; ++i) {
    const double rho = std::sqrt(0.5) * i / 200000.0, t = 0.5 - rho * rho;
    const double c1 = 48.0 * t * t * rho * rho - 8.0 * t * t * t, c2 = -8.0 * t * t * t;
    const double b1 = -8.0 * t * t * t * rho;
    const double m11 = (c1 * c1 + c2 * c2) * rho * rho + 4.0 * rho * c1 * b1 + 4.0 * b1 * b1;
    const double m22 = 2.0 * b1 * b1;
    worst = std::max(worst, std::sqrt(std::max(m11, m22)));
  }
  EXPECT_NEAR(3.0 * 99.0 * worst, 123.81, 0.01);
  EXPECT_LE(3.0 * 99.0 * worst * 1.009, hessian_bound(Basis::simplex, 2));
  EXPECT_TRUE(std::isinf(hessian_bound(Basis::gradient, 3)));
}

TEST(NoiseHessian, GradientDifferencesNeverExceedTheHessianBound) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-200.0f, 200.0f), step(-0.3f, 0.3f);
  for (const Basis basis : {Basis::gradient, Basis::simplex}) {
    const double bound = hessian_bound(basis, 2);
    double worst = 0.0;
    for (int i = 0; i < 400000; ++i) {
      const float x = u(rng), y = u(rng), x2 = x + step(rng), y2 = y + step(rng);
      const Sample2 a = basis == Basis::simplex ? simplex2(x, y, 9) : gradient2(x, y, 9);
      const Sample2 b = basis == Basis::simplex ? simplex2(x2, y2, 9) : gradient2(x2, y2, 9);
      const double d = std::hypot(double{x2} - x, double{y2} - y);
      const double change = std::hypot(double{a.dx} - b.dx, double{a.dy} - b.dy);
      ASSERT_LE(change, bound * d + 1e-4) << (basis == Basis::simplex ? "simplex" : "gradient");
      if (d > 1e-3) worst = std::max(worst, change / d);
    }
    // Sound, and not so loose that small regions gain nothing (gradient ≈ 12 sampled).
    EXPECT_GE(worst, (basis == Basis::simplex ? 0.15 : 0.4) * bound);
  }
}

FractalParams params(Fractal kind, Basis basis, int octaves) {
  FractalParams p;
  p.kind = kind;
  p.basis = basis;
  p.seed = 31;
  p.octaves = octaves;
  p.frequency = 1.0f / 900.0f;
  p.amplitude = 120.0f;
  p.lacunarity = 2.05f;
  p.hurst = 0.9f;
  return p;
}

std::string label(const FractalParams& p, float radius) {
  const char* kinds[] = {"fbm", "ridged", "hybrid", "warped"};
  return std::string(kinds[static_cast<int>(p.kind)]) +
         (p.basis == Basis::simplex ? "/simplex" : "/gradient") + " r=" + std::to_string(radius);
}

Vec2 in_disc(std::mt19937& rng, Vec2 centre, float r) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  while (true) {
    const float x = u(rng), y = u(rng);
    if (x * x + y * y <= 1.0f) return {centre.x + r * x, centre.y + r * y};
  }
}

TEST(FractalRegionBounds, HoldAtEveryPointOfTheRegion) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> far(-3000.0f, 3000.0f);
  for (const Fractal kind : {Fractal::fbm, Fractal::ridged, Fractal::hybrid}) {
    for (const Basis basis : {Basis::gradient, Basis::simplex}) {
      for (const float octaves : {1.0f, 3.5f, 9.0f}) {
        const FractalParams p = params(kind, basis, 9);
        const Interval global_range = fractal_range(p, octaves);
        const float global_slope = fractal_lipschitz(p, octaves, 0.0f);
        for (const float radius : {0.3f, 4.0f, 60.0f, 900.0f}) {
          for (int region = 0; region < 40; ++region) {
            const Vec2 centre{far(rng), far(rng)};
            const RegionBounds b = fractal_bounds_near(p, octaves, centre, radius);
            ASSERT_LE(b.lipschitz, global_slope) << label(p, radius);
            ASSERT_GE(b.value.lo, global_range.lo);
            ASSERT_LE(b.value.hi, global_range.hi);
            for (int k = 0; k < 60; ++k) {
              const Vec2 a = in_disc(rng, centre, radius);
              const Sample2 s = fractal2(p, a, octaves);
              const float tol = 1e-5f * (1.0f + std::abs(s.value));
              ASSERT_GE(s.value, b.value.lo - tol) << label(p, radius);
              ASSERT_LE(s.value, b.value.hi + tol) << label(p, radius);
              ASSERT_LE(std::hypot(s.dx, s.dy), b.lipschitz * 1.0001f + 1e-6f) << label(p, radius);
              ASSERT_LE(std::hypot(s.dx - b.gradient_at_centre.x, s.dy - b.gradient_at_centre.y),
                        b.gradient_spread * 1.0001f + 1e-6f)
                  << label(p, radius) << ": the gradient strays beyond its spread";
              const Vec2 q = in_disc(rng, centre, radius);
              const double d = std::hypot(double{a.x} - q.x, double{a.y} - q.y);
              ASSERT_LE(std::abs(double{s.value} - fractal2(p, q, octaves).value),
                        b.lipschitz * d + 2.0 * tol)
                  << label(p, radius);
            }
          }
        }
      }
    }
  }
}

// A tracer reuses one bound over a band of levels of detail: bounds asked for a range of octave
// counts hold at every count in it, although a region's bounds need not shrink with the count
// (an octave that cancels another's slope at the centre may drop out).
TEST(FractalRegionBounds, HoldAtEveryOctaveCountOfTheBand) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> far(-3000.0f, 3000.0f), unit(0.0f, 1.0f);
  for (const Fractal kind : {Fractal::fbm, Fractal::ridged, Fractal::hybrid}) {
    for (const Basis basis : {Basis::gradient, Basis::simplex}) {
      const FractalParams p = params(kind, basis, 9);
      for (const Interval band :
           {Interval{0.0f, 9.0f}, Interval{2.3f, 4.1f}, Interval{6.0f, 8.5f}}) {
        for (const float radius : {0.5f, 8.0f, 120.0f}) {
          for (int region = 0; region < 30; ++region) {
            const Vec2 centre{far(rng), far(rng)};
            const RegionBounds b = fractal_bounds_near(p, band, centre, radius);
            for (int k = 0; k < 40; ++k) {
              const float octaves = band.lo + unit(rng) * band.width();
              const Vec2 a = in_disc(rng, centre, radius);
              const Sample2 s = fractal2(p, a, octaves);
              const float tol = 1e-5f * (1.0f + std::abs(s.value));
              ASSERT_GE(s.value, b.value.lo - tol) << label(p, radius) << " octaves " << octaves;
              ASSERT_LE(s.value, b.value.hi + tol) << label(p, radius) << " octaves " << octaves;
              ASSERT_LE(std::hypot(s.dx, s.dy), b.lipschitz * 1.0001f + 1e-6f)
                  << label(p, radius) << " octaves " << octaves;
            }
          }
        }
      }
    }
  }
}

TEST(FractalRegionBounds, SmallRegionsGetTheSlopeTheyHave) {
  // Four octaves from 900 m: over a metre every octave is nearly a plane, so the bound is near
  // the slope at the centre, far below the worst case of the four octaves together.
  std::mt19937 rng(3);
  for (const Fractal kind : {Fractal::fbm, Fractal::ridged}) {
    const FractalParams p = params(kind, Basis::gradient, 4);
    const float global = fractal_lipschitz(p, 4.0f, 0.0f);
    double bound_sum = 0.0, slope_sum = 0.0;
    for (int region = 0; region < 200; ++region) {
      const Vec2 centre = in_disc(rng, {0.0f, 0.0f}, 2000.0f);
      const RegionBounds b = fractal_bounds_near(p, 4.0f, centre, 1.0f);
      const Sample2 s = fractal2(p, centre, 4.0f);
      bound_sum += b.lipschitz;
      slope_sum += std::hypot(s.dx, s.dy);
      EXPECT_LE(b.value.width(), 2.0f * b.lipschitz * 1.0001f + 1e-3f) << "over a metre";
    }
    EXPECT_LT(bound_sum / 200.0, 0.5 * global) << "mean region bound against the global";
    // fBm's octaves add as vectors at the centre; ridged's as magnitudes (|Σ∇| ≤ Σ|∇|, about
    // twice the slope for four random directions).
    EXPECT_LT(bound_sum, (kind == Fractal::fbm ? 1.2 : 2.5) * slope_sum)
        << "mean region bound against the mean slope";
  }
}

TEST(FractalRegionBounds, SmallFbmRegionsKnowTheGradientItself) {
  // Three octaves from 1800 m over 10 m: the gradient is nearly the centre's, within a spread far
  // below its length.
  FractalParams p = params(Fractal::fbm, Basis::gradient, 3);
  p.frequency = 1.0f / 1800.0f;
  std::mt19937 rng(5);
  for (int region = 0; region < 100; ++region) {
    const Vec2 centre = in_disc(rng, {0.0f, 0.0f}, 2000.0f);
    const RegionBounds b = fractal_bounds_near(p, 3.0f, centre, 10.0f);
    const Sample2 s = fractal2(p, centre, 3.0f);
    EXPECT_NEAR(b.gradient_at_centre.x, s.dx, 1e-3f * b.lipschitz);
    EXPECT_NEAR(b.gradient_at_centre.y, s.dy, 1e-3f * b.lipschitz);
    EXPECT_LT(b.gradient_spread, 0.25f * fractal_lipschitz(p, 3.0f, 0.0f));
  }
}

// η_i reaches the gradient through its own term and the next octave's weight, which never both
// peak at one point; counting each at its peak made the bound 20% looser per octave.
TEST(FractalLipschitz, RidgedBoundCountsEachOctavesPeakOnce) {
  const FractalParams p = params(Fractal::ridged, Basis::gradient, 9);
  std::mt19937 rng(41);
  float steepest = 0.0f;
  for (int k = 0; k < 400000; ++k) {
    const Sample2 s = fractal2(p, in_disc(rng, {0.0f, 0.0f}, 3000.0f), 9.0f);
    steepest = std::max(steepest, std::hypot(s.dx, s.dy));
  }
  const float bound = fractal_lipschitz(p, 9.0f, 0.0f);
  EXPECT_GE(bound, steepest);
  // 3.46 now; 4.1 when the two peaks were added.
  EXPECT_LE(bound, 3.75f * steepest) << "bound " << bound << ", steepest " << steepest;
}

TEST(FractalRegionBounds, WarpedKindGetsItsGlobalBounds) {
  FractalParams p = params(Fractal::warped, Basis::gradient, 6);
  p.warp_c1 = 0.002f;
  p.warp_c3 = {0.001f, 0.002f};
  const RegionBounds b = fractal_bounds_near(p, 6.0f, {100.0f, 50.0f}, 1.0f);
  // For every point within 1 m of the centre, |p| ≤ |centre| + 1.
  EXPECT_EQ(b.lipschitz, fractal_lipschitz(p, 6.0f, length(Vec2{100.0f, 50.0f}) + 1.0f));
  EXPECT_EQ(b.value.lo, fractal_range(p, 6.0f).lo);
}

}  // namespace
