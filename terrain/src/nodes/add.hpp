// Addition (Génevaux §5.3): adds B's elevation where B has weight: f = f_A + α_B f_B;
// α = α_A ("keep") or α_A + α_B² ("sum").
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& add_node_type();
}
