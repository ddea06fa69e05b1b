// Curve skeletons: flattening, signed distance and side conventions, arc length and elevation,
// gradients, chunk culling, bounds and rejection of malformed input.
#include "terrain/polyline.hpp"

#include "terrain/profile.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace terrain {
namespace {

Polyline make(const std::vector<CurvePiece>& pieces, float tolerance = 0.02f) {
  auto r = Polyline::build(pieces, PolylineOptions{tolerance});
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(r).value();
}

/// A gently winding road: cubic pieces with a rising, then falling elevation.
std::vector<CurvePiece> winding() {
  return {
      {{{0, 0, 10}, {30, 20, 12}, {60, -20, 15}, {90, 0, 16}}},
      {{{90, 0, 16}, {120, 20, 17}, {140, 40, 14}}},
      {{{140, 40, 14}, {160, 60, 13}}},
      {{{160, 60, 13}, {180, 80, 12}, {200, 60, 10}, {230, 70, 8}}},
  };
}

/// A spiral of many short segments: plenty of chunks, and chunks that overlap in space.
std::vector<CurvePiece> spiral(int turns_x16) {
  std::vector<CurvePiece> pieces;
  CurvePoint prev{10.0f, 0.0f, 0.0f};
  for (int i = 1; i <= turns_x16; ++i) {
    const double a = 2.0 * 3.141592653589793 * i / 16.0;
    const double r = 10.0 + 1.5 * a;
    const CurvePoint next{static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)),
                          static_cast<float>(0.1 * i)};
    pieces.push_back({{prev, next}});
    prev = next;
  }
  return pieces;
}

/// Distance from p to the polyline in double (reference).
double reference_distance(const Polyline& line, Vec2 p) {
  double best = INFINITY;
  const auto v = line.vertices();
  for (std::size_t i = 0; i + 1 < v.size(); ++i) {
    const double ax = v[i].x, ay = v[i].y, ex = v[i + 1].x - ax, ey = v[i + 1].y - ay;
    const double wx = p.x - ax, wy = p.y - ay;
    const double h = std::clamp((wx * ex + wy * ey) / (ex * ex + ey * ey), 0.0, 1.0);
    best = std::min(best, std::hypot(wx - h * ex, wy - h * ey));
  }
  return best;
}

/// Region key: the segment for a slab, −1 − vertex for a vertex wedge or end cap.
int feature(const PolylineSample& s) {
  return s.vertex >= 0 ? -1 - s.vertex : s.segment;
}

TEST(Polyline, SignedDistanceIsPositiveOnTheLeft) {
  const Polyline line = make({{{{0, 0, 0}, {10, 0, 0}}}});
  const PolylineSample left = line.nearest({5.0f, 2.0f});
  const PolylineSample right = line.nearest({5.0f, -3.0f});
  EXPECT_EQ(left.signed_distance, 2.0f);
  EXPECT_EQ(left.distance, 2.0f);
  EXPECT_EQ(right.signed_distance, -3.0f);
  EXPECT_EQ(right.distance, 3.0f);
  EXPECT_EQ(left.grad_d.x, 0.0f);
  EXPECT_EQ(left.grad_d.y, 1.0f);
  EXPECT_EQ(right.grad_d.y, 1.0f);  // ∇ of the signed distance points left on both sides
  EXPECT_EQ(left.vertex, -1);
  EXPECT_EQ(left.s, 5.0f);
  // Reversing the direction of travel flips the sign.
  const Polyline back = make({{{{10, 0, 0}, {0, 0, 0}}}});
  EXPECT_EQ(back.nearest({5.0f, 2.0f}).signed_distance, -2.0f);
}

TEST(Polyline, SignIsConsistentInVertexWedges) {
  // Left turn at (10, 0): the outer wedge is on the right (negative side).
  const Polyline line = make({{{{0, 0, 0}, {10, 0, 0}}}, {{{10, 0, 0}, {10, 10, 0}}}});
  const PolylineSample outer = line.nearest({12.0f, -2.0f});
  EXPECT_EQ(outer.vertex, 1);
  EXPECT_LT(outer.signed_distance, 0.0f);
  EXPECT_NEAR(outer.distance, std::sqrt(8.0f), 1e-6f);
  const PolylineSample inner = line.nearest({8.0f, 1.0f});
  EXPECT_GT(inner.signed_distance, 0.0f);
  // Sweeping around the vertex on the outer side: the signed distance is continuous.
  float previous =
      line.nearest({10.0f + 2.0f * std::cos(-3.0f), 2.0f * std::sin(-3.0f)}).signed_distance;
  for (int i = 0; i <= 100; ++i) {
    const float a = -3.0f + 3.0f * static_cast<float>(i) / 100.0f;  // from behind to beyond
    const PolylineSample s = line.nearest({10.0f + 2.0f * std::cos(a), 2.0f * std::sin(a)});
    if (s.vertex == 1) {
      EXPECT_NEAR(s.signed_distance, -2.0f, 1e-5f);
    }
    EXPECT_LE(std::abs(s.signed_distance - previous), 0.2f);
    previous = s.signed_distance;
  }
  // A hairpin (normals cancel) still gives a finite, signed answer.
  const Polyline hairpin = make({{{{0, 0, 0}, {10, 0, 0}}}, {{{10, 0, 0}, {0, 0.0f, 0}}}});
  const PolylineSample h = hairpin.nearest({12.0f, 0.5f});
  EXPECT_TRUE(std::isfinite(h.signed_distance));
  EXPECT_NEAR(h.distance, std::hypot(2.0f, 0.5f), 1e-5f);
}

TEST(Polyline, EndCapsHaveZeroArcLengthGradient) {
  const Polyline line = make({{{{0, 0, 1}, {10, 0, 3}}}});
  const PolylineSample behind = line.nearest({-3.0f, 4.0f});
  EXPECT_EQ(behind.vertex, 0);
  EXPECT_EQ(behind.distance, 5.0f);
  EXPECT_EQ(behind.signed_distance, 5.0f);
  EXPECT_EQ(behind.s, 0.0f);
  EXPECT_EQ(behind.z, 1.0f);
  EXPECT_EQ(behind.grad_s.x, 0.0f);
  EXPECT_EQ(behind.grad_z.y, 0.0f);
  EXPECT_NEAR(behind.grad_d.x, -0.6f, 1e-6f);
  EXPECT_NEAR(behind.grad_d.y, 0.8f, 1e-6f);
  const PolylineSample beyond = line.nearest({13.0f, -4.0f});
  EXPECT_EQ(beyond.vertex, 1);
  EXPECT_EQ(beyond.signed_distance, -5.0f);
  EXPECT_EQ(beyond.s, 10.0f);
  EXPECT_EQ(beyond.z, 3.0f);
  // Exactly on a vertex: distance 0, gradient of d defined as 0.
  const PolylineSample on = line.nearest({0.0f, 0.0f});
  EXPECT_EQ(on.distance, 0.0f);
  EXPECT_EQ(on.grad_d.x, 0.0f);
  EXPECT_EQ(on.grad_d.y, 0.0f);
}

TEST(Polyline, DistanceMatchesADoublePrecisionReference) {
  const Polyline line = make(winding());
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> x(-50.0f, 280.0f), y(-60.0f, 130.0f);
  for (int i = 0; i < 3000; ++i) {
    const Vec2 p{x(rng), y(rng)};
    const PolylineSample s = line.nearest(p);
    ASSERT_TRUE(s.found);
    EXPECT_NEAR(s.distance, reference_distance(line, p), 2e-4);
    EXPECT_NEAR(length(p - s.q), s.distance, 2e-4f);
  }
}

TEST(Polyline, ChunkCullingGivesTheSameAnswersAsBruteForce) {
  const Polyline line = make(spiral(16 * 6));
  ASSERT_GT(line.chunk_count(), 4);
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> c(-80.0f, 80.0f);
  for (int i = 0; i < 5000; ++i) {
    const Vec2 p{c(rng), c(rng)};
    const PolylineSample a = line.nearest(p);
    const PolylineSample b = line.nearest_brute_force(p);
    ASSERT_TRUE(a.found);
    EXPECT_EQ(a.segment, b.segment);
    EXPECT_EQ(a.vertex, b.vertex);
    EXPECT_EQ(a.signed_distance, b.signed_distance);
    EXPECT_EQ(a.s, b.s);
    EXPECT_EQ(a.z, b.z);
    EXPECT_EQ(a.grad_d.x, b.grad_d.x);
    EXPECT_EQ(a.grad_s.y, b.grad_s.y);
  }
}

TEST(Polyline, BlockCandidatesGiveTheSameAnswersAsAFullSearch) {
  const Polyline line = make(spiral(16 * 6));
  std::vector<float> packed;
  line.pack(packed);
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> c(-120.0f, 120.0f), size(0.1f, 40.0f);
  for (int b = 0; b < 300; ++b) {
    const Vec2 lo{c(rng), c(rng)};
    const Box2 box{lo, lo + Vec2{size(rng), size(rng)}};
    std::uint16_t candidates[256];
    const int count = polyline_candidates(packed.data(), box, candidates, 256);
    ASSERT_GE(count, 1);
    std::uniform_real_distribution<float> ux(box.lo.x, box.hi.x), uy(box.lo.y, box.hi.y);
    for (int i = 0; i < 30; ++i) {
      const Vec2 p{ux(rng), uy(rng)};
      const PolylineSample a = polyline_eval_candidates(packed.data(), p, candidates, count);
      const PolylineSample e = polyline_eval(packed.data(), p);
      ASSERT_EQ(a.segment, e.segment);
      ASSERT_EQ(a.signed_distance, e.signed_distance);
      ASSERT_EQ(a.s, e.s);
    }
  }
}

TEST(Polyline, BlockSearchGivesTheSameAnswersAsPointQueries) {
  const Polyline line = make(spiral(16 * 6));
  std::vector<float> packed;
  line.pack(packed);
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> c(-120.0f, 120.0f), size(0.1f, 40.0f);
  for (int b = 0; b < 300; ++b) {
    const Vec2 lo{c(rng), c(rng)};
    const Box2 box{lo, lo + Vec2{size(rng), size(rng)}};
    // Half the blocks with a cut-off, which also prunes the candidates.
    const float cutoff = b % 2 == 0 ? std::numeric_limits<float>::infinity() : 6.0f;
    std::uint16_t candidates[256];
    const int count = polyline_candidates(packed.data(), box, candidates, 256, cutoff);
    if (count <= 0) continue;
    std::uniform_real_distribution<float> ux(box.lo.x, box.hi.x), uy(box.lo.y, box.hi.y);
    constexpr int kPoints = 37;
    float xs[kPoints], ys[kPoints], d2[kPoints], h[kPoints];
    std::int32_t segment[kPoints];
    for (int i = 0; i < kPoints; ++i) {
      xs[i] = ux(rng);
      ys[i] = uy(rng);
    }
    polyline_nearest_block(packed.data(), candidates, count, xs, ys, kPoints, segment, d2, h);
    for (int i = 0; i < kPoints; ++i) {
      const Vec2 p{xs[i], ys[i]};
      const PolylineSample a = polyline_sample(packed.data(), p, segment[i], d2[i], h[i], cutoff);
      const PolylineSample e =
          polyline_eval_candidates(packed.data(), p, candidates, count, cutoff);
      ASSERT_EQ(a.found, e.found);
      ASSERT_EQ(a.segment, e.segment);
      ASSERT_EQ(a.vertex, e.vertex);
      ASSERT_EQ(std::bit_cast<std::uint32_t>(a.signed_distance),
                std::bit_cast<std::uint32_t>(e.signed_distance));
      ASSERT_EQ(std::bit_cast<std::uint32_t>(a.s), std::bit_cast<std::uint32_t>(e.s));
      ASSERT_EQ(std::bit_cast<std::uint32_t>(a.z), std::bit_cast<std::uint32_t>(e.z));
      ASSERT_EQ(std::bit_cast<std::uint32_t>(a.grad_d.x), std::bit_cast<std::uint32_t>(e.grad_d.x));
      ASSERT_EQ(std::bit_cast<std::uint32_t>(a.grad_s.y), std::bit_cast<std::uint32_t>(e.grad_s.y));
    }
  }
}

TEST(Polyline, PointsBeyondTheCutoffAreReportedOutside) {
  const Polyline line = make(spiral(16 * 3));
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> c(-200.0f, 200.0f);
  const float cutoff = 5.0f;
  int inside = 0, outside = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec2 p{c(rng), c(rng)};
    const PolylineSample a = line.nearest(p, cutoff);
    const PolylineSample b = line.nearest_brute_force(p);
    if (b.distance <= cutoff) {
      ++inside;
      ASSERT_TRUE(a.found);
      EXPECT_EQ(a.signed_distance, b.signed_distance);
      EXPECT_EQ(a.s, b.s);
    } else {
      ++outside;
      EXPECT_FALSE(a.found);
      EXPECT_EQ(a.distance, cutoff);
    }
  }
  EXPECT_GT(inside, 50);
  EXPECT_GT(outside, 50);
}

TEST(Polyline, GradientsMatchCentralDifferencesInsideEachRegion) {
  const Polyline line = make(winding());
  std::mt19937 rng(14);
  std::uniform_real_distribution<float> x(-30.0f, 260.0f), y(-50.0f, 110.0f);
  const float h = 1e-3f;
  int checked = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec2 p{x(rng), y(rng)};
    const PolylineSample c = line.nearest(p);
    const PolylineSample sx0 = line.nearest({p.x - h, p.y}), sx1 = line.nearest({p.x + h, p.y});
    const PolylineSample sy0 = line.nearest({p.x, p.y - h}), sy1 = line.nearest({p.x, p.y + h});
    // Only where the whole stencil stays in one region (the fields are piecewise smooth).
    const int f = feature(c);
    if (feature(sx0) != f || feature(sx1) != f || feature(sy0) != f || feature(sy1) != f) continue;
    if (c.distance < 0.01f) continue;  // the unsigned distance kinks on the curve
    ++checked;
    const float tol = 0.02f;
    EXPECT_NEAR(c.grad_d.x, (sx1.signed_distance - sx0.signed_distance) / (2 * h), tol);
    EXPECT_NEAR(c.grad_d.y, (sy1.signed_distance - sy0.signed_distance) / (2 * h), tol);
    EXPECT_NEAR(c.grad_s.x, (sx1.s - sx0.s) / (2 * h), 0.05f);
    EXPECT_NEAR(c.grad_s.y, (sy1.s - sy0.s) / (2 * h), 0.05f);
    EXPECT_NEAR(c.grad_z.x, (sx1.z - sx0.z) / (2 * h), tol);
    EXPECT_NEAR(c.grad_z.y, (sy1.z - sy0.z) / (2 * h), tol);
    EXPECT_NEAR(c.grad_z.x, c.dz_ds * c.grad_s.x, 1e-5f);
    EXPECT_NEAR(c.grad_z.y, c.dz_ds * c.grad_s.y, 1e-5f);
    EXPECT_NEAR(length(c.grad_d), 1.0f, 1e-5f);
    if (c.vertex < 0) {
      EXPECT_NEAR(length(c.grad_s), 1.0f, 1e-4f);
    }
  }
  EXPECT_GT(checked, 3000);
}

TEST(Polyline, UnsignedDistanceIsOneLipschitz) {
  const Polyline line = make(spiral(16 * 4));
  std::mt19937 rng(15);
  std::uniform_real_distribution<float> c(-70.0f, 70.0f), step(-2.0f, 2.0f);
  for (int i = 0; i < 5000; ++i) {
    const Vec2 p{c(rng), c(rng)};
    const Vec2 q = i % 2 ? Vec2{c(rng), c(rng)} : p + Vec2{step(rng), step(rng)};
    EXPECT_LE(std::abs(line.nearest(p).distance - line.nearest(q).distance),
              length(p - q) * (1.0f + 1e-5f) + 1e-4f);
  }
}

TEST(Polyline, SignedDistanceIsOneLipschitzNearAGentleCurve) {
  // Away from the end caps and within the reach of the curve the sign never jumps.
  const Polyline line = make(winding());
  std::mt19937 rng(16);
  std::uniform_real_distribution<float> t(10.0f, 220.0f), step(-1.0f, 1.0f), off(-8.0f, 8.0f);
  int checked = 0;
  for (int i = 0; i < 5000; ++i) {
    const PolylineSample on = line.nearest({t(rng), 0.0f});
    const Vec2 p = on.q + Vec2{off(rng), off(rng)};
    const Vec2 q = p + Vec2{step(rng), step(rng)};
    const PolylineSample a = line.nearest(p), b = line.nearest(q);
    if (a.vertex == 0 || b.vertex == 0 || a.vertex == line.segment_count() ||
        b.vertex == line.segment_count())
      continue;
    ++checked;
    EXPECT_LE(std::abs(a.signed_distance - b.signed_distance),
              length(p - q) * (1.0f + 1e-5f) + 1e-4f);
  }
  EXPECT_GT(checked, 4000);
}

TEST(Polyline, ElevationIsLipschitzAlongTheCurveWithMaxDzDs) {
  const Polyline line = make(winding());
  const auto v = line.vertices();
  const float lip = line.max_dz_ds();
  EXPECT_GT(lip, 0.0f);
  float steepest = 0.0f;
  for (std::size_t i = 0; i + 1 < v.size(); ++i)
    steepest = std::max(steepest, std::abs(v[i + 1].z - v[i].z) / (v[i + 1].s - v[i].s));
  EXPECT_NEAR(lip, steepest, 1e-3f * lip);
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> s(0.0f, 1.0f);
  // Points on the curve, addressed through nearest queries at the vertices' interpolation.
  for (int i = 0; i < 3000; ++i) {
    const std::size_t k = static_cast<std::size_t>(s(rng) * static_cast<float>(v.size() - 1));
    const std::size_t l = static_cast<std::size_t>(s(rng) * static_cast<float>(v.size() - 1));
    const float a = s(rng), b = s(rng);
    const auto at = [&](std::size_t j, float f) {
      const std::size_t j1 = std::min(j + 1, v.size() - 1);
      return Vec2{v[j].x + f * (v[j1].x - v[j].x), v[j].y + f * (v[j1].y - v[j].y)};
    };
    const PolylineSample p = line.nearest(at(k, a)), q = line.nearest(at(l, b));
    EXPECT_LE(std::abs(p.z - q.z), lip * std::abs(p.s - q.s) * (1.0f + 1e-4f) + 1e-4f);
  }
  // In the plane, within one region, |∇z| ≤ max_dz_ds.
  std::uniform_real_distribution<float> x(-30.0f, 260.0f), y(-50.0f, 110.0f);
  for (int i = 0; i < 3000; ++i) {
    const PolylineSample p = line.nearest({x(rng), y(rng)});
    EXPECT_LE(length(p.grad_z), lip * (1.0f + 1e-5f));
  }
  EXPECT_EQ(line.z_range().lo, 8.0f);
  EXPECT_GE(line.z_range().hi, 16.0f);
}

TEST(Polyline, CurvePrimitiveBoundHoldsAwayFromDiscontinuities) {
  // f = z(s) + lerp(c_a, c_b, s/L)(d), the curve primitive's elevation (docs/geometry.md §2.5).
  const Polyline line = make(winding());
  const Profile a = Profile::river(6.0f, 2.0f, 3.0f).value();
  const Profile b = Profile::meander(10.0f, 3.0f, 4.0f, 0.5f).value();
  std::vector<float> pool;
  a.pack(pool);
  const std::size_t ob = pool.size();
  b.pack(pool);
  const float total = line.length();
  const auto f = [&](const PolylineSample& s) {
    return s.z +
           profile_blend_eval(pool.data(), pool.data() + ob, s.signed_distance, s.s / total).value;
  };
  const float ld = std::max(a.max_slope(), b.max_slope());
  const Interval diff = profile_difference(a, b);
  const float ls = std::max(std::abs(diff.lo), std::abs(diff.hi)) / total;
  const float lz = line.max_dz_ds();
  const float bound = std::sqrt(ld * ld + (lz + ls) * (lz + ls));
  std::mt19937 rng(19);
  std::uniform_real_distribution<float> x(10.0f, 220.0f), off(-8.0f, 8.0f), step(-0.5f, 0.5f);
  int checked = 0;
  float worst = 0.0f;
  for (int i = 0; i < 20000; ++i) {
    const Vec2 p = line.nearest({x(rng), 0.0f}).q + Vec2{off(rng), off(rng)};
    const Vec2 q = p + Vec2{step(rng), step(rng)};
    const PolylineSample sp = line.nearest(p), sq = line.nearest(q);
    const int last = line.segment_count();
    if (sp.vertex == 0 || sq.vertex == 0 || sp.vertex == last || sq.vertex == last) continue;
    // Same region, or a slab and the wedge of one of its vertices on the same side: no inner
    // bisector or medial axis between them.
    const auto adjacent = [](const PolylineSample& w, const PolylineSample& slab) {
      return w.vertex >= 0 && slab.vertex < 0 &&
             (slab.segment == w.vertex || slab.segment == w.vertex - 1) &&
             (w.signed_distance > 0.0f) == (slab.signed_distance > 0.0f);
    };
    if (feature(sp) != feature(sq) && !adjacent(sp, sq) && !adjacent(sq, sp)) continue;
    const float dist = length(p - q);
    if (dist < 1e-3f) continue;
    ++checked;
    const float ratio = std::abs(f(sp) - f(sq)) / dist;
    worst = std::max(worst, ratio);
    EXPECT_LE(ratio, bound * (1.0f + 1e-3f) + 1e-3f);
  }
  EXPECT_GT(checked, 15000);
  EXPECT_GT(worst, 0.5f * bound);
}

TEST(Polyline, ArcLengthJumpAcrossAnInnerBisectorIsBoundedByTheTurnAngle) {
  // Left turn by 60° at (20, 0); points just either side of the inner bisector, d from both.
  const float turn = 3.14159265f / 3.0f;
  const CurvePoint v{20, 0, 0}, end{20 + 20 * std::cos(turn), 20 * std::sin(turn), 0};
  const Polyline line = make({{{{0, 0, 0}, v}}, {{v, end}}});
  EXPECT_NEAR(line.max_turn_angle(), turn, 1e-5f);
  const Vec2 tangent_bisector{std::cos(turn / 2), std::sin(turn / 2)};
  for (float d : {0.5f, 2.0f, 5.0f}) {
    const Vec2 inner_dir = Vec2{-tangent_bisector.y, tangent_bisector.x};  // towards the inside
    const float along = d / std::cos(turn / 2);  // distance to v of the tie point
    const Vec2 tie = Vec2{v.x, v.y} + inner_dir * along;
    const PolylineSample before = line.nearest(tie - tangent_bisector * 1e-3f);
    const PolylineSample after = line.nearest(tie + tangent_bisector * 1e-3f);
    EXPECT_EQ(before.segment, 0);
    EXPECT_EQ(after.segment, 1);
    const float jump = after.s - before.s;
    EXPECT_NEAR(jump, 2.0f * d * std::tan(turn / 2), 0.01f);
    EXPECT_LE(jump, 2.0f * d * std::tan(line.max_turn_angle() / 2) + 0.01f);
  }
}

TEST(Polyline, FlatteningStaysWithinTheChordTolerance) {
  const float tol = 0.02f;
  const std::vector<CurvePiece> pieces = {
      {{{0, 0, 0}, {40, 60, 10}, {80, 0, -5}}},                    // quadratic
      {{{80, 0, -5}, {100, -40, 0}, {140, 40, 20}, {160, 0, 3}}},  // cubic
  };
  const Polyline line = make(pieces, tol);
  const auto v = line.vertices();
  // Vertices sit at uniform parameters per piece: count them back.
  std::size_t first = 0;
  for (const CurvePiece& piece : pieces) {
    const auto& c = piece.points;
    const auto bez = [&](double t, int axis) {
      const auto g = [&](const CurvePoint& q) { return axis == 0 ? q.x : axis == 1 ? q.y : q.z; };
      const double u = 1 - t;
      if (c.size() == 3) return u * u * g(c[0]) + 2 * u * t * g(c[1]) + t * t * g(c[2]);
      return u * u * u * g(c[0]) + 3 * u * u * t * g(c[1]) + 3 * u * t * t * g(c[2]) +
             t * t * t * g(c[3]);
    };
    // The vertex whose position matches the piece end closes the piece.
    std::size_t last = first + 1;
    while (last < v.size() && !(v[last].x == c.back().x && v[last].y == c.back().y)) ++last;
    ASSERT_LT(last, v.size());
    const std::size_t n = last - first;
    for (std::size_t k = 0; k < n; ++k) {
      for (int j = 0; j <= 20; ++j) {
        const double f = j / 20.0;
        const double t = (static_cast<double>(k) + f) / static_cast<double>(n);
        const double dx = bez(t, 0) - (v[first + k].x + f * (v[first + k + 1].x - v[first + k].x));
        const double dy = bez(t, 1) - (v[first + k].y + f * (v[first + k + 1].y - v[first + k].y));
        const double dz = bez(t, 2) - (v[first + k].z + f * (v[first + k + 1].z - v[first + k].z));
        EXPECT_LE(std::sqrt(dx * dx + dy * dy + dz * dz), tol + 1e-4);
        // And the horizontal distance from the curve to the polyline.
        const Vec2 p{static_cast<float>(bez(t, 0)), static_cast<float>(bez(t, 1))};
        EXPECT_LE(line.nearest(p).distance, tol + 1e-4f);
      }
    }
    first = last;
  }
  EXPECT_EQ(first, v.size() - 1);
  // A finer tolerance gives more vertices.
  EXPECT_GT(make(pieces, tol / 4).vertices().size(), v.size());
}

TEST(Polyline, ArcLengthIsTheCumulativeFlattenedLength) {
  const Polyline line = make({{{{0, 0, 0}, {3, 4, 0}}}, {{{3, 4, 0}, {3, 10, 6}}}});
  const auto v = line.vertices();
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[0].s, 0.0f);
  EXPECT_EQ(v[1].s, 5.0f);
  EXPECT_EQ(v[2].s, 11.0f);
  EXPECT_EQ(line.length(), 11.0f);
  EXPECT_EQ(line.max_dz_ds(), std::nextafter(1.0f, 2.0f));
  EXPECT_EQ(line.bounds().lo.x, 0.0f);
  EXPECT_EQ(line.bounds().hi.y, 10.0f);
  const PolylineSample mid = line.nearest({4.0f, 7.0f});
  EXPECT_NEAR(mid.s, 8.0f, 1e-6f);
  EXPECT_NEAR(mid.z, 3.0f, 1e-6f);
  EXPECT_NEAR(mid.dz_ds, 1.0f, 1e-6f);
}

TEST(Polyline, PackedEvaluationEqualsTheConstructionData) {
  const Polyline line = make(winding());
  std::vector<float> pool{1.0f, 2.0f, 3.0f};
  const std::size_t offset = pool.size();
  line.pack(pool);
  ASSERT_EQ(pool.size() - offset, line.packed_size());
  const int segments = line.segment_count();
  EXPECT_EQ(pool[offset], static_cast<float>(segments));
  EXPECT_EQ(pool[offset + 1], static_cast<float>(line.chunk_count()));
  EXPECT_EQ(line.packed_size(), 2u + 4u * static_cast<std::size_t>(segments + 1) +
                                    4u * static_cast<std::size_t>(line.chunk_count()));
  const float* packed = pool.data() + offset;
  for (std::size_t k = 0; k < line.vertices().size(); ++k) {
    const PolylineVertex& q = line.vertices()[k];
    EXPECT_EQ(packed[2 + 4 * k], q.x);
    EXPECT_EQ(packed[5 + 4 * k], q.s);
    const PolylineSample s = polyline_eval(packed, {q.x, q.y});
    EXPECT_EQ(s.distance, 0.0f);
    EXPECT_NEAR(s.s, q.s, 1e-4f);
    EXPECT_NEAR(s.z, q.z, 1e-5f);
  }
  std::mt19937 rng(18);
  std::uniform_real_distribution<float> x(-30.0f, 260.0f), y(-50.0f, 110.0f);
  for (int i = 0; i < 1000; ++i) {
    const Vec2 p{x(rng), y(rng)};
    const PolylineSample a = polyline_eval(packed, p), b = line.nearest(p);
    EXPECT_EQ(a.signed_distance, b.signed_distance);
    EXPECT_EQ(a.z, b.z);
  }
}

struct BadCurve {
  const char* name;
  std::vector<CurvePiece> pieces;
  float tolerance;
  const char* message_part;
  const char* pointer;
};

TEST(PolylineMalformedInput, IsRejectedWithClearMessages) {
  const float nan = std::nanf("");
  const BadCurve cases[] = {
      {"no pieces", {}, 0.02f, "at least one piece", "/pieces"},
      {"one point",
       {{{{0, 0, 0}}}},
       0.02f,
       "must have 2 (segment), 3 (quadratic) or 4",
       "/pieces/0/points"},
      {"five points",
       {{{{0, 0, 0}, {1, 0, 0}}}, {{{1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {4, 0, 0}, {5, 0, 0}}}},
       0.02f,
       "got 5",
       "/pieces/1/points"},
      {"NaN coordinate", {{{{0, 0, 0}, {1, nan, 0}}}}, 0.02f, "not finite", "/pieces/0/points/1"},
      {"infinite elevation",
       {{{{0, 0, 0}, {1, 0, INFINITY}}}},
       0.02f,
       "not finite",
       "/pieces/0/points/1"},
      {"disconnected",
       {{{{0, 0, 0}, {1, 0, 0}}}, {{{1.01f, 0, 0}, {2, 0, 0}}}},
       0.02f,
       "consecutive pieces must share their endpoint",
       "/pieces/1/points/0"},
      {"disconnected in z",
       {{{{0, 0, 0}, {1, 0, 0}}}, {{{1, 0, 0.5f}, {2, 0, 0}}}},
       0.02f,
       "piece 1 starts at (1, 0, 0.5) but piece 0 ends at (1, 0, 0)",
       "/pieces/1/points/0"},
      {"zero length",
       {{{{0, 0, 0}, {1, 0, 0}}}, {{{1, 0, 0}, {1, 0, 5}}}},
       0.02f,
       "piece 1 has zero horizontal length",
       "/pieces/1/points"},
      {"too many vertices",
       {{{{0, 0, 0}, {5000, 9000, 0}, {10000, 0, 0}}}},
       0.0001f,
       "more than 4096 vertices",
       "/pieces"},
      {"zero tolerance",
       {{{{0, 0, 0}, {1, 0, 0}}}},
       0.0f,
       "tolerance must be positive",
       "/tolerance"},
      {"NaN tolerance",
       {{{{0, 0, 0}, {1, 0, 0}}}},
       nan,
       "tolerance must be positive",
       "/tolerance"},
  };
  for (const BadCurve& c : cases) {
    const auto r = Polyline::build(c.pieces, PolylineOptions{c.tolerance});
    ASSERT_FALSE(r.ok()) << c.name;
    EXPECT_NE(r.error().message.find(c.message_part), std::string::npos)
        << c.name << ": " << r.error().message;
    EXPECT_EQ(r.error().pointer, c.pointer) << c.name;
  }
  // Endpoints equal within the relative tolerance are accepted.
  EXPECT_TRUE(Polyline::build(std::vector<CurvePiece>{{{{0, 0, 0}, {1000, 0, 0}}},
                                                      {{{1000.0005f, 0, 0}, {2000, 0, 0}}}})
                  .ok());
}

}  // namespace
}  // namespace terrain
