// Lakes on the finished base mesh (issue 20 item 2; docs/planet.md "Lakes").
#pragma once

#include "planet/base_mesh.hpp"

namespace planet {

/// Places up to definition.lakes lakes on the base mesh's leaves (level B + 2), in a seeded
/// order: each covers the two triangles of a river edge whose apexes are dry land, with its water
/// at one level W.
/// - Open lakes stand at their outlet's water (the river edge's lower end, which keeps its river
///   downstream): filled to the spill level.
/// - Closed lakes, where Rules::dryness ≥ 1 − aridity, stand below every neighbour outside them
///   and keep no outflow.
/// Lake triangles become FaceType::lake; their inner edge `lake`, their outline `shore`. Lake
/// vertices get kLake with water W: shores and the closed lakes' outlets at ground W, an open
/// lake's outlet with its river's bed below. Only lowers vertices, so no dry vertex loses the
/// lower neighbour it drains to. Deterministic from the definition.
void place_lakes(BaseMesh& mesh);

}  // namespace planet
