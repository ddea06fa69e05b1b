// LoD operator (Génevaux §6): chooses between a coarse child A and a fine child B by the level of
// detail. κ is derived from the sample spacing: κ = 0 (A) at `coarse_spacing` and above, κ = 1 (B)
// at `fine_spacing` and below, log-linear between, smoothed C1. Both f and α are interpolated.
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& lod_node_type();
/// The interpolation parameter t ∈ [0, 1] for a sample spacing.
float lod_blend_factor(const float* params, float spacing);
}  // namespace terrain
