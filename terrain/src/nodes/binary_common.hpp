// Shared by the binary operators whose B operand acts through its weight (replace, add): the
// weight is clamped to [0, 1] so a blend with Σα > 1 as B still means "fully B".
#pragma once

#include <algorithm>

#include "terrain/field.hpp"
#include "terrain/simd.hpp"

namespace terrain {

/// Clamped weight b = min(α, 1) and its gradient (zero where clamped); branch-free, so the
/// operators' loops over points vectorise.
inline void clamped_weight(const FieldBlock& b, int i, float& w, float& wx, float& wy) {
  const std::uint32_t inside = simd::mask_of(b.a[i] < 1.0f);
  w = simd::select(inside, b.a[i], 1.0f);
  wx = simd::select(inside, b.ax[i], 0.0f);
  wy = simd::select(inside, b.ay[i], 0.0f);
}

/// Upper bound of |x − y| for x, y in the two intervals.
inline float max_difference(Interval a, Interval b) {
  return std::max(std::abs(a.hi - b.lo), std::abs(b.hi - a.lo));
}

/// The bounds of B when it has no weight over the query: the operator then equals A.
inline bool has_no_weight(const NodeBounds& b) {
  return b.weight.hi <= 0.0f;
}

}  // namespace terrain
