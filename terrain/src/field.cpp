#include "terrain/field.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "terrain/simd.hpp"

namespace terrain {

TERRAIN_SIMD_CLONES void PointBlock::recompute_box() {
  // Minima and maxima per lane over whole groups of kLanes points (a loop GCC vectorises), then
  // over the lanes and the last partial group. Each comparison keeps one of its operands (and
  // skips NaN like Box2::with), so the box does not depend on the grouping.
  constexpr int kLanes = 16;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  float lox[kLanes], loy[kLanes], hix[kLanes], hiy[kLanes];
  std::fill_n(lox, kLanes, kInf);
  std::fill_n(loy, kLanes, kInf);
  std::fill_n(hix, kLanes, -kInf);
  std::fill_n(hiy, kLanes, -kInf);
  int i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    for (int l = 0; l < kLanes; ++l) {
      lox[l] = x[i + l] < lox[l] ? x[i + l] : lox[l];
      loy[l] = y[i + l] < loy[l] ? y[i + l] : loy[l];
      hix[l] = hix[l] < x[i + l] ? x[i + l] : hix[l];
      hiy[l] = hiy[l] < y[i + l] ? y[i + l] : hiy[l];
    }
  }
  Box2 b;
  for (int l = 0; l < kLanes; ++l) b = b.united({{lox[l], loy[l]}, {hix[l], hiy[l]}});
  for (; i < count; ++i) b = b.with({x[i], y[i]});
  box = b;
}

void FieldBlock::clear(int count) {
  std::fill_n(f, count, 0.0f);
  std::fill_n(a, count, 0.0f);
  std::fill_n(fx, count, 0.0f);
  std::fill_n(fy, count, 0.0f);
  std::fill_n(ax, count, 0.0f);
  std::fill_n(ay, count, 0.0f);
}

Interval Falloff::range(Interval distance, float r) {
  // g decreases with distance.
  float g_near, g_far, dg;
  eval(distance.lo, r, g_near, dg);
  eval(distance.hi, r, g_far, dg);
  return {g_far, g_near};
}

float Falloff::lipschitz(Interval distance, float r) {
  const double peak = 1.0 / std::sqrt(5.0);
  // Widened by the float rounding of the distances (the slope is steep in t near the rim).
  const double lo = std::max(0.0, static_cast<double>(distance.lo) * (1.0 - 1e-6) / r);
  const double hi = static_cast<double>(distance.hi) * (1.0 + 1e-6) / r;
  if (!(lo < 1.0)) return 0.0f;  // the whole range lies outside the fall-off (or is NaN)
  const double t = std::clamp(peak, lo, std::min(hi, 1.0));
  const double u = 1.0 - t * t;
  // Rounded up past the float evaluation's error, never above the global peak bound.
  const auto slope = static_cast<float>(6.0 * t * u * u / r * (1.0 + 1e-5) + 1e-30);
  return std::min(slope, lipschitz(r));
}

Interval Falloff::distances_of(float weight, float r) {
  // d = r·√(1 − ∛g), decreasing in g; a weight known to about 1e-7 is widened by 2e-6.
  auto distance = [r](double g) {
    return static_cast<double>(r) *
           std::sqrt(std::max(0.0, 1.0 - std::cbrt(std::clamp(g, 0.0, 1.0))));
  };
  const double w = weight;
  if (!std::isfinite(w)) return {0.0f, std::numeric_limits<float>::infinity()};  // unknown
  if (!(w > 0.0)) return {r * (1.0f - 1e-6f), std::numeric_limits<float>::infinity()};
  return {static_cast<float>(distance(w + 2e-6) * (1.0 - 1e-6)),
          static_cast<float>(distance(w - 2e-6) * (1.0 + 1e-6))};
}

}  // namespace terrain
