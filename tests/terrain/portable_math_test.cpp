// The portable atan2 that the contour kernel shares with the GLSL evaluators: its stated error
// bound over the whole plane, exact quadrant handling, and the special points kernels reach.
#include "terrain/portable_math.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace terrain {
namespace {

TEST(PortableAtan2, StaysWithinItsStatedErrorOverThePlane) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
  std::uniform_real_distribution<double> log_radius(-20.0, 20.0);
  double worst = 0.0;
  for (int i = 0; i < 2'000'000; ++i) {
    const double a = angle(random), r = std::exp(log_radius(random));
    const auto x = static_cast<float>(r * std::cos(a)), y = static_cast<float>(r * std::sin(a));
    const double exact = std::atan2(static_cast<double>(y), static_cast<double>(x));
    worst = std::max(worst, std::abs(static_cast<double>(portable_atan2(y, x)) - exact));
  }
  EXPECT_LE(worst, 2.7e-7);  // the bound portable_math.hpp states
  EXPECT_GT(worst, 0.0);     // a float result cannot be exact everywhere: the sweep ran
}

TEST(PortableAtan2, IsRelativelyAccurateNearZeroAndExactOnTheAxes) {
  for (float y = 1e-30f; y < 1e-3f; y *= 3.7f) {
    const double exact = std::atan(static_cast<double>(y));
    EXPECT_NEAR(portable_atan2(y, 1.0f), exact, 1e-7 * exact) << y;
  }
  const float pi = std::numbers::pi_v<float>;
  EXPECT_EQ(portable_atan2(0.0f, 1.0f), 0.0f);
  EXPECT_EQ(portable_atan2(1.0f, 0.0f), pi / 2);
  EXPECT_EQ(portable_atan2(-1.0f, 0.0f), -pi / 2);
  EXPECT_EQ(portable_atan2(0.0f, -1.0f), pi);
  EXPECT_EQ(portable_atan2(0.0f, 0.0f), 0.0f);
}

TEST(PortableAtan2, IsOddInYAndMirrorsInX) {
  for (float x : {0.3f, 1.0f, 7.0f}) {
    for (float y : {0.1f, 0.9f, 3.0f}) {
      EXPECT_EQ(portable_atan2(-y, x), -portable_atan2(y, x));
      EXPECT_EQ(portable_atan2(y, -x), std::numbers::pi_v<float> - portable_atan2(y, x));
    }
  }
}

}  // namespace
}  // namespace terrain
