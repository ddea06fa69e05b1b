#include "nodes/blend.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "field_reader.hpp"
#include "terrain/scene.hpp"
#include "terrain/simd.hpp"

namespace terrain {
namespace {

constexpr int kThreshold = 0, kBase = 1;

Result<NodeParams> parse_blend(FieldReader& reader, ParseContext& context) {
  NodeParams out;
  // The background's weight is divided by the threshold: below 1e-4 the bounds of a blend whose
  // base is far from its children's heights overflow float32 (docs/scene-format.md).
  const double threshold = reader.number("threshold", 0.5, {1e-4, 1.0});
  // The default background is the scene's base level.
  const double base = reader.number("base", context.base_elevation, {-1e5, 1e5});
  if (!reader.ok()) return reader.error();
  out.pool = {static_cast<float>(threshold), static_cast<float>(base)};
  out.canonical = reader.canonical();
  return out;
}

}  // namespace

void blend_clear(FieldBlock& acc, int count) {
  acc.clear(count);
}

TERRAIN_SIMD_CLONES void blend_accumulate(FieldBlock& acc, const FieldBlock& c, int count) {
  for (int i = 0; i < count; ++i) {
    acc.f[i] += c.a[i] * c.f[i];
    acc.a[i] += c.a[i];
    acc.fx[i] += c.ax[i] * c.f[i] + c.a[i] * c.fx[i];
    acc.fy[i] += c.ay[i] * c.f[i] + c.a[i] * c.fy[i];
    acc.ax[i] += c.ax[i];
    acc.ay[i] += c.ay[i];
  }
}

TERRAIN_SIMD_CLONES void blend_finish(const float* params, FieldBlock& acc, int count) {
  const float threshold = params[kThreshold];
  const float base = params[kBase];
  for (int i = 0; i < count; ++i) {
    // Both cases are computed and one is selected, so the loop vectorises; the other's division
    // by a possibly zero sum is dropped.
    const float sum = acc.a[i];
    const float f = acc.f[i] / sum;
    const float fx = (acc.fx[i] - f * acc.ax[i]) / sum;
    const float fy = (acc.fy[i] - f * acc.ay[i]) / sum;
    const float bf = (acc.f[i] + (threshold - sum) * base) / threshold;
    const float bfx = (acc.fx[i] - base * acc.ax[i]) / threshold;
    const float bfy = (acc.fy[i] - base * acc.ay[i]) / threshold;
    const std::uint32_t weighted = simd::mask_of(sum >= threshold);
    acc.f[i] = simd::select(weighted, f, bf);
    acc.fx[i] = simd::select(weighted, fx, bfx);
    acc.fy[i] = simd::select(weighted, fy, bfy);
  }
}

void BlendBoundsAccumulator::add(const NodeBounds& child) {
  if (child.weight.hi <= 0.0f) return;  // no weight here: no influence
  support = support.united(child.support);
  elevation = elevation.hull(child.elevation);
  weight = {weight.lo + child.weight.lo, weight.hi + child.weight.hi};
  max_elevation_lipschitz = std::max(max_elevation_lipschitz, child.elevation_lipschitz);
  weighted_elevation_lipschitz += child.weight.hi * child.elevation_lipschitz;
  sum_weight_lipschitz += child.weight_lipschitz;
  if (children < kKept) {
    kept[children] = {child.weight, child.elevation, child.elevation_lipschitz,
                      child.weight_lipschitz};
  }
  ++children;
}

namespace {

Interval operator*(Interval a, Interval b) {
  const float p[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
  return {std::min({p[0], p[1], p[2], p[3]}), std::max({p[0], p[1], p[2], p[3]})};
}
Interval operator+(Interval a, Interval b) {
  return {a.lo + b.lo, a.hi + b.hi};
}
// a / d for d ⊂ (0, ∞).
Interval divided(Interval a, Interval d) {
  const float p[4] = {a.lo / d.lo, a.lo / d.hi, a.hi / d.lo, a.hi / d.hi};
  return {std::min({p[0], p[1], p[2], p[3]}), std::max({p[0], p[1], p[2], p[3]})};
}

}  // namespace

// f − m = (Σ α_i (f_i − m) + β (base − m)) / D with D = max(W, T), β = max(T − W, 0), for any m:
// each term is an interval product, so the bound is as tight as the weights and ranges are. m
// is the mean at the middle of every range, where the terms cancel best.
Interval BlendBoundsAccumulator::weighted_mean_range(float threshold, float base) const {
  constexpr Interval kUnknown{-std::numeric_limits<float>::infinity(),
                              std::numeric_limits<float>::infinity()};
  if (children > kKept || children == 0) return kUnknown;
  double num = 0.0, den = 0.0;
  for (int i = 0; i < children; ++i) {
    const double w = 0.5 * (static_cast<double>(kept[i].weight.lo) + kept[i].weight.hi);
    num += w * 0.5 * (static_cast<double>(kept[i].elevation.lo) + kept[i].elevation.hi);
    den += w;
  }
  const auto m = static_cast<float>(den > 0.0 ? num / den : base);
  Interval sum = Interval::point(0.0f);
  for (int i = 0; i < children; ++i) {
    sum = sum + kept[i].weight * Interval{kept[i].elevation.lo - m, kept[i].elevation.hi - m};
  }
  Interval out;  // empty: the hull of the cases that can occur
  if (weight.hi >= threshold) {
    out = out.hull(divided(sum, {std::max(threshold, weight.lo), weight.hi}));
  }
  if (weight.lo < threshold) {
    const Interval background{threshold - std::min(weight.hi, threshold), threshold - weight.lo};
    out =
        out.hull(divided(sum + background * Interval::point(base - m), Interval::point(threshold)));
  }
  if (!std::isfinite(out.lo) || !std::isfinite(out.hi)) return kUnknown;
  // Rounded outwards: relative to the magnitudes the float sums went through.
  const float slack = 1e-5f * (std::abs(m) + std::max(std::abs(out.lo), std::abs(out.hi))) + 1e-6f;
  return {m + out.lo - slack, m + out.hi + slack};
}

// The largest Σ α_i L_i / max(T, Σ α_i) over the weights' ranges: a weighted mean of the L_i once
// Σ α_i ≥ T, so it is largest with the steepest children at their highest weight and the others at
// their lowest. Adding children in order of steepness while the ratio grows finds that maximum
// (the ratio is monotone in each weight alone, so each ends at an end of its range).
float BlendBoundsAccumulator::weighted_slope(float threshold) const {
  int order[kKept];
  for (int i = 0; i < children; ++i) order[i] = i;
  std::sort(order, order + children, [&](int a, int b) {
    return kept[a].elevation_lipschitz > kept[b].elevation_lipschitz;
  });
  double sum = 0.0, total = 0.0;
  for (int i = 0; i < children; ++i) {
    sum += static_cast<double>(kept[i].weight.lo) * kept[i].elevation_lipschitz;
    total += kept[i].weight.lo;
  }
  const double t = threshold;
  double best = sum / std::max(t, total);
  for (int k = 0; k < children; ++k) {
    const Child& c = kept[order[k]];
    const double extra = static_cast<double>(c.weight.hi) - c.weight.lo;
    const double ratio = (sum + extra * c.elevation_lipschitz) / std::max(t, total + extra);
    if (ratio < best) break;  // every later child is less steep
    sum += extra * c.elevation_lipschitz;
    total += extra;
    best = ratio;
  }
  return static_cast<float>(best * (1.0 + 1e-5));
}

NodeBounds BlendBoundsAccumulator::finish(const float* params) const {
  const float threshold = params[kThreshold];
  const float base = params[kBase];
  NodeBounds b;
  b.support = support;
  b.weight = weight;
  b.weight_lipschitz = sum_weight_lipschitz;
  // f is a convex combination of the children's f and the base (see blend.hpp); its gradient is
  // Σ ∇α_i (f_i − f)/W' + Σ α_i ∇f_i / W' with W' = max(W, T) ≥ max(T, lowest W over the
  // region). The second sum is at most max L_i (Σ α_i ≤ W'), and at most Σ α_i,hi L_i / W'.lo,
  // which is far less where the steep children have little weight.
  const bool background = weight.lo < threshold;  // the base may show somewhere in the region
  const Interval hull = background ? elevation.hull(Interval::point(base)) : elevation;
  const Interval mean = weighted_mean_range(threshold, base);
  b.elevation = {std::max(hull.lo, mean.lo), std::min(hull.hi, mean.hi)};
  const float divisor = std::max(threshold, weight.lo);
  float children_slope =
      std::min(max_elevation_lipschitz, weighted_elevation_lipschitz / divisor * 1.00001f);
  // The weights' term is Σ ∇α_i (f_i − f)/W where W ≥ T, and Σ ∇α_i (f_i − base)/T where the
  // background shows: |f_i − ·| is at most the farthest point of f's range (and the base) from
  // child i's range, and at most the width of the hull of them all.
  float spread = sum_weight_lipschitz * hull.width();
  if (children <= kKept) {
    children_slope = std::min(children_slope, weighted_slope(threshold));
    const Interval reference = background ? b.elevation.hull(Interval::point(base)) : b.elevation;
    double per_child = 0.0;
    for (int i = 0; i < children; ++i) {
      const Interval e = kept[i].elevation;
      const double far = std::max(std::abs(static_cast<double>(e.hi) - reference.lo),
                                  std::abs(static_cast<double>(reference.hi) - e.lo));
      per_child += kept[i].weight_lipschitz * far;
    }
    spread = std::min(spread, static_cast<float>(per_child * (1.0 + 1e-5)));
  }
  b.elevation_lipschitz = children_slope + spread / divisor;
  return b;
}

const NodeType& blend_node_type() {
  static const NodeType type{
      .id = 16,
      .name = "blend",
      .category = NodeCategory::blend,
      .min_children = 1,
      .max_children = 0xffff,
      .summary =
          "weighted average of any number of children, fading to a base level where "
          "their weights vanish",
      .parse = parse_blend,
      .kernels = {},
      .example_json = R"({"type": "blend", "threshold": 0.5, "base": 0, "children": [
 {"type": "disc", "center": [-800, 0], "radius": 1500, "elevation": 200,
  "noise": {"kind": "fbm", "amplitude": 80, "wavelength": 600, "seed": 1}},
 {"type": "disc", "center": [800, 0], "radius": 1500, "elevation": 350,
  "noise": {"kind": "fbm", "amplitude": 120, "wavelength": 900, "seed": 2}}]})",
      .loop_iterations = no_loops,
  };
  return type;
}

}  // namespace terrain
