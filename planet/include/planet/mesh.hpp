// The planet's mesh hierarchy (Derzapf et al. 2011 §3, §4, §5.3), made order-independent.
//
// Every level is a conforming triangulation of the sphere in which each triangle is paired with
// the neighbour across its "base" edge: the pair is a diamond. Refinement splits whole diamonds:
// the edge split of Figure 2, with v_ev1, v_ev2 the base's ends and v_t, v_d the two apexes.
// The new vertex may lie anywhere inside the diamond (eq. 2, eq. 7) because the four new
// triangles fan out from it to the diamond's unchanged outline, so they tile exactly the area
// the two old triangles covered. The new triangles' bases are the old outline edges, shared with
// the neighbouring diamond's new triangles: the next level is again a set of diamonds. Starting
// from the octahedron (four diamonds around the equator) every level doubles the face count.
//
// Why this makes tiles pure functions: a new vertex is computed from the four diamond vertices
// only, its seed is mix(s_ev1 + s_ev2) (the paper's sum of endpoint seeds, then a 64-bit
// finaliser so that sums of sums do not collide), and the roles of ev1/ev2 are ordered by seed.
// So every vertex at every level is a function of the base mesh alone, whichever diamonds were
// split before and in what order: the split level of the paper is the diamond's level here.
// A point's height at level L is found by descending from the octahedron face holding it,
// splitting (lazily, memoised in a Hierarchy) only the diamonds on its way and those whose
// vertices they need.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "planet/definition.hpp"
#include "planet/geodesy.hpp"

namespace planet {

/// What a vertex is; a river mouth is coast and river at once (§3.2: "vertices have all the
/// types of their incident edges").
enum VertexFlags : std::uint8_t {
  kSea = 1,    ///< under the sea
  kCoast = 2,  ///< on the coastline (ground at sea level, or a river mouth below it)
  kLand = 4,   ///< continental
  kRiver = 8,  ///< on a river: water above the ground (a spring: water equals ground)
  /// On a lake (base_mesh.hpp "Lakes"): its shore (ground at the lake's level, or its outlet, a
  /// river leaving below it) or its floor; the water stands at the lake's level.
  kLake = 16,
};

/// `drain`: a land edge its higher end drains along (to the lower end), so that every dry
/// vertex has a strictly lower neighbour at every level and the surface has no pits.
/// `lake`: between two lake faces; `shore`: between a lake face and a land face (a lake's coast).
enum class EdgeType : std::uint8_t { sea, coast, land, river, drain, lake, shore };
/// `lake`: water stands over the whole face at its corners' level (a lake on a continent).
enum class FaceType : std::uint8_t { sea, land, lake };

struct Vertex {
  Vec3d p{};               ///< unit direction from the centre (eq. 1 without the altitude)
  std::uint64_t seed = 0;  ///< s_v; a split's vertex gets mix(s_ev1 + s_ev2)
  double ground = 0.0;     ///< a_v, metres relative to the reference surface
  double water = 0.0;      ///< w_v; the vertex is submerged where w_v > a_v
  /// A tangent vector at p, one field for two kinds of vertex (a river is never dry land, and
  /// this keeps the vertex at 72 bytes, which the descent's cache misses feel):
  /// - rivers: the unit downstream direction (eq. 9's t_v);
  /// - dry land: the ground's slope (metres per metre), the gradient of the plane that best fits
  ///   the vertex and its four neighbours when it was made (smooth_surface.hpp: ground_slope).
  std::array<float, 3> tangent{};
  std::uint8_t flags = kSea;
  /// Land: hectometres to the nearest sea coast along the mesh, saturating at 65 535 (coastal
  /// plains follow it: Rules::coastal_factor). Sea vertices keep theirs in drainage_area.
  std::uint16_t coast_hm = 0;
  /// Weight of the fractal detail: the region's ruggedness on dry land (Rules::region), 0 on
  /// water and rivers.
  float detail = 0.0f;
  /// Rivers: the area they drain (m²), the base level's land upstream of the vertex and its own
  /// share; a river split's vertex drains what its upstream end does, a new arm's spring 0.
  /// Sea: metres to the nearest coast along the mesh (what the continental shelves follow).
  float drainage_area = 0.0f;
};
static_assert(sizeof(Vertex) <= 72, "a larger vertex slows the descent (Vertex::tangent)");

/// Water stands on or flows through the vertex: sea, coast, river (springs included), or water
/// above its ground.
inline bool wet(const Vertex& v) {
  return (v.flags & (kRiver | kCoast | kSea | kLake)) != 0 || v.water > v.ground;
}

/// std::clamp(x, 0.0, 1.0), the same for every x (NaN and −0 included), written as the max and
/// min that compilers turn into single instructions; std::clamp's form became masks and blends
/// in vectorised loops (drawing the drainage floors).
inline double clamp01(double x) {
  return std::min(std::max(x, 0.0), 1.0);
}

/// 3x² − 2x³ of x clamped to [0, 1]: rises from 0 to 1 with no slope at either end.
inline double smoothstep(double x) {
  x = clamp01(x);
  return x * x * (3.0 - 2.0 * x);
}

/// Metres from a vertex to the nearest sea coast along the mesh (0 on it), from either side.
inline double coast_distance(const Vertex& v) {
  return (v.flags & kSea) != 0 ? static_cast<double>(v.drainage_area) : 100.0 * v.coast_hm;
}

/// The height water leaves a vertex at: its surface where wet, else its ground.
inline double outflow_level(const Vertex& v) {
  return wet(v) ? std::max(v.water, v.ground) : v.ground;
}

/// A triangle (v0, v1, v2), counter-clockwise seen from outside; (v0, v1) is its base.
struct Tri {
  std::array<std::uint32_t, 3> v{};
  /// Triangle across edge k: k = 0 the base (v0, v1), 1 (v1, v2), 2 (v2, v0); −1 not yet known
  /// (only the base's: the partner is created when the neighbouring diamond is split).
  std::array<std::int32_t, 3> nb{-1, -1, -1};
  std::array<std::int32_t, 2> child{-1, -1};  ///< child 0 = (v2, v0, m), child 1 = (v1, v2, m)
  std::int32_t parent = -1;
  std::uint8_t level = 0;
  std::uint8_t which = 0;  ///< which child of the parent
  std::array<EdgeType, 3> edge{EdgeType::sea, EdgeType::sea, EdgeType::sea};
  FaceType face = FaceType::sea;
};

/// Constants of the split rules, derived from a definition once.
struct Rules {
  PlanetDefinition def;
  double radius = 0.0;  ///< metres per radian of arc
  int base_level = 0;   ///< B: the level continents and rivers are built on
  int mesh_level = 0;   ///< B + 2: the stored base mesh (every level-B edge split once)
  int max_level = 0;    ///< refinement stops here (edges about finest_edge long)
  /// The open sea's finest level (edges about kSeaFinestEdge long, at least the stored mesh's):
  /// sea splits of its triangles and finer ones take the mean of their edge's ends, and a sample
  /// in open sea takes the surface of the first open-sea triangle of its descent at this level
  /// or finer (Hierarchy::open_sea), however fine a level it asks for (planet.md "The cone
  /// points").
  int sea_finest_level = 0;
  double roughness_scale = 0.0;

  explicit Rules(const PlanetDefinition& definition);
  /// Random displacement scale for an edge of length l metres: amplitude·(l/wavelength)^H.
  double roughness(double length) const;
  /// Typical edge length at a level (metres).
  double edge_length(int level) const;
  /// The least rise of a new land vertex over the corner it drains to, for an edge of l metres:
  /// min_drain_slope·l, times the region's ruggedness where that is above 1 (rugged land drains
  /// as steeply as it is rough, or its roughness makes pits), capped at a tenth of
  /// max_mountain_altitude (refine.cpp).
  double drain_rise(double length, double ruggedness = 1.0) const;
  /// How far the sea floor rises above the chord between two points l metres apart across a
  /// shelf's edge, where the continental slope begins: a quarter of the slope times l (0 without
  /// shelves).
  double shelf_break_relief(double length) const;
  /// The relief region at a direction (planet.md "Relief regions").
  struct Region {
    /// Factor of the roughness: below 1 on plains, about 1 on hills, up to max_ruggedness()
    /// along mountain belts; exactly 1 everywhere when relief_contrast is 0.
    double ruggedness = 1.0;
    /// Metres the belts and plateaus lift dry land here: belt_height on a belt's crest,
    /// plateau_height on a plateau, 0 away from both.
    double uplift = 0.0;
  };
  /// `coast_distance`: metres from the coast (coast_distance(vertex)); on the coastal plains the
  /// ruggedness is smaller by coastal_factor. The default is inland.
  Region region(const Vec3d& p,
                double coast_distance = std::numeric_limits<double>::infinity()) const;
  /// Factor of the ruggedness at a distance (metres) from the coast: below 1 on the coastal
  /// plains within coastal_plain_width, 1 beyond (planet.md "Relief regions").
  double coastal_factor(double coast_distance) const;
  double max_ruggedness() const;
  /// How dry the climate is at a direction, 0 (wet) to 1 (dry): the subtropical belts of high
  /// pressure around 25° of latitude and a seeded regional field (planet.md "Lakes"). A lake is
  /// closed where dryness ≥ 1 − aridity.
  double dryness(const Vec3d& p) const;
  /// Splits of edges at least this long add the belts' and plateaus' uplift (finer ones inherit
  /// it).
  double uplift_finest_edge() const { return def.belt_wavelength / 80.0; }
};

/// What splitting a diamond produces, besides the topology.
struct SplitResult {
  Vertex m;
  EdgeType half_a, half_b;    ///< (ev1, m) and (m, ev2)
  EdgeType spoke_t, spoke_d;  ///< (m, t) and (m, d)
  /// angle(m.p, X) to ev1, ev2, t and d, where the split measured them (has_corner_angles:
  /// every dry vertex's split does): split_diamond reuses them instead of calling atan2 again.
  std::array<double, 4> corner_angle{};
  bool has_corner_angles = false;
};

/// The split rules of §3.2, §4.1 and §5.3 for the diamond (a, b; t, d): a, b the base's ends, t
/// the apex of the triangle (a, b, t) and d of (b, a, d). A pure function of its arguments, and
/// symmetric: swapping (a, b) together with (t, d) gives the same vertex.
SplitResult split_diamond(const Rules& rules, int level, const Vertex& a, const Vertex& b,
                          const Vertex& t, const Vertex& d, EdgeType base, FaceType face_t,
                          FaceType face_d);

/// A lazily refined hierarchy: a copy of the base mesh plus whatever was split on demand.
/// Splitting is memoised; what a vertex or triangle holds never depends on what else was split.
/// Not thread-safe: one per thread.
class Hierarchy {
 public:
  Hierarchy() = default;
  explicit Hierarchy(const Rules* rules) : rules_(rules) {}

  std::vector<Vertex> vertices;
  std::vector<Tri> tris;

  /// The eight octahedron faces, linked and paired (the four equatorial edges are the bases).
  void make_octahedron(std::uint64_t seed);
  /// Splits t's diamond unless it is split already (and, first, whatever that needs).
  void ensure_split(std::int32_t t);
  /// Makes sure tris[t].nb[0] is known.
  void ensure_partner(std::int32_t t);
  /// Applies a split computed by split_diamond to the diamond (t, partner of t).
  void apply_split(std::int32_t t, const SplitResult& split);
  /// The diamond's inputs for split_diamond.
  SplitResult compute_split(std::int32_t t) const;

  /// The octahedron face holding direction p (ties resolved by the signs' convention).
  std::int32_t root_face(const Vec3d& p) const;
  /// The leaf holding p: the triangle at `level`, or the first open-sea triangle on the way
  /// (open_sea), splitting what is needed on the way.
  std::int32_t locate(const Vec3d& p, int level);
  /// Of the four children of t's split diamond, the one holding p.
  std::int32_t locate_child(std::int32_t t, const Vec3d& p) const;
  /// Whether a descent stops at t whatever level it asks for: t is a sea triangle of the open
  /// sea's finest level or finer (Rules::sea_finest_level) with no corner on a coast. Its
  /// refinement would only add means of its corners, so its own surface is the sea floor there;
  /// every triangle inside it is open sea too.
  bool open_sea(std::int32_t t) const;
  /// The first open-sea triangle on the descent through t (t itself, or its shallowest open-sea
  /// ancestor), or −1 where t is not open sea.
  std::int32_t open_sea_stop(std::int32_t t) const;

  const Rules* rules() const { return rules_; }

 private:
  const Rules* rules_ = nullptr;
};

/// Gnomonic barycentric coordinates of p in the spherical triangle (x, y, z): continuous across
/// shared edges (on an edge they depend on its two ends only).
std::array<double, 3> barycentric(const Vec3d& x, const Vec3d& y, const Vec3d& z, const Vec3d& p);

/// 64-bit finaliser (splitmix64's): the seed mixer and the source of every random number.
constexpr std::uint64_t mix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

/// A deterministic stream of numbers from a seed.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() { return mix64(state_ += 0x9e3779b97f4a7c15ULL); }
  /// Uniform in [0, 1), 53 bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform in [0, n).
  std::uint32_t below(std::uint32_t n) {
    return static_cast<std::uint32_t>((next() >> 32) * n >> 32);
  }

 private:
  std::uint64_t state_;
};

// Small vector helpers on unit directions.
inline Vec3d add(const Vec3d& a, const Vec3d& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
inline Vec3d sub(const Vec3d& a, const Vec3d& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
inline Vec3d scale(const Vec3d& a, double s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
inline double dot(const Vec3d& a, const Vec3d& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double det(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  return dot(cross(a, b), c);
}
Vec3d normalize(const Vec3d& a);
/// Point i of n on a Fibonacci lattice over the unit sphere: every point stands for an equal
/// share of the sphere's area.
inline Vec3d fibonacci_direction(int i, int n) {
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  const double z = 1.0 - 2.0 * (i + 0.5) / n, r = std::sqrt(1.0 - z * z);
  return {r * std::cos(golden * i), r * std::sin(golden * i), z};
}

/// The unit sphere's area (steradians).
inline constexpr double kFourPi = 4.0 * std::numbers::pi;
/// Area of the spherical triangle (a, b, c) on the unit sphere: the excess E, with
/// tan(E/2) = |det| / (1 + a·b + b·c + c·a).
inline double spherical_area(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  return 2.0 * std::atan2(std::abs(det(a, b, c)), 1.0 + dot(a, b) + dot(b, c) + dot(c, a));
}
/// Angle in radians between two unit vectors (stable for tiny angles).
double angle(const Vec3d& a, const Vec3d& b);

}  // namespace planet
