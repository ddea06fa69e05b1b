// Drainage operator (docs/erosion.md, "Drainage"): samples its child subtree on a grid over its
// area, finds its lakes, routes and accumulates flow, and carves channels sized by hydraulic
// geometry into it (terrain/rivers.hpp). The carved grid is shown like the erosion's (bicubic,
// local bounds); the rivers' and lakes' water surface becomes part of the scene's water layer, so
// water masks, samples and the analysis see them.
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& drainage_node_type();
}
