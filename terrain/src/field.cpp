#include "terrain/field.hpp"

#include <algorithm>

namespace terrain {

void PointBlock::recompute_box() {
  Box2 b;
  for (int i = 0; i < count; ++i) b = b.with({x[i], y[i]});
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

}  // namespace terrain
