// Reads a curve skeleton — "pieces" (segments and quadratic/cubic Béziers of [x, y, z] points) and
// "tolerance" — shared by the curve primitive and images mapped along a curve.
#pragma once

#include "field_reader.hpp"
#include "terrain/polyline.hpp"

namespace terrain {

Result<Polyline> read_skeleton(FieldReader& reader);

}  // namespace terrain
