// Bounds of a primitive whose support, elevation range and Lipschitz bounds were computed once at
// parse time (curve, contour, image): inside its support the weight may be anywhere in [0, 1].
#pragma once

#include "terrain/field.hpp"

namespace terrain {

inline NodeBounds stored_bounds(const Box2& support, Interval elevation, float elevation_lipschitz,
                                float weight_lipschitz, const BoundsQuery& query) {
  NodeBounds b;
  b.support = support;
  b.elevation = elevation;
  b.elevation_lipschitz = elevation_lipschitz;
  const bool touches = query.box.intersects(support);
  b.weight = touches ? Interval{0.0f, 1.0f} : Interval{0.0f, 0.0f};
  b.weight_lipschitz = touches ? weight_lipschitz : 0.0f;
  return b;
}

/// A box stored as (lo.x, lo.y, hi.x, hi.y) in the parameter pool.
inline Box2 stored_box(const float* p) {
  return {{p[0], p[1]}, {p[2], p[3]}};
}

}  // namespace terrain
