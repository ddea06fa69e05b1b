// Contour primitive (Génevaux §4.1, Fig 7): a closed star-shaped curve around a centre with radial
// profiles by angular sector: f(p) = c_z + c(ρ, θ) with ρ = |p − c| / R(θ); α = g(ρ) with Wyvill's
// fall-off reaching zero at ρ = `falloff`. Lakes, craters and plateaus are contours.
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& contour_node_type();
}
