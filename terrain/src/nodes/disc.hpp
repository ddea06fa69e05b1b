// Disc primitive (Génevaux §4.1): elevation c_z + fractal noise around a centre, weight by Wyvill's
// fall-off of the distance to the centre. Octaves unravel continuously with the level of detail.
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& disc_node_type();
}
