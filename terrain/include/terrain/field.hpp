// What every node computes: elevation f, weight α and both gradients, for one point or a block of
// points, plus the bounds (support, elevation range, Lipschitz bounds) every node knows.
#pragma once

#include <bit>
#include <cstdint>

#include "terrain/math.hpp"

namespace terrain {

/// Elevation, weight and their gradients at one point.
struct FieldSample {
  float elevation = 0.0f;
  float weight = 0.0f;
  Vec2 elevation_gradient;
  Vec2 weight_gradient;
};

/// Points are evaluated in blocks so node kernels run as vectorisable loops over points.
inline constexpr int kBlockSize = 64;

/// Up to kBlockSize points (structure of arrays), their bounding box and the sample spacing that
/// sets the level of detail (metres between samples; 0 = full detail).
struct PointBlock {
  int count = 0;
  float spacing = 0.0f;
  Box2 box;
  alignas(64) float x[kBlockSize];
  alignas(64) float y[kBlockSize];

  void recompute_box();
};

/// Per-point results for a PointBlock (structure of arrays).
struct FieldBlock {
  alignas(64) float f[kBlockSize];
  alignas(64) float a[kBlockSize];
  alignas(64) float fx[kBlockSize];
  alignas(64) float fy[kBlockSize];
  alignas(64) float ax[kBlockSize];
  alignas(64) float ay[kBlockSize];

  void clear(int count);
  FieldSample at(int i) const { return {f[i], a[i], {fx[i], fy[i]}, {ax[i], ay[i]}}; }
};

/// What a node guarantees over a region (a query box, or the whole plane): f is defined and
/// Lipschitz on the whole plane, α vanishes outside `support`.
struct NodeBounds {
  Box2 support;                      ///< α = 0 outside this box
  Interval elevation;                ///< range of f over the query region
  Interval weight{0, 0};             ///< range of α over the query region
  float elevation_lipschitz = 0.0f;  ///< bound of |∇f| over the query region
  float weight_lipschitz = 0.0f;     ///< bound of |∇α| over the query region
};

/// A region query: bounds over `box` when sampled at any spacing from `spacing` to
/// `coarsest_spacing` metres (coarser spacing drops octaves). Bounds over a box follow what holds
/// there, so they need not shrink with the level of detail: a tracer that reuses one bound over a
/// band of levels (LipschitzGrid) asks for the whole band.
struct BoundsQuery {
  Box2 box = Box2::everywhere();
  float spacing = 0.0f;
  float coarsest_spacing = 0.0f;  ///< below `spacing`: `spacing` alone
  float coarsest() const { return std::max(spacing, coarsest_spacing); }
};

/// Wyvill's C1 fall-off g(d) = (1 − (d/r)²)³ for d < r, else 0 (Génevaux §4.1).
struct Falloff {
  /// g and dg/dd at distance d for radius r.
  static void eval(float d, float r, float& g, float& dg) {
    const float t = d / r;
    // s = t < 1 ? 1 − t² : 0, selected on the bit pattern so loops over points vectorise.
    const std::uint32_t inside = 0u - static_cast<std::uint32_t>(t < 1.0f);
    const float s = std::bit_cast<float>(std::bit_cast<std::uint32_t>(1.0f - t * t) & inside);
    g = s * s * s;
    dg = -6.0f * t * s * s / r;
  }
  /// max |g'| = 96√5 / (125 r) (Génevaux, Appendix).
  static float lipschitz(float r) { return 1.7173003f / r; }
  /// max |g'| over distances in [dmin, dmax]: |g'(d)| = 6t(1 − t²)²/r (t = d/r) rises to its peak
  /// at t = 1/√5 and falls to 0 at t = 1, so near the rim a box's bound is far below the peak.
  static float lipschitz(Interval distance, float r);
  /// The distances at which g could take the value `weight` (widened by its float rounding):
  /// [0, 0] at 1, [r, ∞) at 0.
  static Interval distances_of(float weight, float r);
  /// Range of g over distances in [dmin, dmax].
  static Interval range(Interval distance, float r);
};

}  // namespace terrain
