// Erosion operator (docs/erosion.md): samples its child subtree on a grid over its area, shapes it
// by stream-power incision with uplift, hillslope diffusion, a talus slope and depression deposits
// (terrain/erosion.hpp), and shows the result as an image primitive on that square: bicubic (C1),
// exact gradient, Lipschitz bound from neighbour differences. The grid is made while the scene is
// parsed, so every evaluator (CPU, GPU, browser) reads the same packed floats.
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& erosion_node_type();
}
