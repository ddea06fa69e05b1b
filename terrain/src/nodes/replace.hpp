// Replacement (Génevaux §5.2): B continuously replaces A where B has weight:
// f = (1 − α_B) f_A + α_B f_B; α = α_A ("keep") or (1 − α_B) α_A + α_B² ("progressive").
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& replace_node_type();
}
