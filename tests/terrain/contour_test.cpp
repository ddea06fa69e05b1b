// Contours: the periodic radius spline, polar evaluation and its gradient, the centre condition,
// value and Lipschitz bounds, radial presets and rejection of malformed input.
#include "terrain/contour.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace terrain {
namespace {

constexpr float kPi = 3.14159265358979f;

Profile profile(std::vector<ProfilePoint> points) {
  auto r = Profile::custom(points);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(r).value();
}

Contour make(Vec2 centre, float orientation, std::vector<float> radii,
             std::vector<Profile> profiles) {
  auto r = Contour::build(centre, orientation, radii, profiles);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(r).value();
}

/// A lumpy contour with four different sector profiles sharing the centre value −4.
Contour lumpy() {
  std::vector<Profile> profiles = {
      profile({{0.0f, -4.0f}, {0.6f, -3.0f}, {1.0f, 0.0f}}),
      profile({{0.0f, -4.0f}, {0.3f, -3.8f}, {0.9f, -1.0f}, {1.2f, 0.5f}, {1.5f, 0.0f}}),
      crater_profile(4.0f, 1.5f, 0.4f).value(),
      profile({{0.0f, -4.0f}, {1.0f, 0.0f}, {2.0f, 1.0f}}),
  };
  return make({100.0f, -50.0f}, 0.7f, {40.0f, 55.0f, 30.0f, 45.0f, 60.0f, 35.0f, 50.0f}, profiles);
}

TEST(Contour, CircleWithOneProfileIsRadial) {
  const Profile lake = lake_profile(5.0f, 0.3f).value();
  const Contour c = make({10.0f, 20.0f}, 0.0f, {25.0f, 25.0f, 25.0f}, {lake});
  EXPECT_EQ(c.max_radius_slope(), 0.0f);
  for (int i = 0; i < 100; ++i) {
    const float a = 0.0628f * static_cast<float>(i), r = 0.4f * static_cast<float>(i);
    const ContourSample s = c.sample({10.0f + r * std::cos(a), 20.0f + r * std::sin(a)});
    EXPECT_EQ(s.radius, 25.0f);
    EXPECT_NEAR(s.rho, r / 25.0f, 1e-5f);
    EXPECT_NEAR(s.value, lake.value(r / 25.0f), 1e-5f);
  }
}

TEST(Contour, RadiusInterpolatesTheNodesAndIsPeriodicC1) {
  const std::vector<float> radii{40.0f, 55.0f, 30.0f, 45.0f, 60.0f, 35.0f, 50.0f};
  const Contour c = make({0.0f, 0.0f}, 0.0f, radii, {lake_profile(1.0f, 0.5f).value()});
  const float step = 2.0f * kPi / 7.0f;
  for (int k = 0; k < 7; ++k)
    EXPECT_NEAR(c.radius(step * static_cast<float>(k)), radii[static_cast<std::size_t>(k)], 2e-4f);
  // Periodic: across θ = 0 and beyond 2π.
  const float h = 1e-3f;
  EXPECT_NEAR(c.radius(-h), c.radius(2.0f * kPi - h), 1e-3f);
  EXPECT_NEAR(c.radius(2.0f * kPi + 1.0f), c.radius(1.0f), 1e-3f);
  EXPECT_NEAR(c.radius_slope(-h), c.radius_slope(h), 0.2f);
  // dR/dθ matches central differences everywhere, including the knots.
  for (int i = 0; i < 2000; ++i) {
    const float t = 2.0f * kPi * static_cast<float>(i) / 2000.0f;
    const float fd = (c.radius(t + h) - c.radius(t - h)) / (2.0f * h);
    EXPECT_NEAR(c.radius_slope(t), fd, 0.2f) << "at theta = " << t;
    EXPECT_LE(std::abs(c.radius_slope(t)), c.max_radius_slope() * (1.0f + 1e-5f));
  }
}

TEST(Contour, RadiusNeverOvershootsAndStaysPositive) {
  const std::vector<float> radii{100.0f, 0.5f, 100.0f, 1.0f, 0.5f, 80.0f, 0.1f, 90.0f};
  const Contour c = make({0.0f, 0.0f}, 0.0f, radii, {lake_profile(1.0f, 0.5f).value()});
  EXPECT_EQ(c.radius_range().lo, 0.1f);
  EXPECT_EQ(c.radius_range().hi, 100.0f);
  float lo = INFINITY, hi = 0.0f, slope = 0.0f;
  for (int i = 0; i <= 20000; ++i) {
    const float t = 2.0f * kPi * static_cast<float>(i) / 20000.0f;
    lo = std::min(lo, c.radius(t));
    hi = std::max(hi, c.radius(t));
    slope = std::max(slope, std::abs(c.radius_slope(t)));
  }
  EXPECT_GE(lo, 0.1f - 1e-5f);
  EXPECT_LE(hi, 100.0f + 1e-4f);
  EXPECT_LE(slope, c.max_radius_slope() * (1.0f + 1e-5f));
  EXPECT_GE(slope, 0.99f * c.max_radius_slope());
}

TEST(Contour, OrientationRotatesTheContour) {
  const Contour c =
      make({5.0f, 5.0f}, 0.5f, {10.0f, 20.0f, 20.0f, 20.0f}, {lake_profile(1.0f, 0.5f).value()});
  const ContourSample s = c.sample({5.0f + 10.0f * std::cos(0.5f), 5.0f + 10.0f * std::sin(0.5f)});
  EXPECT_NEAR(s.theta, 0.0f, 1e-5f);
  EXPECT_NEAR(s.radius, 10.0f, 1e-4f);
  EXPECT_NEAR(s.rho, 1.0f, 1e-5f);
  // Angles increase counter-clockwise.
  const ContourSample q =
      c.sample({5.0f + 10.0f * std::cos(0.5f + kPi / 2), 5.0f + 10.0f * std::sin(0.5f + kPi / 2)});
  EXPECT_NEAR(q.theta, kPi / 2, 1e-5f);
  EXPECT_NEAR(q.radius, 20.0f, 1e-4f);
}

TEST(Contour, GradientMatchesCentralDifferences) {
  const Contour c = lumpy();
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> x(0.0f, 200.0f), y(-150.0f, 50.0f);
  const float h = 2e-3f;
  for (int i = 0; i < 5000; ++i) {
    const Vec2 p{x(rng), y(rng)};
    if (length(p - c.centre()) < 0.5f) continue;
    const ContourSample s = c.sample(p);
    const float gx = (c.sample({p.x + h, p.y}).value - c.sample({p.x - h, p.y}).value) / (2 * h);
    const float gy = (c.sample({p.x, p.y + h}).value - c.sample({p.x, p.y - h}).value) / (2 * h);
    EXPECT_NEAR(s.grad.x, gx, 2e-3f) << p.x << ", " << p.y;
    EXPECT_NEAR(s.grad.y, gy, 2e-3f) << p.x << ", " << p.y;
  }
}

TEST(Contour, GradientStaysBoundedAndVanishesAtTheCentre) {
  const Contour c = lumpy();
  const ContourSample centre = c.sample(c.centre());
  EXPECT_EQ(centre.value, -4.0f);
  EXPECT_EQ(centre.grad.x, 0.0f);
  EXPECT_EQ(centre.grad.y, 0.0f);
  float largest = 0.0f;
  for (int i = 0; i < 2000; ++i) {
    const float a = 0.01f * static_cast<float>(i);
    const float r = 1e-4f * static_cast<float>(1 + i % 50);
    const ContourSample s = c.sample(c.centre() + Vec2{r * std::cos(a), r * std::sin(a)});
    largest = std::max(largest, length(s.grad));
  }
  EXPECT_LT(largest, 1e-3f);  // C1 at the centre: the gradient tends to 0
}

TEST(Contour, ValueRangeHoldsOnDenseSamples) {
  const Contour c = lumpy();
  const Interval range = c.range();
  std::mt19937 rng(22);
  std::uniform_real_distribution<float> x(-100.0f, 300.0f), y(-250.0f, 150.0f);
  float lo = INFINITY, hi = -INFINITY;
  for (int i = 0; i < 20000; ++i) {
    const float v = c.sample({x(rng), y(rng)}).value;
    EXPECT_GE(v, range.lo);
    EXPECT_LE(v, range.hi);
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  EXPECT_EQ(range.lo, -4.0f);
  EXPECT_EQ(range.hi, 1.5f);
  EXPECT_LT(lo, -3.9f);
  const Box2 box{{150.0f, 0.0f}, {200.0f, 40.0f}};
  const Interval part = c.range(box);
  for (int i = 0; i < 2000; ++i) {
    std::uniform_real_distribution<float> bx(150.0f, 200.0f), by(0.0f, 40.0f);
    const float v = c.sample({bx(rng), by(rng)}).value;
    EXPECT_GE(v, part.lo);
    EXPECT_LE(v, part.hi);
  }
}

TEST(Contour, LipschitzBoundHoldsOnRandomPairs) {
  const Contour c = lumpy();
  const float lip = c.lipschitz();
  ASSERT_GT(lip, 0.0f);
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> x(-50.0f, 250.0f), y(-200.0f, 100.0f), step(-3.0f, 3.0f);
  float worst = 0.0f;
  for (int i = 0; i < 20000; ++i) {
    const Vec2 p{x(rng), y(rng)};
    const Vec2 q = i % 4 ? p + Vec2{step(rng), step(rng)} : Vec2{x(rng), y(rng)};
    const float dist = length(p - q);
    if (dist < 1e-3f) continue;
    const float ratio = std::abs(c.sample(p).value - c.sample(q).value) / dist;
    worst = std::max(worst, ratio);
    EXPECT_LE(ratio, lip * (1.0f + 1e-4f) + 1e-4f);
    EXPECT_LE(length(c.sample(p).grad), lip * (1.0f + 1e-4f));
  }
  EXPECT_GT(worst, 0.1f * lip);  // and it is not absurdly loose
}

TEST(Contour, BoxLipschitzBoundHoldsInsideTheBox) {
  const Contour c = lumpy();
  std::mt19937 rng(24);
  std::uniform_real_distribution<float> corner(-100.0f, 250.0f), size(1.0f, 60.0f);
  for (int b = 0; b < 40; ++b) {
    const Vec2 lo{corner(rng), corner(rng) - 100.0f};
    const Box2 box{lo, lo + Vec2{size(rng), size(rng)}};
    const float lip = c.lipschitz(box);
    EXPECT_LE(lip, c.lipschitz());
    std::uniform_real_distribution<float> bx(box.lo.x, box.hi.x), by(box.lo.y, box.hi.y);
    for (int i = 0; i < 500; ++i) {
      const Vec2 p{bx(rng), by(rng)};
      EXPECT_LE(length(c.sample(p).grad), lip * (1.0f + 1e-4f) + 1e-6f);
      const Vec2 q{bx(rng), by(rng)};
      const float dist = length(p - q);
      if (dist > 1e-3f) {
        EXPECT_LE(std::abs(c.sample(p).value - c.sample(q).value), lip * dist * 1.0001f + 1e-4f);
      }
    }
  }
  // Far away everything is constant per sector, and the bound decays.
  EXPECT_LT(c.lipschitz(Box2{{5000.0f, 5000.0f}, {5010.0f, 5010.0f}}), 0.01f * c.lipschitz());
}

TEST(Contour, PackedEvaluationEqualsTheContour) {
  const Contour c = lumpy();
  std::vector<float> pool{7.0f, 8.0f};
  const std::size_t offset = pool.size();
  c.pack(pool);
  ASSERT_EQ(pool.size() - offset, c.packed_size());
  const float* packed = pool.data() + offset;
  EXPECT_EQ(packed[0], 100.0f);
  EXPECT_EQ(packed[1], -50.0f);
  EXPECT_EQ(packed[4], 7.0f);
  EXPECT_EQ(packed[5], 4.0f);
  EXPECT_EQ(packed[6], 40.0f);
  EXPECT_EQ(packed[6 + 2 * 4], 60.0f);
  // The first profile block sits right after the offset table.
  EXPECT_EQ(packed[6 + 2 * 7], static_cast<float>(6 + 2 * 7 + 4));
  std::mt19937 rng(25);
  std::uniform_real_distribution<float> x(0.0f, 200.0f), y(-150.0f, 50.0f);
  for (int i = 0; i < 2000; ++i) {
    const Vec2 p{x(rng), y(rng)};
    const ContourSample a = contour_eval(packed, p), b = c.sample(p);
    EXPECT_EQ(a.value, b.value);
    EXPECT_EQ(a.grad.x, b.grad.x);
    EXPECT_EQ(a.rho, b.rho);
  }
}

TEST(ContourPreset, LakeIsDeepestAtTheCentreAndZeroOutside) {
  const Profile p = lake_profile(6.0f, 0.25f).value();
  EXPECT_EQ(p.value(0.0f), -6.0f);
  EXPECT_EQ(p.range().lo, -6.0f);
  EXPECT_FLOAT_EQ(p.value(0.75f), -0.2f * 6.0f);
  for (int i = 0; i <= 100; ++i) {
    const float rho = 1.0f + 0.05f * static_cast<float>(i);
    EXPECT_EQ(p.value(rho), 0.0f);
  }
  for (int i = 0; i < 100; ++i) EXPECT_LT(p.value(0.01f * static_cast<float>(i)), 0.0f);
}

TEST(ContourPreset, CraterHasARaisedRim) {
  const Profile p = crater_profile(8.0f, 2.0f, 0.5f).value();
  EXPECT_EQ(p.value(0.0f), -8.0f);
  EXPECT_EQ(p.value(1.0f), 2.0f);
  EXPECT_EQ(p.range().hi, 2.0f);  // the crest is the highest point
  EXPECT_EQ(p.slope(1.0f), 0.0f);
  EXPECT_EQ(p.value(1.5f), 0.0f);
  EXPECT_EQ(p.value(3.0f), 0.0f);
  EXPECT_GT(p.value(1.2f), 0.0f);
}

TEST(ContourPreset, PlateauIsFlatOnTopAndZeroBeyondTheCliff) {
  const Profile p = plateau_profile(30.0f, 0.4f).value();
  for (int i = 0; i <= 80; ++i) EXPECT_EQ(p.value(0.01f * static_cast<float>(i)), 30.0f);
  EXPECT_NEAR(p.value(1.0f), 15.0f, 1e-4f);
  EXPECT_EQ(p.value(1.2f), 0.0f);
  EXPECT_EQ(p.value(5.0f), 0.0f);
  EXPECT_NEAR(p.max_slope(), 2.0f * 30.0f / 0.4f, 1e-3f);
}

/// The error of a rejected input, or a marker that fails every expectation below.
template <class T>
Error error_of(const Result<T>& r) {
  return r.ok() ? Error{"(accepted)", "(accepted)"} : r.error();
}

struct BadContour {
  const char* name;
  Error error;
  const char* message_part;
  const char* pointer;
};

TEST(ContourMalformedInput, IsRejectedWithClearMessages) {
  const float nan = std::nanf("");
  const Profile lake = lake_profile(5.0f, 0.3f).value();
  const Profile shallow = lake_profile(4.0f, 0.3f).value();
  const Profile negative = profile({{-0.5f, -5.0f}, {1.0f, 0.0f}});
  const std::vector<Profile> one{lake};
  const std::vector<float> ok{10.0f, 10.0f, 10.0f};
  const std::vector<float> many(257, 1.0f);
  const std::vector<float> none;
  const std::vector<Profile> no_profiles;
  const std::vector<Profile> too_many_profiles(65, lake);
  const std::vector<Profile> mismatched{lake, lake, shallow};
  const std::vector<Profile> negative_rho{lake, negative};
  BadContour cases[] = {
      {"two radii", error_of(Contour::build({}, 0.0f, std::vector<float>{1.0f, 2.0f}, one)),
       "3 to 256 radii, got 2", "/radii"},
      {"257 radii", error_of(Contour::build({}, 0.0f, many, one)), "got 257", "/radii"},
      {"no radii", error_of(Contour::build({}, 0.0f, none, one)), "got 0", "/radii"},
      {"zero radius", error_of(Contour::build({}, 0.0f, std::vector<float>{1.0f, 0.0f, 2.0f}, one)),
       "radius 1 must be positive", "/radii/1"},
      {"negative radius",
       error_of(Contour::build({}, 0.0f, std::vector<float>{1.0f, 2.0f, -2.0f}, one)),
       "radius 2 must be positive", "/radii/2"},
      {"NaN radius", error_of(Contour::build({}, 0.0f, std::vector<float>{nan, 2.0f, 2.0f}, one)),
       "radius 0 must be positive and finite", "/radii/0"},
      {"NaN centre", error_of(Contour::build({nan, 0.0f}, 0.0f, ok, one)), "centre is not finite",
       "/centre"},
      {"infinite orientation", error_of(Contour::build({}, INFINITY, ok, one)), "orientation",
       "/orientation"},
      {"no profiles", error_of(Contour::build({}, 0.0f, ok, no_profiles)),
       "1 to 64 profiles, got 0", "/profiles"},
      {"65 profiles", error_of(Contour::build({}, 0.0f, ok, too_many_profiles)), "got 65",
       "/profiles"},
      {"centre mismatch", error_of(Contour::build({}, 0.0f, ok, mismatched)),
       "profile 2 has value -4 at rho = 0 but profile 0 has -5", "/profiles/2"},
      {"negative rho", error_of(Contour::build({}, 0.0f, ok, negative_rho)), "rho >= 0",
       "/profiles/1"},
      {"lake shore 1", error_of(lake_profile(5.0f, 1.0f)), "lake: shore_width must be in (0, 1)",
       "/shore_width"},
      {"lake NaN depth", error_of(lake_profile(nan, 0.2f)), "lake: depth", "/depth"},
      {"crater negative rim", error_of(crater_profile(5.0f, -1.0f, 0.2f)), "crater: rim_height",
       "/rim_height"},
      {"crater zero rim width", error_of(crater_profile(5.0f, 1.0f, 0.0f)), "crater: rim_width",
       "/rim_width"},
      {"plateau cliff 2", error_of(plateau_profile(5.0f, 2.0f)), "plateau: cliff_width",
       "/cliff_width"},
      {"plateau NaN height", error_of(plateau_profile(nan, 0.5f)), "plateau: height", "/height"},
  };
  for (const BadContour& c : cases) {
    EXPECT_NE(c.error.message.find(c.message_part), std::string::npos)
        << c.name << ": " << c.error.message;
    EXPECT_EQ(c.error.pointer, c.pointer) << c.name;
  }
}

}  // namespace
}  // namespace terrain
