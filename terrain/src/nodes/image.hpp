// Image primitive (Génevaux §4.2, Fig 8): a heightfield image (16-bit PNG, float TIFF, EXR)
// mapped onto a convex quadrangle by inverse bilinear parametrisation. Its Lipschitz bound is the
// per-axis largest neighbour difference (§7.3.1) times the quad's inverse-Jacobian bound.
#pragma once

#include "terrain/node.hpp"

namespace terrain {
const NodeType& image_node_type();
}
