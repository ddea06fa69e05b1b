// Curve primitive (Génevaux §4.1, Fig 6): a skeleton of segments and quadratic/cubic Bézier
// pieces carrying their own elevation z, and cross-section profiles interpolated along it:
// f(p) = z(q) + c(d(p), s(q)), α = g(|d|) with Wyvill's fall-off over `falloff` metres.
// Rivers (stream, river, meander presets) and roads (road preset) are curves.
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& curve_node_type();
}
