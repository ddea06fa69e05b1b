// Profiles: interpolation, C1 continuity, shape preservation, exact bounds, presets, blending and
// rejection of malformed input.
#include "terrain/profile.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace terrain {
namespace {

Profile make(std::vector<ProfilePoint> points) {
  auto r = Profile::custom(points);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(r).value();
}

/// A random profile with n points: increasing d with random gaps, random heights.
Profile random_profile(std::mt19937& rng, int n) {
  std::uniform_real_distribution<float> gap(0.05f, 3.0f);
  std::uniform_real_distribution<float> height(-5.0f, 5.0f);
  std::vector<ProfilePoint> p;
  float d = -5.0f;
  for (int k = 0; k < n; ++k) {
    p.push_back({d, height(rng)});
    d += gap(rng);
  }
  return make(p);
}

/// Dense samples of d covering the domain and a margin on both sides.
std::vector<float> dense(const Profile& p, int count = 4000) {
  const Interval dom = p.domain();
  const float margin = 0.1f * dom.width() + 0.5f;
  std::vector<float> xs;
  for (int i = 0; i <= count; ++i)
    xs.push_back(dom.lo - margin +
                 (dom.width() + 2.0f * margin) * static_cast<float>(i) / static_cast<float>(count));
  for (const ProfilePoint& q : p.points()) xs.push_back(q.d);
  return xs;
}

TEST(Profile, ReproducesControlPointsExactly) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const Profile p = random_profile(rng, 2 + trial % 10);
    for (const ProfilePoint& q : p.points()) EXPECT_EQ(p.value(q.d), q.h);
  }
}

TEST(Profile, PackedEvaluationEqualsTheProfile) {
  std::mt19937 rng(2);
  const Profile a = random_profile(rng, 7);
  const Profile b = random_profile(rng, 12);
  std::vector<float> pool{42.0f, 43.0f};  // packing appends at any offset
  const std::size_t offset_a = pool.size();
  a.pack(pool);
  const std::size_t offset_b = pool.size();
  b.pack(pool);
  ASSERT_EQ(pool.size(), offset_b + b.packed_size());
  ASSERT_EQ(a.packed_size(), 1 + 3 * a.points().size());
  EXPECT_EQ(pool[offset_a], 7.0f);
  for (std::size_t k = 0; k < a.points().size(); ++k) {
    EXPECT_EQ(pool[offset_a + 1 + 3 * k], a.points()[k].d);
    EXPECT_EQ(pool[offset_a + 2 + 3 * k], a.points()[k].h);
    EXPECT_EQ(pool[offset_a + 3 + 3 * k], a.slopes()[k]);
  }
  for (float d : dense(b)) {
    const ProfileSample s = profile_eval(pool.data() + offset_b, d);
    EXPECT_EQ(s.value, b.value(d));
    EXPECT_EQ(s.slope, b.slope(d));
  }
}

TEST(Profile, IsC1AtControlPointsAndKnots) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    const Profile p = random_profile(rng, 3 + trial % 8);
    const float scale = std::max(1.0f, p.max_slope());
    std::vector<float> joins;
    const auto pts = p.points();
    for (std::size_t k = 0; k < pts.size(); ++k) {
      joins.push_back(pts[k].d);
      if (k + 1 < pts.size()) joins.push_back(0.5f * (pts[k].d + pts[k + 1].d));
    }
    for (float x : joins) {
      const float eps = 1e-3f;
      const ProfileSample l = p.sample(x - eps), r = p.sample(x + eps);
      // Continuous value and slope: the one-sided samples differ by O(eps).
      EXPECT_NEAR(l.value, r.value, 2.5f * eps * scale) << "at d = " << x;
      EXPECT_NEAR(l.slope, r.slope, 0.05f * scale) << "at d = " << x;
    }
  }
}

TEST(Profile, SlopeMatchesCentralDifferences) {
  std::mt19937 rng(4);
  for (int trial = 0; trial < 10; ++trial) {
    const Profile p = random_profile(rng, 4 + trial);
    const float h = 1e-3f;
    for (float d : dense(p, 1000)) {
      const float fd = (p.value(d + h) - p.value(d - h)) / (2.0f * h);
      EXPECT_NEAR(p.slope(d), fd, 0.02f * std::max(1.0f, p.max_slope())) << "at d = " << d;
    }
  }
}

TEST(Profile, NeverOvershootsNeighbouringControlValues) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 30; ++trial) {
    const Profile p = random_profile(rng, 2 + trial % 20);
    const auto pts = p.points();
    for (std::size_t k = 0; k + 1 < pts.size(); ++k) {
      const float lo = std::min(pts[k].h, pts[k + 1].h), hi = std::max(pts[k].h, pts[k + 1].h);
      for (int i = 0; i <= 200; ++i) {
        const float d = pts[k].d + (pts[k + 1].d - pts[k].d) * static_cast<float>(i) / 200.0f;
        const float v = p.value(d);
        EXPECT_GE(v, lo - 1e-5f);
        EXPECT_LE(v, hi + 1e-5f);
      }
    }
  }
}

TEST(Profile, IsConstantWithZeroSlopeBeyondTheEnds) {
  const Profile p = make({{-2.0f, 1.0f}, {0.0f, -3.0f}, {1.5f, 2.0f}});
  for (float d : {-100.0f, -2.5f, -2.0f}) {
    EXPECT_EQ(p.value(d), 1.0f);
    EXPECT_EQ(p.slope(d), 0.0f);
  }
  for (float d : {1.5f, 1.6f, 1e6f}) {
    EXPECT_EQ(p.value(d), 2.0f);
    EXPECT_EQ(p.slope(d), 0.0f);
  }
  EXPECT_EQ(p.domain().lo, -2.0f);
  EXPECT_EQ(p.domain().hi, 1.5f);
  EXPECT_EQ(p.half_extent(), 2.0f);
}

TEST(Profile, RangeAndMaxSlopeAreExactOnDenseSamples) {
  std::mt19937 rng(6);
  for (int trial = 0; trial < 20; ++trial) {
    const Profile p = random_profile(rng, 2 + trial % 12);
    const Interval range = p.range();
    const float max_slope = p.max_slope();
    float lo = INFINITY, hi = -INFINITY, smax = 0.0f;
    for (float d : dense(p, 20000)) {
      const ProfileSample s = p.sample(d);
      lo = std::min(lo, s.value);
      hi = std::max(hi, s.value);
      smax = std::max(smax, std::abs(s.slope));
    }
    EXPECT_LE(range.lo, lo + 1e-5f);
    EXPECT_GE(range.hi, hi - 1e-5f);
    EXPECT_NEAR(range.lo, lo, 1e-4f);  // exact: attained at control points
    EXPECT_NEAR(range.hi, hi, 1e-4f);
    EXPECT_GE(max_slope * (1.0f + 1e-5f), smax);
    EXPECT_NEAR(max_slope, smax, 0.01f * max_slope + 1e-5f);  // exact up to sampling
  }
}

TEST(Profile, IntervalBoundsHoldOnDenseSamples) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> where(-7.0f, 30.0f);
  for (int trial = 0; trial < 200; ++trial) {
    const Profile p = random_profile(rng, 2 + trial % 15);
    float a = where(rng), b = where(rng);
    if (a > b) std::swap(a, b);
    const Interval range = p.range({a, b});
    const float max_slope = p.max_slope({a, b});
    float lo = INFINITY, hi = -INFINITY, smax = 0.0f;
    for (int i = 0; i <= 2000; ++i) {
      const float d = a + (b - a) * static_cast<float>(i) / 2000.0f;
      const ProfileSample s = p.sample(d);
      lo = std::min(lo, s.value);
      hi = std::max(hi, s.value);
      smax = std::max(smax, std::abs(s.slope));
    }
    EXPECT_LE(range.lo, lo + 1e-5f);
    EXPECT_GE(range.hi, hi - 1e-5f);
    EXPECT_NEAR(range.lo, lo, 1e-3f + 1e-3f * (b - a) * max_slope);
    EXPECT_NEAR(range.hi, hi, 1e-3f + 1e-3f * (b - a) * max_slope);
    EXPECT_GE(max_slope * (1.0f + 1e-5f) + 1e-6f, smax);
    EXPECT_LE(max_slope, p.max_slope());
  }
  const Profile p = random_profile(rng, 5);
  EXPECT_TRUE(p.range(Interval{}).empty());
  EXPECT_EQ(p.max_slope(Interval{}), 0.0f);
}

TEST(Profile, MaxSlopeIsALipschitzBoundOnRandomPairs) {
  std::mt19937 rng(10);
  std::uniform_real_distribution<float> where(-8.0f, 30.0f), step(-0.5f, 0.5f);
  for (int trial = 0; trial < 20; ++trial) {
    const Profile p = random_profile(rng, 2 + trial % 15);
    const float lip = p.max_slope();
    for (int i = 0; i < 2000; ++i) {
      const float a = where(rng);
      const float b = i % 2 ? where(rng) : a + step(rng);
      EXPECT_LE(std::abs(p.value(a) - p.value(b)), lip * std::abs(a - b) * (1.0f + 1e-5f) + 1e-5f);
    }
  }
}

TEST(Profile, BlendInterpolatesValuesAndSlopes) {
  std::mt19937 rng(8);
  const Profile a = random_profile(rng, 6);
  const Profile b = random_profile(rng, 9);
  std::vector<float> pool;
  a.pack(pool);
  const std::size_t ob = pool.size();
  b.pack(pool);
  for (float t : {0.0f, 0.25f, 0.5f, 1.0f}) {
    for (float d : dense(a, 500)) {
      const ProfileBlendSample s = profile_blend_eval(pool.data(), pool.data() + ob, d, t);
      EXPECT_NEAR(s.value, (1.0f - t) * a.value(d) + t * b.value(d), 1e-5f);
      EXPECT_NEAR(s.slope, (1.0f - t) * a.slope(d) + t * b.slope(d), 1e-5f);
      EXPECT_FLOAT_EQ(s.dt, b.value(d) - a.value(d));
      const float h = 1e-2f;
      const float fd_t = (profile_blend_eval(pool.data(), pool.data() + ob, d, t + h).value -
                          profile_blend_eval(pool.data(), pool.data() + ob, d, t - h).value) /
                         (2.0f * h);
      EXPECT_NEAR(s.dt, fd_t, 1e-3f);
    }
  }
}

TEST(Profile, DifferenceBoundsHoldOnDenseSamples) {
  std::mt19937 rng(9);
  for (int trial = 0; trial < 30; ++trial) {
    const Profile a = random_profile(rng, 2 + trial % 9);
    const Profile b = random_profile(rng, 2 + (trial * 7) % 11);
    const Interval diff = profile_difference(a, b);
    const float dslope = profile_difference_max_slope(a, b);
    float lo = INFINITY, hi = -INFINITY, smax = 0.0f;
    for (int i = 0; i <= 40000; ++i) {
      const float d = -8.0f + 50.0f * static_cast<float>(i) / 40000.0f;
      const float v = b.value(d) - a.value(d);
      lo = std::min(lo, v);
      hi = std::max(hi, v);
      smax = std::max(smax, std::abs(b.slope(d) - a.slope(d)));
    }
    EXPECT_LE(diff.lo, lo + 1e-5f);
    EXPECT_GE(diff.hi, hi - 1e-5f);
    EXPECT_NEAR(diff.lo, lo, 1e-3f);
    EXPECT_NEAR(diff.hi, hi, 1e-3f);
    EXPECT_GE(dslope * (1.0f + 1e-5f), smax);
    EXPECT_NEAR(dslope, smax, 0.01f * dslope + 1e-4f);
    const Interval part = profile_difference(a, b, {0.0f, 1.0f});
    EXPECT_GE(part.lo, diff.lo);
    EXPECT_LE(part.hi, diff.hi);
  }
}

TEST(ProfilePreset, StreamIsDeepestAtTheCentreAndZeroAtTheBanks) {
  const Profile p = Profile::stream(4.0f, 1.5f).value();
  EXPECT_EQ(p.value(0.0f), -1.5f);
  EXPECT_EQ(p.slope(0.0f), 0.0f);
  EXPECT_EQ(p.value(-2.0f), 0.0f);
  EXPECT_EQ(p.value(2.0f), 0.0f);
  EXPECT_EQ(p.value(10.0f), 0.0f);
  EXPECT_EQ(p.range().lo, -1.5f);
  EXPECT_EQ(p.range().hi, 0.0f);
  // Symmetric and monotone on each side.
  for (int i = 0; i <= 200; ++i) {
    const float d = 0.01f * static_cast<float>(i);
    EXPECT_NEAR(p.value(d), p.value(-d), 1e-6f);
    EXPECT_GE(p.slope(d), 0.0f);
  }
}

TEST(ProfilePreset, RiverHasAFlatishBedAndBanksReachingZero) {
  const Profile p = Profile::river(20.0f, 3.0f, 5.0f).value();
  EXPECT_EQ(p.value(0.0f), -3.0f);
  // The bed (|d| ≤ 10) stays within 10% of the depth and is gentle; the banks are steep.
  for (int i = -100; i <= 100; ++i) {
    const float d = 0.1f * static_cast<float>(i);
    EXPECT_LE(p.value(d), -0.9f * 3.0f + 1e-5f);
    EXPECT_LE(std::abs(p.slope(d)), 0.1f);
  }
  EXPECT_EQ(p.value(15.0f), 0.0f);
  EXPECT_EQ(p.value(-15.0f), 0.0f);
  EXPECT_EQ(p.half_extent(), 15.0f);
  EXPECT_GT(p.max_slope(), 0.5f);
}

TEST(ProfilePreset, MeanderPutsTheCutBankOnTheAsymmetrySide) {
  const Profile left = Profile::meander(20.0f, 3.0f, 6.0f, 0.8f).value();
  const Profile right = Profile::meander(20.0f, 3.0f, 6.0f, -0.8f).value();
  const Profile sym = Profile::meander(20.0f, 3.0f, 6.0f, 0.0f).value();
  const Profile river = Profile::river(20.0f, 3.0f, 6.0f).value();
  const Interval pos{0.0f, 100.0f}, neg{-100.0f, 0.0f};
  EXPECT_GT(left.max_slope(pos), 2.0f * left.max_slope(neg));  // steep cut bank on the left
  EXPECT_GT(right.max_slope(neg), 2.0f * right.max_slope(pos));
  for (int i = -50; i <= 50; ++i) {
    const float d = 0.5f * static_cast<float>(i);
    EXPECT_NEAR(left.value(d), right.value(-d), 1e-6f);  // mirror images
    EXPECT_EQ(sym.value(d), river.value(d));
  }
  // The deepest point moves towards the cut bank.
  EXPECT_EQ(left.value(0.8f * 5.0f), -3.0f);
  EXPECT_EQ(left.range().lo, -3.0f);
  EXPECT_GT(left.domain().lo, -100.0f);
  EXPECT_LT(left.domain().hi, 20.0f);
  EXPECT_LT(left.domain().lo, -20.0f);  // gentle point bar is wider
}

TEST(ProfilePreset, RoadCarriagewayIsFlat) {
  const Profile p = Profile::road(10.0f, 7.0f, 4.0f).value();
  for (int i = -180; i <= 180; ++i) {
    const float d = 0.05f * static_cast<float>(i);
    EXPECT_EQ(p.value(d), 0.0f);
    EXPECT_EQ(p.slope(d), 0.0f);
  }
  EXPECT_EQ(p.half_extent(), 9.0f);
  EXPECT_EQ(p.max_slope(), 0.0f);
}

TEST(ProfilePreset, RoadCrownIsASmoothHumpOnTheCarriagewayOnly) {
  const Profile p = Profile::road(10.0f, 7.0f, 4.0f, 0.1f).value();
  EXPECT_EQ(p.value(0.0f), 0.1f);
  EXPECT_EQ(p.slope(0.0f), 0.0f);
  EXPECT_EQ(p.value(3.5f), 0.0f);
  EXPECT_EQ(p.value(-3.5f), 0.0f);
  for (int i = 70; i <= 200; ++i) {
    const float d = 0.05f * static_cast<float>(i);
    EXPECT_EQ(p.value(d), 0.0f);
    EXPECT_EQ(p.value(-d), 0.0f);
  }
  EXPECT_EQ(p.range().hi, 0.1f);
  EXPECT_EQ(p.range().lo, 0.0f);
  // No shoulders when width == carriageway.
  EXPECT_TRUE(Profile::road(7.0f, 7.0f, 2.0f).ok());
}

struct BadProfile {
  const char* name;
  Result<Profile> result;
  const char* message_part;
  const char* pointer;
};

TEST(ProfileMalformedInput, IsRejectedWithClearMessages) {
  const float nan = std::nanf("");
  std::vector<ProfilePoint> many;
  for (int k = 0; k < 65; ++k) many.push_back({static_cast<float>(k), 0.0f});
  const std::vector<ProfilePoint> one{{0.0f, 0.0f}};
  const std::vector<ProfilePoint> decreasing{{0.0f, 0.0f}, {2.0f, 1.0f}, {1.0f, 0.0f}};
  const std::vector<ProfilePoint> repeated{{0.0f, 0.0f}, {1.0f, 1.0f}, {1.0f, 0.0f}};
  const std::vector<ProfilePoint> nan_d{{0.0f, 0.0f}, {nan, 1.0f}};
  const std::vector<ProfilePoint> inf_h{{0.0f, 0.0f}, {1.0f, INFINITY}};
  BadProfile cases[] = {
      {"one point", Profile::custom(one), "at least 2 points", "/points"},
      {"65 points", Profile::custom(many), "at most 64 points", "/points"},
      {"decreasing d", Profile::custom(decreasing), "strictly increasing", "/points/2"},
      {"repeated d", Profile::custom(repeated), "strictly increasing", "/points/2"},
      {"NaN d", Profile::custom(nan_d), "not finite", "/points/1"},
      {"infinite h", Profile::custom(inf_h), "not finite", "/points/1"},
      {"stream width 0", Profile::stream(0.0f, 1.0f), "stream: width must be positive", "/width"},
      {"stream depth < 0", Profile::stream(2.0f, -1.0f), "stream: depth", "/depth"},
      {"river NaN depth", Profile::river(2.0f, nan, 1.0f), "river: depth", "/depth"},
      {"river bank 0", Profile::river(2.0f, 1.0f, 0.0f), "river: bank_width", "/bank_width"},
      {"meander asymmetry 2", Profile::meander(2.0f, 1.0f, 1.0f, 2.0f),
       "meander: asymmetry must be in [-1, 1]", "/asymmetry"},
      {"meander NaN asymmetry", Profile::meander(2.0f, 1.0f, 1.0f, nan), "meander: asymmetry",
       "/asymmetry"},
      {"road width < carriageway", Profile::road(5.0f, 7.0f, 2.0f),
       "road: width must be finite and >= carriageway", "/width"},
      {"road embankment 0", Profile::road(10.0f, 7.0f, 0.0f), "road: embankment", "/embankment"},
      {"road carriageway inf", Profile::road(10.0f, INFINITY, 1.0f), "road: carriageway",
       "/carriageway"},
      {"road huge crown", Profile::road(10.0f, 7.0f, 2.0f, 1.0f), "road: crown", "/crown"},
  };
  for (const BadProfile& c : cases) {
    ASSERT_FALSE(c.result.ok()) << c.name;
    EXPECT_NE(c.result.error().message.find(c.message_part), std::string::npos)
        << c.name << ": " << c.result.error().message;
    EXPECT_EQ(c.result.error().pointer, c.pointer) << c.name;
  }
}

}  // namespace
}  // namespace terrain
