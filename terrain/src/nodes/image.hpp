// Image primitive (Génevaux §4.2, Fig 8): a heightfield image (16-bit PNG, float TIFF, EXR)
// mapped onto a convex quadrangle by inverse bilinear parametrisation. Its Lipschitz bound is the
// per-axis largest neighbour difference (§7.3.1) times the quad's inverse-Jacobian bound.
#pragma once

#include "terrain/node.hpp"

#include <vector>

#include "terrain/heightfield.hpp"

namespace terrain {
const NodeType& image_node_type();

/// The parameters of an image primitive showing `field` on `quad`: nodes that make their own
/// heightfield (erosion) pack it so, and evaluate with the image's kernels and shader call.
std::vector<float> pack_image_on_quad(const Heightfield& field, const QuadMap& quad);
}  // namespace terrain
