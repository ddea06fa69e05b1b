// n-ary blend (Génevaux §5.1): f = Σ α_i f_i / Σ α_i, α = Σ α_i. Where Σ α_i falls below the
// threshold T an implicit background of elevation `base` makes up the weight, so f is defined
// and Lipschitz everywhere and fades to the base level outside every child's support:
//   f = (Σ α_i f_i + max(T − Σ α_i, 0)·base) / max(Σ α_i, T).
// Children are accumulated one at a time, which is what lets the compiler group them in a BVH.
#pragma once

#include "terrain/node.hpp"

namespace terrain {

const NodeType& blend_node_type();

/// Accumulator layout in a FieldBlock: f = Σαf, a = Σα, fx/fy = Σ∇(αf), ax/ay = Σ∇α.
void blend_clear(FieldBlock& accumulator, int count);
void blend_accumulate(FieldBlock& accumulator, const FieldBlock& child, int count);
void blend_finish(const float* params, FieldBlock& accumulator, int count);

/// The same for bounds: accumulates children, then yields the blend's bounds.
struct BlendBoundsAccumulator {
  Box2 support;
  Interval elevation;
  Interval weight{0, 0};
  float max_elevation_lipschitz = 0.0f;
  float weighted_elevation_lipschitz = 0.0f;  ///< Σ (highest α_i) · L_i
  float sum_weight_lipschitz = 0.0f;
  /// The weighted children's bounds, kept (up to kKept of them) to bound the weighted mean and
  /// its slope from each child's own weight and range rather than from their sums and hull.
  static constexpr int kKept = 16;
  struct Child {
    Interval weight;
    Interval elevation;
    float elevation_lipschitz = 0.0f;
    float weight_lipschitz = 0.0f;
  };
  Child kept[kKept];
  int children = 0;
  void add(const NodeBounds& child);
  NodeBounds finish(const float* params) const;

 private:
  Interval weighted_mean_range(float threshold, float base) const;
  float weighted_slope(float threshold) const;
};

}  // namespace terrain
