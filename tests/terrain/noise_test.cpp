// Tests of terrain/noise: hash, single-octave bases (range, exact gradients, Lipschitz bounds with
// an interval certificate, golden values) and the fractal sums (gradients, bounds, LoD continuity,
// batch == scalar bit for bit, determinism).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "terrain/noise.hpp"

namespace terrain::noise {
namespace {

// ------------------------------------------------------------------------------------------------
// Helpers.

std::uint32_t bits(float x) {
  return std::bit_cast<std::uint32_t>(x);
}

double norm2(const Sample2& s) {
  return std::hypot(double{s.dx}, double{s.dy});
}
double norm3(const Sample3& s) {
  return std::sqrt(double{s.dx} * s.dx + double{s.dy} * s.dy + double{s.dz} * s.dz);
}

struct Basis2Case {
  const char* name;
  Basis basis;
  Sample2 (*fn)(float, float, std::uint32_t);
};
struct Basis3Case {
  const char* name;
  Basis basis;
  Sample3 (*fn)(float, float, float, std::uint32_t);
};
const Basis2Case kBases2[] = {{"gradient2", Basis::gradient, gradient2},
                              {"simplex2", Basis::simplex, simplex2}};
const Basis3Case kBases3[] = {{"gradient3", Basis::gradient, gradient3},
                              {"simplex3", Basis::simplex, simplex3}};

const char* kind_name(Fractal k) {
  switch (k) {
    case Fractal::fbm:
      return "fbm";
    case Fractal::ridged:
      return "ridged";
    case Fractal::hybrid:
      return "hybrid";
    case Fractal::warped:
      return "warped";
  }
  return "?";
}

constexpr Fractal kKinds[] = {Fractal::fbm, Fractal::ridged, Fractal::hybrid, Fractal::warped};
constexpr Basis kBases[] = {Basis::gradient, Basis::simplex};

// Typical parameters: 6 octaves from 0.1 cycles/m, with a strong warp for the warped kind.
FractalParams test_params(Fractal kind, Basis basis, std::uint32_t seed = 77) {
  FractalParams p;
  p.kind = kind;
  p.basis = basis;
  p.seed = seed;
  p.octaves = 6;
  p.frequency = 0.1f;
  p.amplitude = 1.0f;
  p.lacunarity = 2.0f;
  p.hurst = 0.8f;
  p.ridge_offset = 1.0f;
  p.ridge_gain = 2.0f;
  p.warp_c1 = 0.35f;
  p.warp_c2 = 0.13f;
  p.warp_c3 = {0.11f, 0.17f};
  return p;
}

std::string label(const FractalParams& p) {
  return std::string(kind_name(p.kind)) + (p.basis == Basis::simplex ? "/simplex" : "/gradient");
}

// Uniform points in a disc of radius r around the origin.
Vec2 in_disc(std::mt19937& rng, float r) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  while (true) {
    const float x = u(rng), y = u(rng);
    if (x * x + y * y <= 1.0f) return {r * x, r * y};
  }
}

// ------------------------------------------------------------------------------------------------
// Hash.

TEST(NoiseHash, MatchesLowbias32ReferenceValues) {
  // Reference: lowbias32 by Chris Wellons (xorshift 16, ×0x7feb352d, xorshift 15, ×0x846ca68b,
  // xorshift 16); it maps 0 to 0.
  EXPECT_EQ(hash(0u), 0u);
  std::uint32_t x = 1u;
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  EXPECT_EQ(hash(1u), x);
  EXPECT_EQ(hash(1u), 0x688990c0u);
  EXPECT_EQ(hash(0xdeadbeefu), 0xe628c683u);
}

TEST(NoiseHash, StructuredKeysDependOnOrder) {
  EXPECT_NE(hash(1u, 2u), hash(2u, 1u));
  EXPECT_NE(hash(1u, 2u, 3u), hash(3u, 2u, 1u));
  EXPECT_NE(hash(1u, 2u, 3u, 4u), hash(4u, 3u, 2u, 1u));
  EXPECT_EQ(hash(5u, 6u, 7u), hash(hash(5u, 6u), 7u));
}

TEST(NoiseHash, FlippingAnInputBitFlipsAboutHalfTheOutputBits) {
  std::mt19937 rng(3);
  double total = 0.0;
  int count = 0;
  for (int i = 0; i < 2000; ++i) {
    const auto x = static_cast<std::uint32_t>(rng());
    for (int b = 0; b < 32; ++b) {
      total += std::popcount(hash(x) ^ hash(x ^ (1u << b)));
      ++count;
    }
  }
  EXPECT_NEAR(total / count, 16.0, 0.2);
}

// ------------------------------------------------------------------------------------------------
// Single-octave bases: range, gradients, Lipschitz bounds.

TEST(NoiseBasis, ValuesStayWithinUnitRangeOnMillionsOfPoints) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-500.0f, 500.0f);
  float max2[2] = {0, 0}, max3[2] = {0, 0};
  for (int i = 0; i < 2'000'000; ++i) {
    const float x = u(rng), y = u(rng), z = u(rng);
    const auto seed = static_cast<std::uint32_t>(i & 15);
    for (int b = 0; b < 2; ++b) {
      const float v2 = kBases2[b].fn(x, y, seed).value;
      const float v3 = kBases3[b].fn(x, y, z, seed).value;
      ASSERT_LE(std::abs(v2), 1.0f) << kBases2[b].name << " at " << x << "," << y;
      ASSERT_LE(std::abs(v3), 1.0f) << kBases3[b].name << " at " << x << "," << y << "," << z;
      max2[b] = std::max(max2[b], std::abs(v2));
      max3[b] = std::max(max3[b], std::abs(v3));
    }
  }
  // The scales are not wasteful: the sampled extremes come close to the proven ±1.
  EXPECT_GT(max2[0], 0.9f);
  EXPECT_GT(max2[1], 0.95f);
  EXPECT_GT(max3[0], 0.7f);  // twelve edge gradients cannot point at the cell centre
  EXPECT_GT(max3[1], 0.95f);
}

TEST(NoiseBasis, GradientMatchesCentralDifferences) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-40.0f, 40.0f);
  const float h = 1.0f / 1024.0f;
  for (const auto& b : kBases2) {
    for (int i = 0; i < 20000; ++i) {
      const float x = u(rng), y = u(rng);
      const Sample2 s = b.fn(x, y, 9);
      const double fx = (double{b.fn(x + h, y, 9).value} - b.fn(x - h, y, 9).value) / (2.0 * h);
      const double fy = (double{b.fn(x, y + h, 9).value} - b.fn(x, y - h, 9).value) / (2.0 * h);
      ASSERT_NEAR(s.dx, fx, 2e-3 * (1.0 + std::abs(fx))) << b.name << " at " << x << "," << y;
      ASSERT_NEAR(s.dy, fy, 2e-3 * (1.0 + std::abs(fy))) << b.name << " at " << x << "," << y;
    }
  }
  for (const auto& b : kBases3) {
    for (int i = 0; i < 20000; ++i) {
      const float x = u(rng), y = u(rng), z = u(rng);
      const Sample3 s = b.fn(x, y, z, 9);
      const double fx =
          (double{b.fn(x + h, y, z, 9).value} - b.fn(x - h, y, z, 9).value) / (2.0 * h);
      const double fy =
          (double{b.fn(x, y + h, z, 9).value} - b.fn(x, y - h, z, 9).value) / (2.0 * h);
      const double fz =
          (double{b.fn(x, y, z + h, 9).value} - b.fn(x, y, z - h, 9).value) / (2.0 * h);
      ASSERT_NEAR(s.dx, fx, 2e-3 * (1.0 + std::abs(fx))) << b.name;
      ASSERT_NEAR(s.dy, fy, 2e-3 * (1.0 + std::abs(fy))) << b.name;
      ASSERT_NEAR(s.dz, fz, 2e-3 * (1.0 + std::abs(fz))) << b.name;
    }
  }
}

TEST(NoiseBasis, IsContinuousAcrossCellAndSimplexBoundaries) {
  // Walk lines in random directions with small steps, crossing hundreds of cell and simplex
  // faces: every step must agree with the trapezoid rule on the analytic gradient. A jump of the
  // value (or a wrong gradient) anywhere along the way breaks it; smooth noise errs by at most
  // δ³/12 times the third derivative.
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-60.0f, 60.0f), angle(0.0f, 6.2831853f);
  const float delta = 1.0f / 512.0f;
  // Each basis adds its sub-cell lattice offset to the coordinates, which rounds them to the
  // float spacing of the sum: a value may belong to a point up to half that spacing away.
  const auto tolerance = [](Basis basis, int dims, float x, float y, float z = 0.0f) {
    const float m = std::max({std::abs(x), std::abs(y), std::abs(z)}) + 1.0f;
    const double spacing = std::nextafter(m, 2.0f * m) - m;
    return 2e-6 + 1.5 * lipschitz(basis, dims) * spacing;
  };
  for (const auto& b : kBases2) {
    for (int line = 0; line < 20; ++line) {
      const float x0 = u(rng), y0 = u(rng), a = angle(rng);
      const float ex = std::cos(a), ey = std::sin(a);
      Sample2 prev = b.fn(x0, y0, 1);
      float px = x0, py = y0;
      for (int k = 1; k <= 20000; ++k) {
        const float d = delta * static_cast<float>(k);
        const float x = x0 + ex * d, y = y0 + ey * d;
        const Sample2 s = b.fn(x, y, 1);
        const double change = double{s.value} - prev.value;
        const double slope = 0.5 * ((double{x} - px) * (double{s.dx} + prev.dx) +
                                    (double{y} - py) * (double{s.dy} + prev.dy));
        ASSERT_NEAR(change, slope, tolerance(b.basis, 2, x, y)) << b.name << " line " << line;
        prev = s;
        px = x;
        py = y;
      }
    }
  }
  for (const auto& b : kBases3) {
    for (int line = 0; line < 10; ++line) {
      const float x0 = u(rng), y0 = u(rng), z0 = u(rng);
      float e[3] = {u(rng), u(rng), u(rng)};
      const float len = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
      for (float& c : e) c /= len;
      Sample3 prev = b.fn(x0, y0, z0, 1);
      float p[3] = {x0, y0, z0};
      for (int k = 1; k <= 20000; ++k) {
        const float d = delta * static_cast<float>(k);
        const float q[3] = {x0 + e[0] * d, y0 + e[1] * d, z0 + e[2] * d};
        const Sample3 s = b.fn(q[0], q[1], q[2], 1);
        const double change = double{s.value} - prev.value;
        const double slope = 0.5 * ((double{q[0]} - p[0]) * (double{s.dx} + prev.dx) +
                                    (double{q[1]} - p[1]) * (double{s.dy} + prev.dy) +
                                    (double{q[2]} - p[2]) * (double{s.dz} + prev.dz));
        ASSERT_NEAR(change, slope, tolerance(b.basis, 3, q[0], q[1], q[2]))
            << b.name << " line " << line;
        prev = s;
        std::copy(q, q + 3, p);
      }
    }
  }
}

TEST(NoiseBasis, LipschitzBoundHoldsOnDenseSamplesAndIsTight) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(-300.0f, 300.0f);
  for (const auto& b : kBases2) {
    const double bound = lipschitz(b.basis, 2);
    double worst = 0.0;
    for (int i = 0; i < 3'000'000; ++i) {
      const double g = norm2(b.fn(u(rng), u(rng), static_cast<std::uint32_t>(i & 7)));
      ASSERT_LE(g, bound) << b.name;
      worst = std::max(worst, g);
    }
    EXPECT_GE(worst, 0.4 * bound) << b.name << " bound " << bound << " is loose";
  }
  for (const auto& b : kBases3) {
    const double bound = lipschitz(b.basis, 3);
    double worst = 0.0;
    for (int i = 0; i < 3'000'000; ++i) {
      const double g = norm3(b.fn(u(rng), u(rng), u(rng), static_cast<std::uint32_t>(i & 7)));
      ASSERT_LE(g, bound) << b.name;
      worst = std::max(worst, g);
    }
    EXPECT_GE(worst, 0.4 * bound) << b.name << " bound " << bound << " is loose";
  }
  EXPECT_TRUE(std::isinf(lipschitz(Basis::gradient, 4)));
}

TEST(NoiseBasis, DifferencesNeverExceedTheLipschitzBound) {
  std::mt19937 rng(22);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f), step(-1.5f, 1.5f);
  for (const auto& b : kBases2) {
    const double bound = lipschitz(b.basis, 2);
    for (int i = 0; i < 200000; ++i) {
      const float x = u(rng), y = u(rng), x2 = x + step(rng), y2 = y + step(rng);
      const double d = std::hypot(double{x2} - x, double{y2} - y);
      ASSERT_LE(std::abs(double{b.fn(x, y, 3).value} - b.fn(x2, y2, 3).value), bound * d + 1e-6);
    }
  }
}

TEST(NoiseBasis, SeedsGiveDifferentFieldsAndTheSameSeedTheSameField) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-100.0f, 100.0f);
  for (const auto& b : kBases2) {
    int same = 0;
    double correlation = 0.0;
    for (int i = 0; i < 4000; ++i) {
      const float x = u(rng), y = u(rng);
      const Sample2 a = b.fn(x, y, 0), a2 = b.fn(x, y, 0), c = b.fn(x, y, 1);
      EXPECT_EQ(bits(a.value), bits(a2.value));
      EXPECT_EQ(bits(a.dx), bits(a2.dx));
      same += a.value == c.value;
      correlation += double{a.value} * c.value;
    }
    EXPECT_LT(same, 10) << b.name;
    EXPECT_LT(std::abs(correlation / 4000.0), 0.02) << b.name << ": seeds 0 and 1 correlate";
  }
  for (const auto& b : kBases3) {
    int same = 0;
    for (int i = 0; i < 4000; ++i) {
      const float x = u(rng), y = u(rng), z = u(rng);
      same += b.fn(x, y, z, 0).value == b.fn(x, y, z, 1).value;
      EXPECT_EQ(bits(b.fn(x, y, z, 5).value), bits(b.fn(x, y, z, 5).value));
    }
    EXPECT_LT(same, 10) << b.name;
  }
}

TEST(NoiseBasis, WorksAtNegativeAndLargeCoordinates) {
  // Far from the origin floats are coarse (spacing 1/16 at 10^6), so instead of finite
  // differences the gradient is integrated with Simpson's rule along a segment of representable
  // points: it must reproduce the change of value. This checks the floor (also for negative
  // inputs), the cell hashing and the gradient together at every magnitude.
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> frac(0.0f, 1.0f);
  for (const float centre : {-1.0e6f, -123456.0f, -3.0f, 3.0f, 654321.0f, 1.0e6f}) {
    const float ulp = std::nextafter(std::abs(centre), 2e6f) - std::abs(centre);
    const float step = std::max(ulp, 1.0f / 64.0f);
    const int steps = 32;  // even, for Simpson
    for (const auto& b : kBases2) {
      for (int i = 0; i < 200; ++i) {
        const float x0 = centre + step * std::floor(frac(rng) * 64.0f);
        const float y0 = -centre + step * std::floor(frac(rng) * 64.0f);
        const float ex = i % 2 == 0 ? 1.0f : 0.0f, ey = 1.0f - ex;
        double integral = 0.0;
        for (int k = 0; k <= steps; ++k) {
          const float d = step * static_cast<float>(k);
          const Sample2 s = b.fn(x0 + ex * d, y0 + ey * d, 2);
          ASSERT_TRUE(std::isfinite(s.value) && std::isfinite(s.dx) && std::isfinite(s.dy));
          ASSERT_LE(std::abs(s.value), 1.0f);
          const double w = (k == 0 || k == steps) ? 1.0 : (k % 2 == 1 ? 4.0 : 2.0);
          integral += w * (ex * s.dx + ey * s.dy);
        }
        integral *= step / 3.0;
        const float span = step * static_cast<float>(steps);
        const double change =
            double{b.fn(x0 + ex * span, y0 + ey * span, 2).value} - b.fn(x0, y0, 2).value;
        ASSERT_NEAR(integral, change, 0.01) << b.name << " near " << centre;
      }
    }
    for (const auto& b : kBases3) {
      for (int i = 0; i < 100; ++i) {
        const float x0 = centre + step * std::floor(frac(rng) * 64.0f);
        double integral = 0.0;
        for (int k = 0; k <= steps; ++k) {
          const float d = step * static_cast<float>(k);
          const Sample3 s = b.fn(x0, -centre, centre + d, 2);
          ASSERT_TRUE(std::isfinite(s.value) && std::isfinite(s.dz));
          ASSERT_LE(std::abs(s.value), 1.0f);
          integral += ((k == 0 || k == steps) ? 1.0 : (k % 2 == 1 ? 4.0 : 2.0)) * s.dz;
        }
        integral *= step / 3.0;
        const float span = step * static_cast<float>(steps);
        const double change =
            double{b.fn(x0, -centre, centre + span, 2).value} - b.fn(x0, -centre, centre, 2).value;
        ASSERT_NEAR(integral, change, 0.01) << b.name << " near " << centre;
      }
    }
  }
  // Beyond the clamp limit (2^26) and for non-finite input the result is still finite.
  for (const float x : {3.0e9f, -3.0e9f, std::numeric_limits<float>::infinity(),
                        std::numeric_limits<float>::quiet_NaN()}) {
    for (const auto& b : kBases2) EXPECT_TRUE(std::isfinite(b.fn(x, 1.5f, 0).value)) << b.name;
    for (const auto& b : kBases3) EXPECT_TRUE(std::isfinite(b.fn(x, 1.5f, x, 0).value)) << b.name;
  }
}

// ------------------------------------------------------------------------------------------------
// Interval certificates of the constants (docs/noise.md, "Lipschitz bounds"). A box of positions
// is bounded with interval arithmetic; boxes whose bound exceeds the target are split. The
// certificate holds when every box ends below the target; a centre point above it refutes it.

struct Iv {
  double lo = 0.0;
  double hi = 0.0;
};
Iv point(double v) {
  return {v, v};
}
Iv operator+(Iv a, Iv b) {
  return {a.lo + b.lo, a.hi + b.hi};
}
Iv operator-(Iv a, Iv b) {
  return {a.lo - b.hi, a.hi - b.lo};
}
Iv operator*(Iv a, Iv b) {
  const double p[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
  return {std::min({p[0], p[1], p[2], p[3]}), std::max({p[0], p[1], p[2], p[3]})};
}
Iv operator*(double s, Iv a) {
  return point(s) * a;
}
Iv square(Iv a) {
  if (a.lo >= 0.0) return {a.lo * a.lo, a.hi * a.hi};
  if (a.hi <= 0.0) return {a.hi * a.hi, a.lo * a.lo};
  return {0.0, std::max(a.lo * a.lo, a.hi * a.hi)};
}
double magnitude(Iv a) {
  return std::max(std::abs(a.lo), std::abs(a.hi));
}

// A polynomial with a tight range on short intervals: the endpoints, widened by the chord error
// (b − a)²/8 · max|f''| where max|f''| comes from interval Horner evaluation of f''.
struct Poly {
  std::vector<double> c;  // c[i] x^i
  double operator()(double x) const {
    double r = 0.0;
    for (std::size_t i = c.size(); i-- > 0;) r = r * x + c[i];
    return r;
  }
  Iv range(double a, double b) const {
    Iv curvature = point(0.0);
    for (std::size_t i = c.size(); i-- > 2;) {
      curvature = curvature * Iv{a, b} + point(c[i] * static_cast<double>(i * (i - 1)));
    }
    const double fa = (*this)(a), fb = (*this)(b);
    const double chord = magnitude(curvature) * (b - a) * (b - a) / 8.0;
    return {std::min(fa, fb) - chord, std::max(fa, fb) + chord};
  }
};
Poly operator+(const Poly& a, const Poly& b) {
  Poly r{std::vector<double>(std::max(a.c.size(), b.c.size()), 0.0)};
  for (std::size_t i = 0; i < a.c.size(); ++i) r.c[i] += a.c[i];
  for (std::size_t i = 0; i < b.c.size(); ++i) r.c[i] += b.c[i];
  return r;
}
Poly operator*(const Poly& a, const Poly& b) {
  Poly r{std::vector<double>(a.c.size() + b.c.size() - 1, 0.0)};
  for (std::size_t i = 0; i < a.c.size(); ++i) {
    for (std::size_t j = 0; j < b.c.size(); ++j) r.c[i + j] += a.c[i] * b.c[j];
  }
  return r;
}
Poly operator*(double s, const Poly& a) {
  return Poly{{s}} * a;
}
Poly power(const Poly& a, int n) {
  Poly r{{1.0}};
  for (int i = 0; i < n; ++i) r = r * a;
  return r;
}

// Largest eigenvalue of a symmetric N×N matrix (cyclic Jacobi).
template <int N>
double max_eigenvalue(std::array<std::array<double, N>, N> a) {
  for (int sweep = 0; sweep < 50; ++sweep) {
    double off = 0.0;
    for (int i = 0; i < N; ++i) {
      for (int j = i + 1; j < N; ++j) off += a[i][j] * a[i][j];
    }
    if (off < 1e-30) break;
    for (int p = 0; p < N; ++p) {
      for (int q = p + 1; q < N; ++q) {
        if (a[p][q] == 0.0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::hypot(theta, 1.0));
        const double c = 1.0 / std::hypot(t, 1.0), s = t * c;
        for (int k = 0; k < N; ++k) {
          const double kp = a[k][p], kq = a[k][q];
          a[k][p] = c * kp - s * kq;
          a[k][q] = s * kp + c * kq;
        }
        for (int k = 0; k < N; ++k) {
          const double pk = a[p][k], qk = a[q][k];
          a[p][k] = c * pk - s * qk;
          a[q][k] = s * pk + c * qk;
        }
      }
    }
  }
  double m = a[0][0];
  for (int i = 1; i < N; ++i) m = std::max(m, a[i][i]);
  return m;
}

// Upper bound of λmax over a symmetric interval matrix (Weyl: λmax(mid) + ‖radius‖_F).
template <int N>
double max_eigenvalue_bound(const std::array<std::array<Iv, N>, N>& a) {
  std::array<std::array<double, N>, N> mid{};
  double radius = 0.0;
  for (int i = 0; i < N; ++i) {
    for (int j = 0; j < N; ++j) {
      mid[i][j] = 0.5 * (a[i][j].lo + a[i][j].hi);
      radius += 0.25 * (a[i][j].hi - a[i][j].lo) * (a[i][j].hi - a[i][j].lo);
    }
  }
  return max_eigenvalue<N>(mid) + std::sqrt(radius) + 1e-12;
}

template <int D>
struct Box {
  std::array<double, D> lo, hi;
};

struct Certificate {
  bool proven = false;
  double sampled_max = 0.0;  // largest centre value seen (a lower bound of the true maximum)
  long boxes = 0;
};

// Proves bound(box) ≤ target on every box of the region; `inside` prunes boxes off the region.
template <int D, class Bound, class Inside>
Certificate certify(const Box<D>& root, Bound bound, Inside inside, double target, long budget) {
  Certificate out;
  std::vector<Box<D>> stack{root};
  while (!stack.empty()) {
    const Box<D> b = stack.back();
    stack.pop_back();
    if (!inside(b)) continue;
    if (++out.boxes > budget) return out;
    Box<D> centre;
    for (int k = 0; k < D; ++k) centre.lo[k] = centre.hi[k] = 0.5 * (b.lo[k] + b.hi[k]);
    if (inside(centre)) {
      const double v = bound(centre);
      out.sampled_max = std::max(out.sampled_max, v);
      if (v > target) return out;
    }
    if (bound(b) <= target) continue;
    int axis = 0;
    for (int k = 1; k < D; ++k) {
      if (b.hi[k] - b.lo[k] > b.hi[axis] - b.lo[axis]) axis = k;
    }
    Box<D> left = b, right = b;
    left.hi[axis] = right.lo[axis] = centre.lo[axis];
    stack.push_back(left);
    stack.push_back(right);
  }
  out.proven = true;
  return out;
}

// Gradient noise. With M_c = w_c I + d_c ∇w_cᵀ (corner weight w_c, offset d_c), |∇n| ≤
// max_e Σ_c |M_c e| ≤ √(2^N λmax(Σ_c M_cᵀM_c)) (Cauchy–Schwarz). Σ_c factorises over the axes
// into 1D polynomials of each coordinate (docs/noise.md), evaluated with tight ranges.
struct AxisPolys {
  Poly q, b, t, s2, a, bc;
  AxisPolys() {
    const Poly x{{0.0, 1.0}}, s{{0, 0, 0, 10, -15, 6}}, ds{{0, 0, 30, -60, 30}};
    const Poly r = Poly{{1.0}} + (-1.0) * s, xm = x + Poly{{-1.0}};
    const Poly z = 2.0 * s + Poly{{-1.0}};
    const Poly y = r * r * x + s * s * xm;
    const Poly p = (-1.0) * r * x + s * xm;
    const Poly e = x * x + xm * xm;
    const Poly v = (-1.0) * r * x * x + s * xm * xm;
    q = r * r + s * s;
    t = r * r * x * x + s * s * xm * xm;
    s2 = ds * ds;
    b = q + 2.0 * ds * p + s2 * e;
    a = ds * z;
    bc = y + ds * v;
  }
};

template <int N>
double gradient_bound(const Box<N>& box) {
  static const AxisPolys poly;
  struct Axis {
    Iv q, b, t, s2, a, bc;
  };
  std::array<Axis, N> ax;
  for (int k = 0; k < N; ++k) {
    const double lo = box.lo[k], hi = box.hi[k];
    ax[k] = {poly.q.range(lo, hi),  poly.b.range(lo, hi), poly.t.range(lo, hi),
             poly.s2.range(lo, hi), poly.a.range(lo, hi), poly.bc.range(lo, hi)};
  }
  const auto q_except = [&](int e1, int e2, int e3) {
    Iv r = point(1.0);
    for (int m = 0; m < N; ++m) {
      if (m != e1 && m != e2 && m != e3) r = r * ax[m].q;
    }
    return r;
  };
  std::array<std::array<Iv, N>, N> a{};
  for (int j = 0; j < N; ++j) {
    Iv t = point(0.0);
    for (int l = 0; l < N; ++l) {
      if (l != j) t = t + ax[l].t * q_except(j, l, -1);
    }
    a[j][j] = ax[j].b * q_except(j, -1, -1) + 2.0 * ax[j].s2 * t;
  }
  for (int i = 0; i < N; ++i) {
    for (int j = i + 1; j < N; ++j) {
      Iv t = point(0.0);
      for (int l = 0; l < N; ++l) {
        if (l != i && l != j) t = t + ax[l].t * q_except(i, j, l);
      }
      a[i][j] = a[j][i] =
          q_except(i, j, -1) * (ax[i].a * ax[j].bc + ax[j].a * ax[i].bc) + ax[i].a * ax[j].a * t;
    }
  }
  return std::sqrt(static_cast<double>(1 << N) * max_eigenvalue_bound<N>(a));
}

// Simplex noise on the simplex u ≥ v (≥ w) of the skewed unit cell (the others are its images
// under axis permutations), summing over every vertex in reach. Per vertex M_k = t⁴I − 8t³ d dᵀ
// with t = ½ − |d|²; weighted Cauchy–Schwarz with μ_k = t_k³: |∇n| ≤ √(Σμ_k · λmax(Σ M_k²/μ_k)) and
// M_k²/μ_k = t⁵ I + 8t³(10|d|² − 1) d dᵀ, functions of ρ = |d|².
template <int N>
struct SimplexGeometry {
  static constexpr double unskew = N == 2 ? 0.21132486540518711775 : 1.0 / 6.0;
  // Unskewed offsets from every lattice vertex in reach of the box. Candidates are v ∈ {−1..2}^N
  // (skewed coordinates) whose distance to the whole unit cell can be below √½; kernels out of
  // reach get ρ ≥ ½ and drop out, so the certificate does not rely on the support argument of
  // docs/noise.md.
  static std::array<Iv, N> offset(const Box<N>& box, const std::array<double, N>& v) {
    std::array<Iv, N> dv{};
    for (int k = 0; k < N; ++k) {
      Iv sum = point(0.0);
      for (int m = 0; m < N; ++m) {
        sum = sum + ((m == k ? 1.0 : 0.0) - unskew) *
                        (Iv{box.lo[m], box.hi[m]} - point(v[static_cast<std::size_t>(m)]));
      }
      dv[static_cast<std::size_t>(k)] = sum;
    }
    return dv;
  }
  static Iv squared_length(const std::array<Iv, N>& d) {
    Iv r = point(0.0);
    for (const Iv& c : d) r = r + square(c);
    return r;
  }
  static const std::vector<std::array<double, N>>& candidates() {
    static const std::vector<std::array<double, N>> list = [] {
      std::vector<std::array<double, N>> out;
      Box<N> cell;
      cell.lo.fill(0.0);
      cell.hi.fill(1.0);
      int count = 1;
      for (int k = 0; k < N; ++k) count *= 4;
      for (int code = 0; code < count; ++code) {
        std::array<double, N> v{};
        for (int k = 0, c = code; k < N; ++k, c /= 4) v[static_cast<std::size_t>(k)] = c % 4 - 1;
        if (squared_length(offset(cell, v)).lo < 0.5) out.push_back(v);
      }
      return out;
    }();
    return list;
  }
  static std::vector<std::array<Iv, N>> offsets(const Box<N>& box) {
    std::vector<std::array<Iv, N>> d;
    for (const auto& v : candidates()) d.push_back(offset(box, v));
    return d;
  }
  static bool inside(const Box<N>& b) {
    // Some point of the box has u ≥ v (≥ w).
    if constexpr (N == 2) {
      return b.hi[0] >= b.lo[1];
    } else {
      return std::max(b.lo[1], b.lo[2]) <= std::min(b.hi[1], b.hi[0]) && b.hi[0] >= b.lo[2];
    }
  }
};

// Range of f(ρ) over ρ ∈ r ∩ [0, ½], and 0 if r reaches past ½ (where t₊ = 0).
Iv kernel_range(const Poly& f, Iv r) {
  const double lo = std::max(r.lo, 0.0), hi = std::min(r.hi, 0.5);
  if (lo >= 0.5) return point(0.0);
  Iv out = f.range(lo, hi);
  if (r.hi > 0.5) out = {std::min(out.lo, 0.0), std::max(out.hi, 0.0)};
  return out;
}

template <int N>
double simplex_bound(const Box<N>& box) {
  static const Poly t{{0.5, -1.0}}, rho{{0.0, 1.0}};
  static const Poly tau = power(t, 5), alpha = 8.0 * power(t, 3) * (10.0 * rho + Poly{{-1.0}}),
                    mu = power(t, 3);
  const auto d = SimplexGeometry<N>::offsets(box);
  std::array<std::array<Iv, N>, N> a{};
  double mu_sum = 0.0;
  for (const auto& dv : d) {
    Iv r = point(0.0);
    for (const Iv& c : dv) r = r + square(c);
    const Iv ta = kernel_range(tau, r), al = kernel_range(alpha, r);
    mu_sum += std::max(0.0, kernel_range(mu, r).hi);
    for (int i = 0; i < N; ++i) {
      for (int j = 0; j < N; ++j) {
        a[i][j] = a[i][j] + (i == j ? ta : point(0.0)) +
                  al * (i == j ? square(dv[static_cast<std::size_t>(i)])
                               : dv[static_cast<std::size_t>(i)] * dv[static_cast<std::size_t>(j)]);
      }
    }
  }
  return std::sqrt(mu_sum * max_eigenvalue_bound<N>(a));
}

// Σ_k (½ − |d_k|²)₊⁴ |d_k|: the largest simplex value with unit gradients.
template <int N>
double simplex_value_bound(const Box<N>& box) {
  // φ(ρ) = (½ − ρ)⁴ √ρ increases on [0, 1/18] and decreases on [1/18, ½].
  const auto phi = [](double r) { return std::pow(0.5 - r, 4) * std::sqrt(r); };
  double total = 0.0;
  for (const auto& dv : SimplexGeometry<N>::offsets(box)) {
    Iv r = point(0.0);
    for (const Iv& c : dv) r = r + square(c);
    const double lo = std::max(r.lo, 0.0), hi = std::min(r.hi, 0.5);
    if (lo >= 0.5) continue;
    total += (lo <= 1.0 / 18.0 && hi >= 1.0 / 18.0) ? phi(1.0 / 18.0) : std::max(phi(lo), phi(hi));
  }
  return total;
}

// Mirrors of the value scales in noise.cpp (the golden values pin that they are the ones used).
constexpr double kSimplexScale2 = 99.0;
constexpr double kSimplexScale3 = 107.5;
constexpr double kGradientScale2 = 1.41421354;
constexpr double kGradientScale3 = 1.15470052;

TEST(NoiseLipschitz, GradientBoundsAreCertifiedByIntervalBranchAndBound) {
  // Symmetric under x_k → 1 − x_k and axis permutations: certify [0, ½]^N with sorted coordinates.
  const auto sorted2 = [](const Box<2>& b) { return b.lo[0] <= b.hi[1]; };
  const auto sorted3 = [](const Box<3>& b) {
    return b.lo[0] <= b.hi[1] && b.lo[1] <= b.hi[2] && b.lo[0] <= b.hi[2];
  };
  const Certificate c2 = certify<2>({{0, 0}, {0.5, 0.5}}, gradient_bound<2>, sorted2,
                                    lipschitz(Basis::gradient, 2) / kGradientScale2, 1'000'000);
  EXPECT_TRUE(c2.proven) << "sampled " << c2.sampled_max * kGradientScale2;
  const Certificate c3 = certify<3>({{0, 0, 0}, {0.5, 0.5, 0.5}}, gradient_bound<3>, sorted3,
                                    lipschitz(Basis::gradient, 3) / kGradientScale3, 2'000'000);
  EXPECT_TRUE(c3.proven) << "sampled " << c3.sampled_max * kGradientScale3;
  // Not loose: the bound function itself reaches within 5% of the constant.
  EXPECT_GT(c2.sampled_max * kGradientScale2, 0.95 * lipschitz(Basis::gradient, 2));
  EXPECT_GT(c3.sampled_max * kGradientScale3, 0.95 * lipschitz(Basis::gradient, 3));
}

TEST(NoiseLipschitz, SimplexBoundsAreCertifiedByIntervalBranchAndBound) {
  const Certificate c2 = certify<2>({{0, 0}, {1, 1}}, simplex_bound<2>, SimplexGeometry<2>::inside,
                                    lipschitz(Basis::simplex, 2) / kSimplexScale2, 2'000'000);
  EXPECT_TRUE(c2.proven) << "sampled " << c2.sampled_max * kSimplexScale2;
  const Certificate c3 =
      certify<3>({{0, 0, 0}, {1, 1, 1}}, simplex_bound<3>, SimplexGeometry<3>::inside,
                 lipschitz(Basis::simplex, 3) / kSimplexScale3, 4'000'000);
  EXPECT_TRUE(c3.proven) << "sampled " << c3.sampled_max * kSimplexScale3;
  EXPECT_GT(c2.sampled_max * kSimplexScale2, 0.95 * lipschitz(Basis::simplex, 2));
  EXPECT_GT(c3.sampled_max * kSimplexScale3, 0.95 * lipschitz(Basis::simplex, 3));
}

TEST(NoiseRange, SimplexScalesAreCertifiedByIntervalBranchAndBound) {
  // scale · max Σ t⁴|d| ≤ 1, so |simplex| ≤ 1 with unit gradients.
  const Certificate c2 = certify<2>({{0, 0}, {1, 1}}, simplex_value_bound<2>,
                                    SimplexGeometry<2>::inside, 1.0 / kSimplexScale2, 2'000'000);
  EXPECT_TRUE(c2.proven) << "sampled " << c2.sampled_max * kSimplexScale2;
  const Certificate c3 = certify<3>({{0, 0, 0}, {1, 1, 1}}, simplex_value_bound<3>,
                                    SimplexGeometry<3>::inside, 1.0 / kSimplexScale3, 4'000'000);
  EXPECT_TRUE(c3.proven) << "sampled " << c3.sampled_max * kSimplexScale3;
  // The known maximum in 2D: two vertices at the midpoint of an edge, 2/(81√6).
  EXPECT_NEAR(c2.sampled_max, 2.0 / (81.0 * std::sqrt(6.0)), 1e-6);
  EXPECT_GT(c3.sampled_max * kSimplexScale3, 0.99);
}

// ------------------------------------------------------------------------------------------------
// Golden values: any change of the numbers (hash use, gradient sets, offsets, scales, fractal
// formulas) fails here. Regenerate deliberately, never to make a test pass.

struct Golden2 {
  float x, y;
  std::uint32_t seed;
  float value, dx, dy;
};
struct Golden3 {
  float x, y, z;
  std::uint32_t seed;
  float value, dx, dy, dz;
};

void expect_bits(float actual, float expected, const std::string& what) {
  EXPECT_EQ(bits(actual), bits(expected))
      << what << ": got " << std::hexfloat << actual << " expected " << expected;
}

// GOLDEN_BASES_BEGIN
TEST(NoiseBasis, GoldenValuesArePinned) {
  static const Golden2 kgradient2[] = {
      {0x1p-2, 0x1.8p-1, 0u, -0x1.3890e8p-5, 0x1.103c9ep-2, 0x1.5d0ec8p+0},
      {-0x1.d9999ap+1, 0x1.833334p+3, 1u, 0x1.a20982p-2, 0x1.13de42p+0, -0x1.093824p+0},
      {0x1.34ap+10, -0x1.edap+9, 2u, -0x1.90116ep-3, -0x1.3624c6p-11, -0x1.89c37ep-1},
      {-0x1.e847fp+19, 0x1.e847f8p+19, 3u, 0x1.2698eap-3, -0x1.5a9908p+0, 0x1.0f9426p-1},
      {0x0p+0, 0x0p+0, 4u, -0x1.398656p-3, -0x1.174df4p-3, 0x1.cc2b94p-1},
      {0x1.107ae2p+4, -0x1.0624dep-10, 5u, -0x1.219164p-2, 0x1.1dc5f4p-1, -0x1.e83ea6p-1},
      {-0x1p-1, -0x1p-1, 6u, 0x1.07b8e6p-2, 0x1.53a6bcp-1, -0x1.8c3accp-1},
      {0x1.8ff5c2p+6, 0x1.535c28p+5, 7u, -0x1.4b944cp-2, -0x1.2a3742p+0, 0x1.571024p-3},
      {-0x1.f44p+7, 0x1.cp+1, 8u, 0x1.7910dep-3, -0x1.4cfdc4p-1, -0x1.0703fcp-3},
      {0x1.e848p+18, -0x1.f147aep+2, 4294967295u, -0x1.9bc89p-3, -0x1.2dba26p-1, 0x1.5cbd22p+0},
  };
  for (const Golden2& g : kgradient2) {
    const Sample2 s = gradient2(g.x, g.y, g.seed);
    const std::string at = "gradient2 at " + std::to_string(g.x) + "," + std::to_string(g.y);
    expect_bits(s.value, g.value, at);
    expect_bits(s.dx, g.dx, at);
    expect_bits(s.dy, g.dy, at);
  }
  static const Golden2 ksimplex2[] = {
      {0x1p-2, 0x1.8p-1, 0u, 0x1.2148c8p-1, 0x1.86d464p+0, -0x1.4ee72cp+1},
      {-0x1.d9999ap+1, 0x1.833334p+3, 1u, 0x1.557eb8p-3, -0x1.9bb432p+1, -0x1.0bf88p+1},
      {0x1.34ap+10, -0x1.edap+9, 2u, 0x1.0fa7cep-3, 0x1.f3e986p-1, -0x1.4de268p+1},
      {-0x1.e847fp+19, 0x1.e847f8p+19, 3u, 0x1.17c704p-6, 0x1.887998p+1, -0x1.54184cp-1},
      {0x0p+0, 0x0p+0, 4u, -0x1.c2bfbep-2, -0x1.727b4p-2, 0x1.3b815p+2},
      {0x1.107ae2p+4, -0x1.0624dep-10, 5u, 0x1.2b5f9ep-4, 0x1.60632ap+1, -0x1.3b85e8p+1},
      {-0x1p-1, -0x1p-1, 6u, 0x1.047b8ep-1, 0x1.ff599ap+1, 0x1.84a7ap+0},
      {0x1.8ff5c2p+6, 0x1.535c28p+5, 7u, 0x1.0daad8p-3, 0x1.169ed4p+2, -0x1.374f48p+1},
      {-0x1.f44p+7, 0x1.cp+1, 8u, 0x1.9819fep-1, -0x1.26ab62p+0, 0x1.0d819p+0},
      {0x1.e848p+18, -0x1.f147aep+2, 4294967295u, 0x1.73bd2ep-4, 0x1.502fcap-1, 0x1.4301a8p+1},
  };
  for (const Golden2& g : ksimplex2) {
    const Sample2 s = simplex2(g.x, g.y, g.seed);
    const std::string at = "simplex2 at " + std::to_string(g.x) + "," + std::to_string(g.y);
    expect_bits(s.value, g.value, at);
    expect_bits(s.dx, g.dx, at);
    expect_bits(s.dy, g.dy, at);
  }
  static const Golden3 kgradient3[] = {
      {0x1p-2, 0x1.8p-1, 0x1p-1, 0u, -0x1.953aep-5, -0x1.a20f34p-1, 0x1.d8e672p-7, -0x1.3829e4p-1},
      {-0x1.d9999ap+1, 0x1.833334p+3, -0x1.08p+3, 1u, -0x1.1da89ep-2, -0x1.ac466ap-2, 0x1.035498p+0,
       -0x1.df52ecp-1},
      {0x1.34ap+10, -0x1.edap+9, 0x1.bcp+5, 2u, -0x1.ecaf32p-3, -0x1.cbc4d8p-4, 0x1.2ebd38p-2,
       0x1.95a1c2p-1},
      {-0x1.e847fp+19, 0x1.e847f8p+19, -0x1.e847e8p+19, 3u, 0x1.0c05f2p-3, -0x1.aac1bp-4,
       -0x1.f9751ap-1, 0x1.440c82p-1},
      {0x0p+0, 0x0p+0, 0x0p+0, 4u, -0x1.07b266p-6, -0x1.dd12bep-2, 0x1.455daap-1, -0x1.69fa52p-1},
      {0x1.107ae2p+4, -0x1.0624dep-10, 0x1p+1, 5u, -0x1.eb8b6ep-4, -0x1.b796bp-8, 0x1.0ffd58p-3,
       0x1.3aa9ap-1},
      {-0x1p-1, -0x1p-1, -0x1p-1, 6u, -0x1.74d0dep-2, -0x1.b46f86p-3, -0x1.8aaefcp-2,
       0x1.501b7cp-3},
      {0x1.8ff5c2p+6, 0x1.535c28p+5, -0x1.028f5cp+0, 7u, -0x1.caa344p-4, 0x1.30f5f4p-1,
       0x1.ae1e9ep-2, 0x1.47f904p+0},
      {-0x1.f44p+7, 0x1.cp+1, 0x1p+6, 8u, 0x1.667c36p-2, 0x1.aaeceep-3, -0x1.b6b76cp-3,
       0x1.95e4e6p-5},
      {0x1.e848p+18, -0x1.f147aep+2, 0x1.fp+4, 4294967295u, -0x1.c1eb3p-3, 0x1.0c3b28p-3,
       0x1.bfd92ap-1, 0x1.54b47ap-4},
  };
  for (const Golden3& g : kgradient3) {
    const Sample3 s = gradient3(g.x, g.y, g.z, g.seed);
    const std::string at = "gradient3 at " + std::to_string(g.x);
    expect_bits(s.value, g.value, at);
    expect_bits(s.dx, g.dx, at);
    expect_bits(s.dy, g.dy, at);
    expect_bits(s.dz, g.dz, at);
  }
  static const Golden3 ksimplex3[] = {
      {0x1p-2, 0x1.8p-1, 0x1p-1, 0u, -0x1.73efbap-3, -0x1.b16076p+0, -0x1.167f04p-3, 0x1.07596cp+1},
      {-0x1.d9999ap+1, 0x1.833334p+3, -0x1.08p+3, 1u, 0x1.0aed32p-3, 0x1.006566p+0, 0x1.e7110ap+0,
       0x1.d9b37ap-1},
      {0x1.34ap+10, -0x1.edap+9, 0x1.bcp+5, 2u, -0x1.760ff2p-1, 0x1.2abefap-2, -0x1.274f44p+0,
       -0x1.0b25bcp+0},
      {-0x1.e847fp+19, 0x1.e847f8p+19, -0x1.e847e8p+19, 3u, -0x1.16aacep-5, 0x1.31405ap+1,
       -0x1.23c3bep-1, 0x1.c1833cp-4},
      {0x0p+0, 0x0p+0, 0x0p+0, 4u, 0x1.b26924p-6, -0x1.0669dap+2, 0x1.efe384p+0, 0x1.4917bcp-1},
      {0x1.107ae2p+4, -0x1.0624dep-10, 0x1p+1, 5u, 0x1.c66418p-1, -0x1.a66cd4p-1, -0x1.9f2a2ap+0,
       -0x1.ca6d4p-3},
      {-0x1p-1, -0x1p-1, -0x1p-1, 6u, -0x1.bf5a54p-2, -0x1.e75012p-1, -0x1.3261d2p+1,
       0x1.d4ab3cp-2},
      {0x1.8ff5c2p+6, 0x1.535c28p+5, -0x1.028f5cp+0, 7u, 0x1.1670d8p-1, 0x1.7937b4p-1,
       0x1.523a66p-3, -0x1.509976p+2},
      {-0x1.f44p+7, 0x1.cp+1, 0x1p+6, 8u, 0x1.b6c5ep-2, -0x1.749cb2p-1, 0x1.3c6522p+1,
       0x1.03c626p+0},
      {0x1.e848p+18, -0x1.f147aep+2, 0x1.fp+4, 4294967295u, 0x1.c709bp-1, -0x1.a713e6p+0,
       -0x1.40d2d4p-2, 0x1.8fe456p-1},
  };
  for (const Golden3& g : ksimplex3) {
    const Sample3 s = simplex3(g.x, g.y, g.z, g.seed);
    const std::string at = "simplex3 at " + std::to_string(g.x);
    expect_bits(s.value, g.value, at);
    expect_bits(s.dx, g.dx, at);
    expect_bits(s.dy, g.dy, at);
    expect_bits(s.dz, g.dz, at);
  }
}
// GOLDEN_BASES_END

// ------------------------------------------------------------------------------------------------
// Octave weights and LoD.

TEST(FractalOctaves, OctaveWeightIsOneZeroAndAC1RampBetween) {
  EXPECT_EQ(octave_weight(0, 3.0f), 1.0f);
  EXPECT_EQ(octave_weight(2, 3.0f), 1.0f);
  EXPECT_EQ(octave_weight(3, 3.0f), 0.0f);
  EXPECT_EQ(octave_weight(5, 3.0f), 0.0f);
  EXPECT_EQ(octave_weight(0, 0.0f), 0.0f);
  EXPECT_EQ(octave_weight(0, std::numeric_limits<float>::quiet_NaN()), 0.0f);
  // 1 − (1 − t²)³ at t = ½.
  EXPECT_FLOAT_EQ(octave_weight(3, 3.5f), 1.0f - 0.75f * 0.75f * 0.75f);
  // Continuous and with zero slope at both ends of the ramp.
  for (int i = 0; i < 5; ++i) {
    const auto fi = static_cast<float>(i);
    EXPECT_NEAR(octave_weight(i, fi + 1e-3f), 0.0f, 1e-5f);
    EXPECT_NEAR(octave_weight(i, fi + 1.0f - 1e-3f), 1.0f, 1e-5f);
  }
  float previous = 0.0f;
  for (int k = 0; k <= 1000; ++k) {
    const float w = octave_weight(2, 2.0f + static_cast<float>(k) / 1000.0f);
    EXPECT_GE(w, previous);
    EXPECT_LE(w - previous, 0.0025f);  // max slope 6t(1 − t²)² ≈ 2.3 per octave
    previous = w;
  }
}

TEST(FractalOctaves, VisibleOctavesFollowsTheNyquistLimit) {
  FractalParams p = test_params(Fractal::fbm, Basis::gradient);
  p.octaves = 10;
  p.frequency = 0.01f;  // 100 m wavelength at octave 0
  EXPECT_EQ(visible_octaves(p, 0.0f), 10.0f);
  EXPECT_EQ(visible_octaves(p, -1.0f), 10.0f);
  // Octave i has wavelength 100/2^i m, visible while ≥ 2·spacing: at spacing 50/2^k exactly
  // k + 1 octaves.
  for (int k = 0; k < 8; ++k) {
    const float spacing = 50.0f / static_cast<float>(1 << k);
    EXPECT_NEAR(visible_octaves(p, spacing), static_cast<float>(k + 1), 1e-5f) << k;
  }
  EXPECT_EQ(visible_octaves(p, 1000.0f), 0.0f);
  EXPECT_EQ(visible_octaves(p, 1e-6f), 10.0f);
  // Continuous and decreasing in the spacing.
  float previous = 11.0f;
  for (float s = 0.01f; s < 100.0f; s *= 1.01f) {
    const float n = visible_octaves(p, s);
    EXPECT_LE(n, previous);
    previous = n;
  }
}

TEST(FractalOctaves, ValueIsContinuousInTheOctaveCount) {
  std::mt19937 rng(31);
  for (const Fractal kind : kKinds) {
    for (const Basis basis : kBases) {
      const FractalParams p = test_params(kind, basis);
      for (int i = 0; i < 200; ++i) {
        const Vec2 q = in_disc(rng, 40.0f);
        for (int k = 1; k <= 6; ++k) {
          const auto fk = static_cast<float>(k);
          const Sample2 below = fractal2(p, q, fk - 1e-4f), above = fractal2(p, q, fk + 1e-4f);
          ASSERT_NEAR(below.value, above.value, 1e-4f) << label(p) << " octaves " << k;
        }
        // Integer counts equal the limit from both sides.
        const Sample2 at = fractal2(p, q, 3.0f), near = fractal2(p, q, 3.0f + 1e-6f);
        ASSERT_NEAR(at.value, near.value, 1e-5f) << label(p);
      }
    }
  }
}

// ------------------------------------------------------------------------------------------------
// Fractals: gradients, bounds, batch == scalar.

// Analytic gradient vs central differences. At creases (ridged |η| = 0, clamped weights) the
// one-sided slopes differ; a mismatch is accepted only where the analytic gradient itself jumps
// across the difference stencil, and such points must be rare.
TEST(Fractal, GradientMatchesCentralDifferencesForEveryKindAndBasis) {
  std::mt19937 rng(41);
  const float h = 1.0f / 2048.0f;
  const float oct = 5.5f;
  for (const Fractal kind : kKinds) {
    for (const Basis basis : kBases) {
      const FractalParams p = test_params(kind, basis);
      int creases = 0;
      const int samples = 4000;
      for (int i = 0; i < samples; ++i) {
        // The warped sum's slope grows with |p| (docs/noise.md): sample it closer to the origin.
        const Vec2 q = in_disc(rng, kind == Fractal::warped ? 4.0f : 30.0f);
        const Sample2 s = fractal2(p, q, oct);
        for (const Vec2 e : {Vec2{1, 0}, Vec2{0, 1}}) {
          const Sample2 plus = fractal2(p, q + h * e, oct), minus = fractal2(p, q - h * e, oct);
          const double fd = (double{plus.value} - minus.value) / (2.0 * h);
          const double analytic = e.x * s.dx + e.y * s.dy;
          // Truncation ~h², and float rounding of the two values divided by 2h.
          const double tol =
              3e-3 * (1.0 + std::abs(fd)) + 32.0 * 6e-8 * (1.0 + std::abs(s.value)) / h;
          if (std::abs(analytic - fd) <= tol) continue;
          const double jump =
              std::abs((e.x * plus.dx + e.y * plus.dy) - (e.x * minus.dx + e.y * minus.dy));
          ASSERT_GT(jump, 0.25 * std::abs(analytic - fd))
              << label(p) << " at " << q.x << "," << q.y << ": " << analytic << " vs " << fd;
          ++creases;
        }
      }
      EXPECT_LT(creases, samples / 20) << label(p);
    }
  }
}

TEST(Fractal, Gradient3MatchesCentralDifferences) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(-30.0f, 30.0f);
  const float h = 1.0f / 2048.0f;
  for (const Fractal kind : {Fractal::fbm, Fractal::ridged, Fractal::hybrid}) {
    for (const Basis basis : kBases) {
      const FractalParams p = test_params(kind, basis);
      int creases = 0;
      for (int i = 0; i < 2000; ++i) {
        const float x = u(rng), y = u(rng), z = u(rng);
        const Sample3 s = fractal3(p, x, y, z, 5.5f);
        for (int k = 0; k < 3; ++k) {
          const float ex = k == 0 ? h : 0.0f, ey = k == 1 ? h : 0.0f, ez = k == 2 ? h : 0.0f;
          const Sample3 plus = fractal3(p, x + ex, y + ey, z + ez, 5.5f);
          const Sample3 minus = fractal3(p, x - ex, y - ey, z - ez, 5.5f);
          const double fd = (double{plus.value} - minus.value) / (2.0 * h);
          const auto along = [k](const Sample3& t) { return k == 0 ? t.dx : k == 1 ? t.dy : t.dz; };
          const double tol =
              3e-3 * (1.0 + std::abs(fd)) + 32.0 * 6e-8 * (1.0 + std::abs(s.value)) / h;
          if (std::abs(along(s) - fd) <= tol) continue;
          ASSERT_GT(std::abs(double{along(plus)} - along(minus)), 0.25 * std::abs(along(s) - fd))
              << label(p) << " axis " << k;
          ++creases;
        }
      }
      EXPECT_LT(creases, 200) << label(p);  // of 6000 checks
    }
  }
}

TEST(Fractal, ValuesStayWithinFractalRange) {
  std::mt19937 rng(43);
  for (const Fractal kind : kKinds) {
    for (const Basis basis : kBases) {
      for (const float oct : {1.0f, 3.3f, 6.0f}) {
        FractalParams p = test_params(kind, basis);
        const Interval r = fractal_range(p, oct);
        ASSERT_FALSE(r.empty());
        float lo = 1e30f, hi = -1e30f;
        for (int i = 0; i < 20000; ++i) {
          const float v = fractal2(p, in_disc(rng, 200.0f), oct).value;
          ASSERT_TRUE(r.contains(v))
              << label(p) << " " << v << " outside [" << r.lo << ", " << r.hi << "]";
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
        // Sanity: the samples use a good part of the interval.
        EXPECT_GT(hi - lo, 0.2f * r.width()) << label(p) << " octaves " << oct;
        std::vector<float> xs(512), ys(512), zs(512), v(512), dx(512), dy(512), dz(512);
        for (std::size_t i = 0; i < xs.size(); ++i) {
          const Vec2 q = in_disc(rng, 100.0f);
          xs[i] = q.x;
          ys[i] = q.y;
          zs[i] = q.x - q.y;
        }
        fractal3(p, xs.data(), ys.data(), zs.data(), xs.size(), oct, v.data(), dx.data(), dy.data(),
                 dz.data());
        for (const float value : v) ASSERT_TRUE(r.contains(value)) << label(p) << " 3D";
      }
    }
  }
}

TEST(Fractal, RangeAndLipschitzOfDegenerateParameters) {
  FractalParams p = test_params(Fractal::fbm, Basis::gradient);
  const Interval none = fractal_range(p, 0.0f);
  EXPECT_EQ(none.lo, 0.0f);
  EXPECT_EQ(none.hi, 0.0f);
  EXPECT_EQ(fractal_lipschitz(p, 0.0f, 10.0f), 0.0f);
  EXPECT_EQ(fractal2(p, Vec2{1.5f, 2.5f}, 0.0f).value, 0.0f);
  // fBm range is Σ a_i exactly (a_i = 2^{−0.8 i}).
  const Interval two = fractal_range(p, 2.0f);
  const double sum = 1.0 + std::pow(2.0, -0.8);
  EXPECT_NEAR(two.hi, sum, 1e-5);
  EXPECT_NEAR(two.lo, -sum, 1e-5);
  // Octave count above the parameter's maximum is clamped to it.
  EXPECT_EQ(fractal2(p, Vec2{1.5f, 2.5f}, 100.0f).value, fractal2(p, Vec2{1.5f, 2.5f}, 6.0f).value);
}

TEST(Fractal, GradientNeverExceedsFractalLipschitzBound) {
  std::mt19937 rng(44);
  for (const Fractal kind : kKinds) {
    for (const Basis basis : kBases) {
      for (const float oct : {1.0f, 2.5f, 6.0f}) {
        for (const float radius : {10.0f, 60.0f}) {
          const FractalParams p = test_params(kind, basis);
          const float bound = fractal_lipschitz(p, oct, radius);
          ASSERT_TRUE(std::isfinite(bound) && bound > 0.0f);
          double worst = 0.0;
          const std::size_t n = 20000;
          std::vector<float> xs(n), ys(n), v(n), dx(n), dy(n);
          for (std::size_t i = 0; i < n; ++i) {
            const Vec2 q = in_disc(rng, radius);
            xs[i] = q.x;
            ys[i] = q.y;
          }
          fractal2(p, xs.data(), ys.data(), n, oct, v.data(), dx.data(), dy.data());
          for (std::size_t i = 0; i < n; ++i) {
            const double g = std::hypot(double{dx[i]}, double{dy[i]});
            ASSERT_LE(g, bound) << label(p) << " octaves " << oct << " radius " << radius;
            worst = std::max(worst, g);
          }
          // The fBm bound adds per-octave maxima; the sampled slope gets within a factor ~4.
          if (kind == Fractal::fbm) {
            EXPECT_GT(worst, 0.2 * bound) << label(p);
          }
          // Differences over random pairs in the disc, near and far.
          for (int i = 0; i < 5000; ++i) {
            const Vec2 a = in_disc(rng, radius);
            const float reach = i % 2 == 0 ? 0.05f : radius;
            Vec2 b = a + in_disc(rng, reach);
            if (length(b) > radius) b = a;
            const double d = std::hypot(double{a.x} - b.x, double{a.y} - b.y);
            const double diff =
                std::abs(double{fractal2(p, a, oct).value} - fractal2(p, b, oct).value);
            ASSERT_LE(diff, bound * d + 1e-5) << label(p);
          }
        }
      }
    }
  }
}

TEST(Fractal, Gradient3NeverExceedsFractal3LipschitzBound) {
  std::mt19937 rng(45);
  std::uniform_real_distribution<float> u(-80.0f, 80.0f);
  for (const Fractal kind : kKinds) {
    for (const Basis basis : kBases) {
      const FractalParams p = test_params(kind, basis);
      const float bound = fractal3_lipschitz(p, 6.0f);
      const std::size_t n = 20000;
      std::vector<float> xs(n), ys(n), zs(n), v(n), dx(n), dy(n), dz(n);
      for (std::size_t i = 0; i < n; ++i) {
        xs[i] = u(rng);
        ys[i] = u(rng);
        zs[i] = u(rng);
      }
      fractal3(p, xs.data(), ys.data(), zs.data(), n, 6.0f, v.data(), dx.data(), dy.data(),
               dz.data());
      for (std::size_t i = 0; i < n; ++i) {
        const double g =
            std::sqrt(double{dx[i]} * dx[i] + double{dy[i]} * dy[i] + double{dz[i]} * dz[i]);
        ASSERT_LE(g, bound) << label(p);
      }
    }
  }
}

TEST(Fractal, WarpedBoundGrowsWithRadiusOnlyWhenRotating) {
  FractalParams p = test_params(Fractal::warped, Basis::gradient);
  EXPECT_GT(fractal_lipschitz(p, 6.0f, 100.0f), fractal_lipschitz(p, 6.0f, 10.0f));
  p.warp_c1 = 0.0f;
  EXPECT_EQ(fractal_lipschitz(p, 6.0f, 100.0f), fractal_lipschitz(p, 6.0f, 10.0f));
  // No warp at all: the warped sum is the fBm sum, and so are its bounds.
  p.warp_c2 = 0.0f;
  p.warp_c3 = {0.0f, 0.0f};
  FractalParams f = p;
  f.kind = Fractal::fbm;
  // (up to the 1e-4 allowance for the polynomial rotation's norm)
  EXPECT_GE(fractal_lipschitz(p, 6.0f, 100.0f), fractal_lipschitz(f, 6.0f, 100.0f));
  EXPECT_LE(fractal_lipschitz(p, 6.0f, 100.0f), 1.0002f * fractal_lipschitz(f, 6.0f, 100.0f));
  std::mt19937 rng(46);
  for (int i = 0; i < 1000; ++i) {
    const Vec2 q = in_disc(rng, 50.0f);
    const Sample2 a = fractal2(p, q, 5.5f), b = fractal2(f, q, 5.5f);
    EXPECT_EQ(bits(a.value), bits(b.value));
    EXPECT_NEAR(a.dx, b.dx, 1e-5f * (1.0f + std::abs(b.dx)));
    EXPECT_NEAR(a.dy, b.dy, 1e-5f * (1.0f + std::abs(b.dy)));
  }
}

TEST(Fractal, BatchEqualsScalarBitForBit) {
  // The batch path runs 16- or 8-lane vectors where the CPU has AVX-512 or AVX2 (gradient noise)
  // or loops GCC vectorised; the single-point path is scalar baseline code. Both must give the
  // same bits, for every kind, basis and a partial last vector or chunk.
  std::mt19937 rng(47);
  const std::size_t n = 1000;
  std::vector<float> xs(n), ys(n), zs(n), v(n), dx(n), dy(n), dz(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 q = in_disc(rng, 500.0f);
    xs[i] = q.x;
    ys[i] = q.y;
    zs[i] = 0.5f * q.x - q.y;
  }
  xs[0] = -1.0e6f;  // far and negative coordinates, the clamp, and exact zero
  ys[0] = 1.0e6f;
  xs[1] = 3.0e9f;
  xs[2] = 0.0f;
  ys[2] = -0.0f;
  for (const Fractal kind : kKinds) {
    for (const Basis basis : kBases) {
      for (const float oct : {1.0f, 4.37f, 6.0f}) {
        const FractalParams p = test_params(kind, basis, 1234);
        fractal2(p, xs.data(), ys.data(), n, oct, v.data(), dx.data(), dy.data());
        for (std::size_t i = 0; i < n; ++i) {
          const Sample2 s = fractal2(p, Vec2{xs[i], ys[i]}, oct);
          ASSERT_EQ(bits(v[i]), bits(s.value)) << label(p) << " point " << i;
          ASSERT_EQ(bits(dx[i]), bits(s.dx)) << label(p) << " point " << i;
          ASSERT_EQ(bits(dy[i]), bits(s.dy)) << label(p) << " point " << i;
        }
        fractal3(p, xs.data(), ys.data(), zs.data(), n, oct, v.data(), dx.data(), dy.data(),
                 dz.data());
        for (std::size_t i = 0; i < n; ++i) {
          const Sample3 s = fractal3(p, xs[i], ys[i], zs[i], oct);
          ASSERT_EQ(bits(v[i]), bits(s.value)) << label(p) << " 3D point " << i;
          ASSERT_EQ(bits(dx[i]), bits(s.dx)) << label(p) << " 3D point " << i;
          ASSERT_EQ(bits(dy[i]), bits(s.dy)) << label(p) << " 3D point " << i;
          ASSERT_EQ(bits(dz[i]), bits(s.dz)) << label(p) << " 3D point " << i;
        }
      }
    }
  }
  // Sizes around the vector lengths and the chunk length, and the empty call.
  for (const Basis basis : kBases) {
    for (const std::size_t m : {0u, 1u, 7u, 8u, 9u, 15u, 16u, 17u, 63u, 127u, 128u, 129u, 300u}) {
      const FractalParams p = test_params(Fractal::ridged, basis);
      std::vector<float> w(m + 1, -7.0f), wx(m + 1, -7.0f), wy(m + 1, -7.0f);
      fractal2(p, xs.data(), ys.data(), m, 6.0f, w.data(), wx.data(), wy.data());
      for (std::size_t i = 0; i < m; ++i) {
        ASSERT_EQ(bits(w[i]), bits(fractal2(p, Vec2{xs[i], ys[i]}, 6.0f).value)) << m;
      }
      EXPECT_EQ(w[m], -7.0f) << "wrote past the end for n = " << m;
      EXPECT_EQ(wx[m], -7.0f) << "wrote past the end for n = " << m;
      EXPECT_EQ(wy[m], -7.0f) << "wrote past the end for n = " << m;
    }
  }
}

TEST(Fractal, AtSpacingEqualsTheVisibleOctavesBitForBit) {
  // fractal2_at_spacing caches plans per (parameters, spacing): interleave more fractals than the
  // cache holds, in several rounds, so that hits, misses and evictions all occur.
  std::mt19937 rng(61);
  const std::size_t n = 40;
  std::vector<float> xs(n), ys(n), v(n), dx(n), dy(n), w(n), wx(n), wy(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 q = in_disc(rng, 300.0f);
    xs[i] = q.x;
    ys[i] = q.y;
  }
  for (int round = 0; round < 3; ++round) {
    for (std::uint32_t seed = 0; seed < 400; seed += 1 + static_cast<std::uint32_t>(round)) {
      const FractalParams p = test_params(kKinds[seed % std::size(kKinds)],
                                          kBases[(seed / 4) % std::size(kBases)], seed);
      const float spacing = std::array{0.0f, 0.7f, 3.0f, 25.0f}[seed % 4];
      fractal2_at_spacing(p, spacing, xs.data(), ys.data(), n, v.data(), dx.data(), dy.data());
      fractal2(p, xs.data(), ys.data(), n, visible_octaves(p, spacing), w.data(), wx.data(),
               wy.data());
      for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(bits(v[i]), bits(w[i])) << label(p) << " spacing " << spacing;
        ASSERT_EQ(bits(dx[i]), bits(wx[i])) << label(p) << " spacing " << spacing;
        ASSERT_EQ(bits(dy[i]), bits(wy[i])) << label(p) << " spacing " << spacing;
      }
    }
  }
}

TEST(Fractal, Fractal3WarpedIsFbm) {
  FractalParams p = test_params(Fractal::warped, Basis::simplex);
  FractalParams f = p;
  f.kind = Fractal::fbm;
  for (const float x : {-3.5f, 0.25f, 17.0f}) {
    const Sample3 a = fractal3(p, x, 2.0f * x, -x, 6.0f), b = fractal3(f, x, 2.0f * x, -x, 6.0f);
    EXPECT_EQ(bits(a.value), bits(b.value));
    EXPECT_EQ(bits(a.dz), bits(b.dz));
  }
  EXPECT_EQ(fractal3_lipschitz(p, 6.0f), fractal3_lipschitz(f, 6.0f));
}

TEST(Fractal, SeedsGiveDifferentFieldsAndTheSameSeedTheSameField) {
  std::mt19937 rng(48);
  for (const Fractal kind : kKinds) {
    for (const Basis basis : kBases) {
      const FractalParams a = test_params(kind, basis, 1), b = test_params(kind, basis, 2);
      int same = 0;
      for (int i = 0; i < 500; ++i) {
        const Vec2 q = in_disc(rng, 100.0f);
        const Sample2 s1 = fractal2(a, q, 6.0f), s2 = fractal2(a, q, 6.0f);
        EXPECT_EQ(bits(s1.value), bits(s2.value));
        same += s1.value == fractal2(b, q, 6.0f).value;
      }
      EXPECT_LT(same, 5) << label(a);
    }
  }
}

TEST(Fractal, WorksAtNegativeAndLargeCoordinates) {
  for (const Fractal kind : kKinds) {
    for (const Basis basis : kBases) {
      const FractalParams p = test_params(kind, basis);
      const Interval r = fractal_range(p, 6.0f);
      for (const Vec2 q : {Vec2{-1.0e6f, -1.0e6f}, Vec2{1.0e6f, -2.5e5f}, Vec2{-0.5f, -0.25f},
                           Vec2{-4.0e7f, 9.0e8f}}) {
        const Sample2 s = fractal2(p, q, 6.0f);
        EXPECT_TRUE(std::isfinite(s.value)) << label(p);
        EXPECT_TRUE(r.contains(s.value)) << label(p);
        // The warped slope grows like (f·|p|)^octaves (docs/noise.md); callers keep |p| within
        // the radius they pass to fractal_lipschitz, so only the other kinds promise a finite one.
        if (kind != Fractal::warped) {
          EXPECT_TRUE(std::isfinite(s.dx) && std::isfinite(s.dy)) << label(p);
        }
      }
    }
  }
}

// GOLDEN_FRACTALS_BEGIN
struct GoldenFractal {
  Fractal kind;
  Basis basis;
  float x, y;
  float value, dx, dy;
};
struct GoldenFractal3 {
  Fractal kind;
  Basis basis;
  float x, y, z;
  float value, dx, dy, dz;
};

TEST(Fractal, GoldenValuesArePinned) {
  // test_params(kind, basis, 99) at 5.5 octaves.
  static const GoldenFractal k2[] = {
      {Fractal::fbm, Basis::gradient, 0x1.47ae14p-9, 0x1.eb851ep-8, 0x1.ac2438p-3, -0x1.60796ep-3,
       -0x1.467638p-3},
      {Fractal::fbm, Basis::gradient, -0x1.2f1aap-4, 0x1.ef9db2p-3, 0x1.c1864ap-3, -0x1.d14f1cp-3,
       0x1.299534p-4},
      {Fractal::fbm, Basis::gradient, 0x1.2847acp+5, -0x1.d9e146p+4, 0x1.bc547cp-4, 0x1.b3f43p-8,
       -0x1.aaf838p-2},
      {Fractal::fbm, Basis::gradient, -0x1.387ff6p+15, 0x1.387ffap+15, 0x1.9cdf36p-4, 0x1.a7bde4p-4,
       -0x1.5ed276p-2},
      {Fractal::fbm, Basis::gradient, 0x0p+0, 0x0p+0, 0x1.af7486p-3, -0x1.44e42p-3, -0x1.4b7dacp-3},
      {Fractal::fbm, Basis::gradient, 0x1.0594bp+0, -0x1.f75108p-15, 0x1.9a8cf8p-3, -0x1.6f925p-1,
       -0x1.4e5144p-1},
      {Fractal::fbm, Basis::gradient, -0x1.1eb852p-5, -0x1.1eb852p-5, 0x1.c1a644p-3, -0x1.b4f51p-6,
       -0x1.4df0cep-3},
      {Fractal::fbm, Basis::gradient, 0x1.fff2e4p+2, 0x1.b2617ap+1, -0x1.e379e4p-5, 0x1.60f396p-2,
       0x1.c2d94p-8},
      {Fractal::fbm, Basis::gradient, -0x1.682e14p+4, 0x1.428f5cp-2, -0x1.f2a8ecp-3, -0x1.048eccp-2,
       0x1.29ad3ap-2},
      {Fractal::fbm, Basis::gradient, 0x1.86ap+15, -0x1.8dd2fp-1, -0x1.472efcp-2, 0x1.058e58p-2,
       0x1.adec6p-5},
      {Fractal::fbm, Basis::simplex, 0x1.47ae14p-9, 0x1.eb851ep-8, -0x1.69e8cep-1, -0x1.50d79ep-1,
       0x1.5e2c36p-1},
      {Fractal::fbm, Basis::simplex, -0x1.2f1aap-4, 0x1.ef9db2p-3, -0x1.0f5528p-1, -0x1.a53df2p-1,
       -0x1.6712aep-1},
      {Fractal::fbm, Basis::simplex, 0x1.2847acp+5, -0x1.d9e146p+4, -0x1.fe4f18p-1, 0x1.ee58a8p-2,
       -0x1.38a2cp-2},
      {Fractal::fbm, Basis::simplex, -0x1.387ff6p+15, 0x1.387ffap+15, 0x1.0b0f48p-1, 0x1.885858p-3,
       0x1.51d6dap-2},
      {Fractal::fbm, Basis::simplex, 0x0p+0, 0x0p+0, -0x1.6b8784p-1, -0x1.5f4b84p-1, 0x1.377324p-1},
      {Fractal::fbm, Basis::simplex, 0x1.0594bp+0, -0x1.f75108p-15, -0x1.d05724p-1, -0x1.0ac17ep-1,
       -0x1.567684p-5},
      {Fractal::fbm, Basis::simplex, -0x1.1eb852p-5, -0x1.1eb852p-5, -0x1.65d998p-1, -0x1.a67b3ep-1,
       0x1.53f248p-2},
      {Fractal::fbm, Basis::simplex, 0x1.fff2e4p+2, 0x1.b2617ap+1, -0x1.557bdcp-1, 0x1.10278ap-1,
       0x1.06b75p-3},
      {Fractal::fbm, Basis::simplex, -0x1.682e14p+4, 0x1.428f5cp-2, -0x1.17fadp-4, -0x1.9289cep-1,
       -0x1.43d258p-2},
      {Fractal::fbm, Basis::simplex, 0x1.86ap+15, -0x1.8dd2fp-1, 0x1.345376p-1, -0x1.6c429p+0,
       -0x1.e1145cp+0},
      {Fractal::ridged, Basis::gradient, 0x1.47ae14p-9, 0x1.eb851ep-8, 0x1.9e6ab8p+0,
       -0x1.55eee8p-2, 0x1.e6e24p-1},
      {Fractal::ridged, Basis::gradient, -0x1.2f1aap-4, 0x1.ef9db2p-3, 0x1.bd3428p+0,
       -0x1.6b7bb2p-3, 0x1.770cc2p-2},
      {Fractal::ridged, Basis::gradient, 0x1.2847acp+5, -0x1.d9e146p+4, 0x1.2e524ep+0,
       -0x1.62b584p-3, -0x1.4d4374p-2},
      {Fractal::ridged, Basis::gradient, -0x1.387ff6p+15, 0x1.387ffap+15, 0x1.a4f1p+0,
       0x1.9d0e44p-1, -0x1.741dcp-4},
      {Fractal::ridged, Basis::gradient, 0x0p+0, 0x0p+0, 0x1.9cd48ap+0, -0x1.5730b8p-2,
       0x1.d9b138p-1},
      {Fractal::ridged, Basis::gradient, 0x1.0594bp+0, -0x1.f75108p-15, 0x1.7463d4p+0,
       0x1.d9d278p-2, -0x1.0c0624p-1},
      {Fractal::ridged, Basis::gradient, -0x1.1eb852p-5, -0x1.1eb852p-5, 0x1.983476p+0,
       -0x1.94cf9cp-2, 0x1.b0f9fep-1},
      {Fractal::ridged, Basis::gradient, 0x1.fff2e4p+2, 0x1.b2617ap+1, 0x1.2ab4d6p+0, 0x1.eb6f34p-3,
       0x1.12b8a8p-5},
      {Fractal::ridged, Basis::gradient, -0x1.682e14p+4, 0x1.428f5cp-2, 0x1.7bf0b6p+0,
       -0x1.4567a8p-1, 0x1.cf10dep-1},
      {Fractal::ridged, Basis::gradient, 0x1.86ap+15, -0x1.8dd2fp-1, 0x1.542706p-1, 0x1.270d76p-2,
       0x1.484dd6p-2},
      {Fractal::ridged, Basis::simplex, 0x1.47ae14p-9, 0x1.eb851ep-8, 0x1.901a5cp-2, 0x1.04c9d6p-4,
       0x1.4bede2p-1},
      {Fractal::ridged, Basis::simplex, -0x1.2f1aap-4, 0x1.ef9db2p-3, 0x1.7cc72p-2, 0x1.b4cccep-3,
       0x1.845e64p-3},
      {Fractal::ridged, Basis::simplex, 0x1.2847acp+5, -0x1.d9e146p+4, 0x1.5a27dep-3,
       -0x1.17a2f4p-1, -0x1.73e5ap-4},
      {Fractal::ridged, Basis::simplex, -0x1.387ff6p+15, 0x1.387ffap+15, 0x1.a4c8p-1, 0x1.42a92ap-1,
       -0x1.284ec4p-1},
      {Fractal::ridged, Basis::simplex, 0x0p+0, 0x0p+0, 0x1.8b6148p-2, 0x1.48e8e6p-4,
       0x1.112578p-1},
      {Fractal::ridged, Basis::simplex, 0x1.0594bp+0, -0x1.f75108p-15, 0x1.2500d8p-2, 0x1.72443cp+0,
       0x1.aeb304p+0},
      {Fractal::ridged, Basis::simplex, -0x1.1eb852p-5, -0x1.1eb852p-5, 0x1.7f9446p-2,
       -0x1.161394p-5, 0x1.922564p-4},
      {Fractal::ridged, Basis::simplex, 0x1.fff2e4p+2, 0x1.b2617ap+1, 0x1.fa8bdep-1, 0x1.25a488p+0,
       -0x1.066ad8p-3},
      {Fractal::ridged, Basis::simplex, -0x1.682e14p+4, 0x1.428f5cp-2, 0x1.51f3fp+0, 0x1.bdbef6p+0,
       0x1.81f518p+1},
      {Fractal::ridged, Basis::simplex, 0x1.86ap+15, -0x1.8dd2fp-1, 0x1.9bf5d6p-1, 0x1.f24b1p-5,
       0x1.8df72ap-2},
      {Fractal::hybrid, Basis::gradient, 0x1.47ae14p-9, 0x1.eb851ep-8, 0x1.0bdc24p+1,
       -0x1.0cbdb4p-4, -0x1.41df38p-2},
      {Fractal::hybrid, Basis::gradient, -0x1.2f1aap-4, 0x1.ef9db2p-3, 0x1.036a34p+1,
       -0x1.fb3e52p-5, -0x1.383576p-2},
      {Fractal::hybrid, Basis::gradient, 0x1.2847acp+5, -0x1.d9e146p+4, 0x1.be7d74p+0,
       0x1.820ef2p-3, -0x1.f35af4p-3},
      {Fractal::hybrid, Basis::gradient, -0x1.387ff6p+15, 0x1.387ffap+15, 0x1.e10578p+0,
       0x1.38646cp-3, 0x1.5c5244p-5},
      {Fractal::hybrid, Basis::gradient, 0x0p+0, 0x0p+0, 0x1.0c2eb2p+1, -0x1.03dba8p-4,
       -0x1.421222p-2},
      {Fractal::hybrid, Basis::gradient, 0x1.0594bp+0, -0x1.f75108p-15, 0x1.e7f192p+0,
       -0x1.6f314ap-2, -0x1.ebb45cp-2},
      {Fractal::hybrid, Basis::gradient, -0x1.1eb852p-5, -0x1.1eb852p-5, 0x1.0dd40cp+1,
       -0x1.7aba1p-5, -0x1.3e0b9ap-2},
      {Fractal::hybrid, Basis::gradient, 0x1.fff2e4p+2, 0x1.b2617ap+1, 0x1.a58bcap+0, 0x1.c74124p-5,
       -0x1.a7cee4p-10},
      {Fractal::hybrid, Basis::gradient, -0x1.682e14p+4, 0x1.428f5cp-2, 0x1.6a9a28p+0,
       -0x1.91442ep-2, 0x1.0d4936p-2},
      {Fractal::hybrid, Basis::gradient, 0x1.86ap+15, -0x1.8dd2fp-1, 0x1.f230cep-1, -0x1.47d8bp-5,
       0x1.01e19ap-3},
      {Fractal::hybrid, Basis::simplex, 0x1.47ae14p-9, 0x1.eb851ep-8, 0x1.55fe14p-1, -0x1.0defc8p-2,
       -0x1.5661cap-3},
      {Fractal::hybrid, Basis::simplex, -0x1.2f1aap-4, 0x1.ef9db2p-3, 0x1.509972p-1, -0x1.d6aa56p-3,
       -0x1.655c96p-4},
      {Fractal::hybrid, Basis::simplex, 0x1.2847acp+5, -0x1.d9e146p+4, 0x1.ded2b2p-2, 0x1.4427bap-3,
       -0x1.f35d8cp-3},
      {Fractal::hybrid, Basis::simplex, -0x1.387ff6p+15, 0x1.387ffap+15, 0x1.4fc7aep+1,
       -0x1.357844p-4, 0x1.68263p-2},
      {Fractal::hybrid, Basis::simplex, 0x0p+0, 0x0p+0, 0x1.56fb5p-1, -0x1.10ca9cp-2,
       -0x1.5ec2d8p-3},
      {Fractal::hybrid, Basis::simplex, 0x1.0594bp+0, -0x1.f75108p-15, 0x1.e011fep-2,
       -0x1.942354p-3, 0x1.b7ffacp-4},
      {Fractal::hybrid, Basis::simplex, -0x1.1eb852p-5, -0x1.1eb852p-5, 0x1.5f3e1cp-1,
       -0x1.28123ap-2, -0x1.8f760cp-3},
      {Fractal::hybrid, Basis::simplex, 0x1.fff2e4p+2, 0x1.b2617ap+1, 0x1.18005ep+0, 0x1.a48c9ep-1,
       -0x1.96d08p-5},
      {Fractal::hybrid, Basis::simplex, -0x1.682e14p+4, 0x1.428f5cp-2, 0x1.91ea22p+0, -0x1.2a7c5p-1,
       0x1.fb4a8p-2},
      {Fractal::hybrid, Basis::simplex, 0x1.86ap+15, -0x1.8dd2fp-1, 0x1.2c56a8p+1, -0x1.38a95ap-1,
       -0x1.c1c99cp-1},
      {Fractal::warped, Basis::gradient, 0x1.47ae14p-9, 0x1.eb851ep-8, 0x1.bce356p-3,
       -0x1.211212p-3, 0x1.fd2be4p-5},
      {Fractal::warped, Basis::gradient, -0x1.2f1aap-4, 0x1.ef9db2p-3, 0x1.de6e7p-3, 0x1.bf1d7p-3,
       0x1.41449ap-5},
      {Fractal::warped, Basis::gradient, 0x1.2847acp+5, -0x1.d9e146p+4, 0x1.61c5bp-2, 0x1.b21422p-1,
       -0x1.1cb83ep-1},
      {Fractal::warped, Basis::gradient, -0x1.387ff6p+15, 0x1.387ffap+15, -0x1.62ed84p-3,
       -0x1.4e226cp+40, -0x1.b95a5p+35},
      {Fractal::warped, Basis::gradient, 0x0p+0, 0x0p+0, 0x1.bcb0fp-3, -0x1.21e4bep-3,
       0x1.d840bcp-5},
      {Fractal::warped, Basis::gradient, 0x1.0594bp+0, -0x1.f75108p-15, 0x1.0d18ecp-3,
       0x1.7ffe5cp-4, -0x1.5029aep-2},
      {Fractal::warped, Basis::gradient, -0x1.1eb852p-5, -0x1.1eb852p-5, 0x1.c3b00cp-3,
       -0x1.16d668p-3, 0x1.8f2248p-6},
      {Fractal::warped, Basis::gradient, 0x1.fff2e4p+2, 0x1.b2617ap+1, 0x1.d598ecp-3, 0x1.bd4274p-5,
       -0x1.e7162ep-3},
      {Fractal::warped, Basis::gradient, -0x1.682e14p+4, 0x1.428f5cp-2, -0x1.af343p-2,
       0x1.bc8e36p-2, -0x1.480176p-4},
      {Fractal::warped, Basis::gradient, 0x1.86ap+15, -0x1.8dd2fp-1, -0x1.b5525p-1, -0x1.fbd6fap+45,
       0x1.bea808p+47},
      {Fractal::warped, Basis::simplex, 0x1.47ae14p-9, 0x1.eb851ep-8, -0x1.6fa64ep-1,
       -0x1.0ad30ap+0, 0x1.ae4b98p-2},
      {Fractal::warped, Basis::simplex, -0x1.2f1aap-4, 0x1.ef9db2p-3, -0x1.f70fa4p-2,
       -0x1.79786ap+0, 0x1.56106p+0},
      {Fractal::warped, Basis::simplex, 0x1.2847acp+5, -0x1.d9e146p+4, -0x1.52da52p+0,
       0x1.672578p-1, 0x1.2455cp-2},
      {Fractal::warped, Basis::simplex, -0x1.387ff6p+15, 0x1.387ffap+15, -0x1.877d26p-5,
       -0x1.847868p+48, -0x1.5e8356p+49},
      {Fractal::warped, Basis::simplex, 0x0p+0, 0x0p+0, -0x1.6fdeb6p-1, -0x1.0b797ap+0,
       0x1.906248p-2},
      {Fractal::warped, Basis::simplex, 0x1.0594bp+0, -0x1.f75108p-15, -0x1.157214p+0,
       -0x1.0d19c4p-4, 0x1.08b77cp-2},
      {Fractal::warped, Basis::simplex, -0x1.1eb852p-5, -0x1.1eb852p-5, -0x1.63cdcep-1,
       -0x1.f3d472p-1, 0x1.7c49dp-2},
      {Fractal::warped, Basis::simplex, 0x1.fff2e4p+2, 0x1.b2617ap+1, -0x1.f73dcp-3, 0x1.deaffp-1,
       0x1.0b13p-2},
      {Fractal::warped, Basis::simplex, -0x1.682e14p+4, 0x1.428f5cp-2, 0x1.dfce14p-2, 0x1.81ceep-1,
       -0x1.d1fe46p-2},
      {Fractal::warped, Basis::simplex, 0x1.86ap+15, -0x1.8dd2fp-1, -0x1.8be52cp-3, -0x1.46fcep+55,
       -0x1.622a7ap+55},
  };
  for (const GoldenFractal& g : k2) {
    const FractalParams p = test_params(g.kind, g.basis, 99);
    const Sample2 s = fractal2(p, Vec2{g.x, g.y}, 5.5f);
    const std::string at = label(p) + " at " + std::to_string(g.x) + "," + std::to_string(g.y);
    expect_bits(s.value, g.value, at);
    expect_bits(s.dx, g.dx, at);
    expect_bits(s.dy, g.dy, at);
  }
  static const GoldenFractal3 k3[] = {
      {Fractal::fbm, Basis::gradient, -0x1.7ae148p-3, 0x1.35c29p-1, -0x1.a66666p-2, 0x1.79c896p-3,
       0x1.c1d888p-5, -0x1.8827a4p-5, 0x1.333028p-2},
      {Fractal::fbm, Basis::gradient, 0x1.edcccep+5, -0x1.8ae666p+5, 0x1.633334p+1, -0x1.c6617ap-2,
       -0x1.b20a02p-4, -0x1.3d9a58p-4, 0x1.eafep-3},
      {Fractal::fbm, Basis::gradient, -0x1.869ff4p+15, 0x1.869ffap+15, -0x1.869feep+15,
       -0x1.1fb24cp-3, 0x1.df7114p-5, -0x1.581e84p-3, -0x1.b75d4ep-6},
      {Fractal::fbm, Basis::gradient, 0x0p+0, 0x0p+0, 0x0p+0, 0x1.475938p-2, -0x1.65064cp-7,
       0x1.4f90a2p-3, -0x1.36c538p-3},
      {Fractal::fbm, Basis::simplex, -0x1.7ae148p-3, 0x1.35c29p-1, -0x1.a66666p-2, 0x1.f76112p-3,
       -0x1.d4ff2cp-1, -0x1.82acc8p+0, 0x1.2ef232p-2},
      {Fractal::fbm, Basis::simplex, 0x1.edcccep+5, -0x1.8ae666p+5, 0x1.633334p+1, 0x1.7c4b7p-1,
       0x1.c3ae82p-1, -0x1.9f95b8p-2, 0x1.db5cbcp-2},
      {Fractal::fbm, Basis::simplex, -0x1.869ff4p+15, 0x1.869ffap+15, -0x1.869feep+15,
       -0x1.4eb702p-2, 0x1.e4d678p-1, -0x1.996feap-1, -0x1.a7f9cp-1},
      {Fractal::fbm, Basis::simplex, 0x0p+0, 0x0p+0, 0x0p+0, 0x1.886f52p-2, -0x1.e1c626p-1,
       -0x1.a787bp-2, 0x1.3373e2p-2},
      {Fractal::ridged, Basis::gradient, -0x1.7ae148p-3, 0x1.35c29p-1, -0x1.a66666p-2,
       0x1.9abb68p+0, 0x1.b3fcbp-6, 0x1.04e94cp-3, 0x1.50f52cp-3},
      {Fractal::ridged, Basis::gradient, 0x1.edcccep+5, -0x1.8ae666p+5, 0x1.633334p+1,
       0x1.2cb8b8p+0, 0x1.bb1598p-5, -0x1.6303ep-2, -0x1.8ef9ccp-4},
      {Fractal::ridged, Basis::gradient, -0x1.869ff4p+15, 0x1.869ffap+15, -0x1.869feep+15,
       0x1.d4a62p+0, 0x1.34659p-3, 0x1.5faeeap-4, 0x1.6a506p-2},
      {Fractal::ridged, Basis::gradient, 0x0p+0, 0x0p+0, 0x0p+0, 0x1.7660bep+0, 0x1.f0270cp-3,
       0x1.8d833ap-4, 0x1.8e35d6p-2},
      {Fractal::ridged, Basis::simplex, -0x1.7ae148p-3, 0x1.35c29p-1, -0x1.a66666p-2, 0x1.582e38p+0,
       0x1.905f4p-3, 0x1.03f87cp-2, -0x1.858e34p-1},
      {Fractal::ridged, Basis::simplex, 0x1.edcccep+5, -0x1.8ae666p+5, 0x1.633334p+1, 0x1.bd3c4cp-2,
       -0x1.d730fcp-3, 0x1.9e30a4p-1, 0x1.373758p-1},
      {Fractal::ridged, Basis::simplex, -0x1.869ff4p+15, 0x1.869ffap+15, -0x1.869feep+15,
       0x1.3a3dbep+0, 0x1.8ad7f4p-1, 0x1.044198p+0, -0x1.7ff6a8p+0},
      {Fractal::ridged, Basis::simplex, 0x0p+0, 0x0p+0, 0x0p+0, 0x1.6352fp+0, 0x1.d76efap+0,
       0x1.8d38eap-1, -0x1.922a08p-4},
      {Fractal::hybrid, Basis::gradient, -0x1.7ae148p-3, 0x1.35c29p-1, -0x1.a66666p-2,
       0x1.f411fap+0, 0x1.5bcdd8p-4, 0x1.fb62acp-7, 0x1.101778p-3},
      {Fractal::hybrid, Basis::gradient, 0x1.edcccep+5, -0x1.8ae666p+5, 0x1.633334p+1,
       0x1.046cf2p+0, -0x1.a6df82p-6, -0x1.73b1f8p-4, 0x1.923022p-4},
      {Fractal::hybrid, Basis::gradient, -0x1.869ff4p+15, 0x1.869ffap+15, -0x1.869feep+15,
       0x1.b07c24p+0, 0x1.975b3p-5, -0x1.d350c4p-4, 0x1.acb436p-5},
      {Fractal::hybrid, Basis::gradient, 0x0p+0, 0x0p+0, 0x0p+0, 0x1.ff140ep+0, 0x1.4fde0ap-4,
       0x1.57b494p-3, 0x1.dfce44p-4},
      {Fractal::hybrid, Basis::simplex, -0x1.7ae148p-3, 0x1.35c29p-1, -0x1.a66666p-2, 0x1.1a7bd2p+1,
       -0x1.453e78p-1, -0x1.018146p+0, 0x1.fc982ep-3},
      {Fractal::hybrid, Basis::simplex, 0x1.edcccep+5, -0x1.8ae666p+5, 0x1.633334p+1, 0x1.4cc886p+1,
       0x1.0b4bb8p-2, 0x1.172252p-2, 0x1.cc6a3ep-3},
      {Fractal::hybrid, Basis::simplex, -0x1.869ff4p+15, 0x1.869ffap+15, -0x1.869feep+15,
       0x1.3cd862p+0, 0x1.2bdc98p-1, -0x1.6841ccp-1, -0x1.6ceeep-2},
      {Fractal::hybrid, Basis::simplex, 0x0p+0, 0x0p+0, 0x0p+0, 0x1.24405ap+1, -0x1.2d9308p+0,
       -0x1.fe31b6p-3, -0x1.a6e512p-3},
  };
  for (const GoldenFractal3& g : k3) {
    const FractalParams p = test_params(g.kind, g.basis, 99);
    const Sample3 s = fractal3(p, g.x, g.y, g.z, 5.5f);
    const std::string at = label(p) + " 3D at " + std::to_string(g.x);
    expect_bits(s.value, g.value, at);
    expect_bits(s.dx, g.dx, at);
    expect_bits(s.dy, g.dy, at);
    expect_bits(s.dz, g.dz, at);
  }
}
// GOLDEN_FRACTALS_END

}  // namespace
}  // namespace terrain::noise
