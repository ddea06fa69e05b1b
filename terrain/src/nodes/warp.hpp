// Noise domain warp (Génevaux §5.4, Fig 14): evaluates its child at q = p + d(p), where d is a
// 2D fractal displacement. Its Lipschitz bound is kept below 1/√2 so the warp stays bijective
// (as the paper requires) and gradients follow the Jacobian I + ∇d.
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& warp_node_type();
}
