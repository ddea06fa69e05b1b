// Affine warp (Génevaux §5.4, Fig 15): places its child, defined in canonical position, with a
// translation, rotation and scale, and optionally scales and offsets its elevation. Consecutive
// transforms are concatenated by the compiler. Used with {"ref": …} children for instancing.
#pragma once

#include <vector>

#include "terrain/node.hpp"

namespace terrain {

const NodeType& transform_node_type();

/// Pool layout of a transform (the compiler composes two of them).
struct AffineParams {
  float inverse[6];  ///< q = A p + b: a00 a01 a10 a11 b0 b1 (parent → child)
  float forward[6];  ///< p = F q + g (child → parent)
  float elevation_scale;
  float elevation_offset;
  float inverse_norm;  ///< spectral norm of A

  static constexpr int kFloats = 15;
  static AffineParams unpack(const float* pool);
  void pack(std::vector<float>& pool) const;
};

/// outer ∘ inner: the child of `inner` seen from the parent of `outer`.
AffineParams compose(const AffineParams& outer, const AffineParams& inner);

}  // namespace terrain
