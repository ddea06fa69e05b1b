// The base mesh (Derzapf et al. 2011 §4): the octahedron bisected to B levels with randomised
// vertex positions (eq. 2) on the sphere (eq. 1); continents grown face by face to the land
// fraction; coasts labelled; river networks grown from the mouths in seeded order with ground
// and water altitudes (eqs. 3–4); then every level-B edge split once (two more levels), which
// inserts the mountain vertices between rivers (eq. 5). Deterministic from the definition alone.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "planet/continent_map.hpp"
#include "planet/mesh.hpp"

namespace planet {

/// The octahedron's four vertices on the equator are the hierarchy's cone points: four triangles
/// meet at each where the bisection's pattern has eight meet elsewhere, so the triangles around
/// them shrink level after level (planet.md "The cone points"). A level-B face with a corner
/// within this many radians of one is sea on every planet, grown or mapped: land there would be
/// slivers whose drain floors cost a tile seconds.
inline constexpr double kConePointSea = 0.05;

/// Whether the unit vector p lies within kConePointSea of a cone point.
bool near_cone_point(const Vec3d& p);

/// Whether a corner of triangle t of h lies within kConePointSea of a cone point: the faces
/// that stay sea.
bool touches_cone_point(const Hierarchy& h, const Tri& t);

struct BuildOptions {
  /// Threads for the vertex computations of the bisection levels. The result does not depend
  /// on it: each split is a pure function of its diamond and is linked in a fixed order.
  int threads = 1;
};

struct BaseMeshStats {
  int river_faces = 0;         ///< faces of the level-B mesh continents and rivers live on
  int mesh_faces = 0;          ///< faces after the mountain levels (what refinement starts from)
  double land_fraction = 0.0;  ///< land area over the sphere's, on the level-B faces
  /// Continents seeded (islands started when others were blocked); with a continent map, its
  /// connected land components.
  int continents = 0;
  int mouths = 0;
  int river_vertices = 0;              ///< continental vertices on a river (all of them, §4.2)
  int endorheic = 0;                   ///< river ends that could not reach the sea
  int lakes = 0;                       ///< lakes (base_mesh.cpp "Lakes")
  int closed_lakes = 0;                ///< of those, kept without an outflow by the climate
  double longest_river = 0.0;          ///< metres along the base network
  double largest_drainage_area = 0.0;  ///< m², the largest river's at its mouth
};

class BaseMesh {
 public:
  Rules rules;
  Hierarchy hierarchy;                    ///< levels 0 … B + 2, every diamond split
  std::vector<std::int32_t> leaves;       ///< the level B + 2 triangles
  std::vector<std::int32_t> river_faces;  ///< the level-B triangles
  /// Per vertex of the level-B mesh: the next vertex downstream, −1 for none (sea, coast that
  /// is no mouth, river mouths).
  std::vector<std::int32_t> downstream;
  BaseMeshStats stats;

  explicit BaseMesh(const PlanetDefinition& definition) : rules(definition), hierarchy(&rules) {}
  BaseMesh(const BaseMesh&) = delete;  // the hierarchy points at rules
  BaseMesh& operator=(const BaseMesh&) = delete;

  /// SHA-256 (hex) of every vertex's and triangle's data, in creation order.
  std::string hash() const;
};

/// `map`: null for random continents (§4.1); else the land faces are where the map says
/// (ContinentMap::land at each level-B face's centre), and the definition's continents and
/// land_fraction are ignored. The caller makes sure the map is the one the definition names
/// (Planet::build checks it).
std::unique_ptr<BaseMesh> build_base_mesh(const PlanetDefinition& definition,
                                          const BuildOptions& options = {},
                                          const ContinentMap* map = nullptr);

}  // namespace planet
