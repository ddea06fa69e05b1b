// Split rules (Derzapf et al. 2011 §3.2, §4.1, §5.3) and the lazily refined hierarchy.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>

#include "detail_batch.hpp"
#include "gradient_noise.hpp"
#include "planet/mesh.hpp"
#include "planet/smooth_surface.hpp"

namespace planet {
namespace {

// The open sea's floor is refined to edges about this long (Rules::sea_finest_level). Finer, its
// roughness was detail nobody sees under the water, and around the octahedron's cone points,
// where the triangles of every level are twenty times smaller than elsewhere, a zoom-12 tile of
// open sea split 1.5 million of them (0.2 s; planet.md "The cone points").
constexpr double kSeaFinestEdge = 2000.0;

}  // namespace

Vec3d normalize(const Vec3d& a) {
  const double n = std::sqrt(dot(a, a));
  return {a[0] / n, a[1] / n, a[2] / n};
}

double angle(const Vec3d& a, const Vec3d& b) {
  return std::atan2(std::sqrt(dot(cross(a, b), cross(a, b))), dot(a, b));
}

std::array<double, 3> barycentric(const Vec3d& x, const Vec3d& y, const Vec3d& z, const Vec3d& p) {
  const double bx = det(p, y, z), by = det(x, p, z), bz = det(x, y, p);
  const double sum = bx + by + bz;
  return {bx / sum, by / sum, bz / sum};
}

Rules::Rules(const PlanetDefinition& definition) : def(definition) {
  radius = def.radius;
  base_level = def.base_levels();
  mesh_level = base_level + 2;
  max_level = mesh_level;
  while (max_level < 60 && edge_length(max_level) > def.finest_edge) ++max_level;
  sea_finest_level = mesh_level;
  while (sea_finest_level < max_level && edge_length(sea_finest_level + 1) >= kSeaFinestEdge) {
    ++sea_finest_level;
  }
}

double Rules::edge_length(int level) const {
  // The octahedron's edges span a quarter circle; bisection shortens them by √2 per level.
  return radius * std::numbers::pi / 2.0 * std::exp2(-0.5 * level);
}

double Rules::drain_rise(double length, double ruggedness) const {
  // Capped: over a long edge the slope alone would lift a vertex kilometres above its lowest
  // corner, every coarse level would stand far lower than the finer ones under it, and coarse
  // tiles would dip far under the surface their finer children show.
  return std::min(length * def.min_drain_slope * std::max(1.0, ruggedness),
                  0.1 * def.max_mountain_altitude);
}

// The regional field's, the belts' and the plateaus' seeds, apart from every other stream of the
// planet's seed.
constexpr std::uint64_t kRegionSalt = 0x726567696f6eULL, kBeltSalt = 0x62656c7473ULL,
                        kPlateauSalt = 0x706c617465617573ULL;
// ruggedness = exp(contrast · (kRegional·v + kBelt·belt + kScarp·scarp − kTableland·plateau −
// kShift)): v the regional field in [−1, 1], belt, plateau and scarp in [0, 1]; the exponent spans
// [−1.2 − kTableland, 1.8 + kScarp]·contrast.
constexpr double kRegional = 0.7, kBelt = 1.6, kShift = 0.5, kScarp = 0.8, kTableland = 1.5;
// Plateaus stand where their field exceeds kPlateauEdge, rising over the next kPlateauRise of it.
constexpr double kPlateauEdge = 0.3, kPlateauRise = 0.1;

Rules::Region Rules::region(const Vec3d& p, double coast_distance) const {
  if (def.relief_contrast == 0.0 && def.belt_height == 0.0 && def.plateau_height == 0.0) return {};
  // Regions and plateaus vary at half the belts' spacing; belts follow the zero lines of a second
  // field (the ridges of 1 − |S|), narrowed by a sixth power.
  const double regional_scale = 2.0 * radius / def.belt_wavelength;
  const double belt_scale = radius / def.belt_wavelength;
  // The three fields in one evaluation (a split asks for its region once or more, and the
  // noise was a third of a split's cost): the regional field, the belts' and the plateaus'.
  const auto seed = [&](std::uint64_t salt) {
    return static_cast<std::uint32_t>(mix64(def.seed ^ salt));
  };
  const double scale[4] = {regional_scale, belt_scale, regional_scale, regional_scale};
  detail::Four x{}, y{}, z{};
  for (std::size_t i = 0; i < 4; ++i) {
    x[i] = p[0] * scale[i];
    y[i] = p[1] * scale[i];
    z[i] = p[2] * scale[i];
  }
  const detail::Four field = detail::gradient3_fours(
      x, y, z, {seed(kRegionSalt), seed(kBeltSalt), seed(kPlateauSalt), seed(kPlateauSalt)});
  const auto clamped = [&](std::size_t i) { return std::clamp(field[i], -1.0, 1.0); };
  const double v = clamped(0);
  const double ridge = 1.0 - std::abs(clamped(1));
  const double ridge2 = ridge * ridge;
  const double belt = ridge2 * ridge2 * ridge2;
  // A tableland: 0 off it, 1 on its top, a smoothstep across its edge, where the escarpment is.
  const double plateau =
      def.plateau_height > 0.0 ? smoothstep((clamped(2) - kPlateauEdge) / kPlateauRise) : 0.0;
  const double scarp = 4.0 * plateau * (1.0 - plateau);
  return {std::exp(def.relief_contrast * (kRegional * v + kBelt * belt + kScarp * scarp -
                                          kTableland * plateau - kShift)) *
              coastal_factor(coast_distance),
          def.belt_height * belt + def.plateau_height * plateau};
}

// Coastal plains: the ruggedness at the coast is exp(−contrast · kCoastal) of inland's, rising
// to it over coastal_plain_width.
constexpr double kCoastal = 1.5;

double Rules::coastal_factor(double coast_distance) const {
  if (def.coastal_plain_width <= 0.0 || coast_distance >= def.coastal_plain_width) return 1.0;
  const double inland = smoothstep(coast_distance / def.coastal_plain_width);
  return std::exp(-def.relief_contrast * kCoastal * (1.0 - inland));
}

double Rules::max_ruggedness() const {
  return std::exp(def.relief_contrast * (kRegional + kBelt + kScarp - kShift));
}

// The climate's seed, apart from every other stream of the planet's seed; its regional field
// varies over about a third of the planet's circumference.
constexpr std::uint64_t kClimateSalt = 0x636c696d617465ULL;
constexpr double kClimateFrequency = 3.0;

double Rules::dryness(const Vec3d& p) const {
  // Deserts lie under the subtropical highs (latitudes 15–35°), with a regional field for the
  // continents' interiors and rain shadows this model does not compute.
  const double latitude = std::asin(std::clamp(p[2], -1.0, 1.0)) * 180.0 / std::numbers::pi;
  const double belt = (std::abs(latitude) - 25.0) / 13.0;
  const double regional = detail::gradient3(
      p[0] * kClimateFrequency, p[1] * kClimateFrequency, p[2] * kClimateFrequency,
      static_cast<std::uint32_t>(mix64(def.seed ^ kClimateSalt)));
  return std::clamp(0.55 * std::exp(-belt * belt) + 0.45 * 0.5 * (1.0 + regional), 0.0, 1.0);
}

// The continental slope beyond a shelf's edge (4 %, about 2.3°: continental slopes are 1–5°).
constexpr double kContinentalSlope = 0.04;

double Rules::shelf_break_relief(double length) const {
  return def.shelf_width > 0.0 ? 0.25 * kContinentalSlope * length : 0.0;
}

double Rules::roughness(double length) const {
  return def.detail.amplitude * std::pow(length / def.detail.wavelength, def.detail.hurst);
}

namespace {

// How much of eq. 2's offset from the base's midpoint a new vertex keeps. A bisection keeps its
// triangles' shapes (newest-vertex bisection makes finitely many shapes from each start), so a
// sliver made at any level stays a sliver at every level below, and a piecewise-linear surface
// over slivers shows streaks and pits at every zoom (docs/analysis.md "Where the pits come
// from"). The refinement of land keeps 15 %; coastlines keep all of it, since their wiggle is the
// continents' outline. The base shape moves half way from the midpoint to the diamond's centre,
// eq. 2's mean (kBaseShapePull), and keeps a quarter of eq. 2's random offset around that centre
// (kBaseShapeJitter): the jitter, compounded over the base levels, made leaves of the stored mesh
// from a fifth to five times the mean area, and a tile's land has more pits the larger its
// leaves (docs/analysis.md "Generation 19"). With half the jitter, as eq. 2's half offset had, a
// quarter of the zoom-8 land squares of `planet survey` missed the pits target; with a quarter,
// a tenth. Less than a quarter leaves straight coasts at 45° and 90° in the pictures.
constexpr double kBaseShapePull = 0.5;
constexpr double kBaseShapeJitter = 0.25;
constexpr double kLandOffset = 0.15;
// Rivers keep half of eq. 7–9's offset from the base's midpoint (its jitter and the Hermite
// curve's pull alike): with all of it, the triangles beside a river became slivers whose valley
// floor, half their height, was narrower than a sample, and tiles read it as pits (0.043 % at
// zoom 8 on the default planet with all of it, 0.024 % with half; docs/analysis.md,
// "Generation 15"). Half still meanders at every scale.
constexpr double kRiverOffset = 0.5;
// A drain split's vertex keeps at least this share of its edge's drop to each end.
constexpr double kDrainMargin = 0.2;
// The drainage relief model (planet.md "Relief models"): a dry vertex stands above the corner it
// drains to by min_drain_slope · (l / 1 km)^−kHangConcavity · l for a link l metres long, at most
// kHangSteepest · l: links steepen towards the headwaters as Flint's law has it (slope ∝ area^−θ
// with area ∝ l², so θ = kHangConcavity / 2: 0.5, which left fewer land squares of `planet
// survey` with θ above 0.8 at zoom 11 than 0.575 did), and a chain of links from any vertex down to
// a river sums to a few hundred metres. The rise grows with the square root of the region's
// ruggedness (with all of it, the squares that mix smooth plateau tops with rugged escarpments
// scatter from Flint's law at zoom 8), and with the belts' and plateaus' uplift U as 1 + U /
// kHangUpliftScale: the stream-power law's steady slope grows with the uplift rate, so belts
// steepen every link alike and keep θ. Added to the height instead, the uplift steepened trunks as
// much as headwaters on every link, and on the coarse links alone stood up as spikes and cliffs
// that the finer vertices, hung from lower corners, did not follow (docs/analysis.md "The drainage
// relief model"). Drains wind twice as far off their edge as land splits do.
constexpr double kHangConcavity = 1.0;
constexpr double kHangUpliftScale = 500.0;
constexpr double kHangRuggedness = 0.5;
constexpr double kHangSteepest = 0.1;
constexpr double kHangDrainOffset = 2.0;
// Below the length where its slope reaches kHangSteepest (300 m on the default planet), a link's
// rise is spread by up to this share either way (the split's own random number). At one slope
// for every finer link, each new vertex hung from its lowest corner landed on the plane through
// its corners, and steep belts stood as planar facets hundreds of metres wide in zoom-14
// hillshades. With the spread, 26 of the 900 windows of 16² samples on the default planet's
// zoom-14 square are facets instead of 264, and the survey's squares keep their figures
// (docs/analysis.md "Generation 21").
constexpr double kHangCapSpread = 0.3;
// A drain turns across its edge to an opposite corner at most this share of a rise above the
// lowest corner. The vertex then stands that much higher than it would hang from the lowest: with
// no bound, 379 of the 65 025 samples of the default planet's zoom-8 square stood more than their
// spacing above a neighbour (12 without turning, 60 with half a rise, 289 with one).
constexpr double kTurnAbove = 0.5;
// A vertex beside a lake stands at least this share of its rise above the lake.
constexpr double kHangAboveLake = 0.1;
// A new arm's spring climbs this share of the uplift gained from the river it joins to it (as
// the base rivers do by base_mesh.cpp's kRiverUpliftShare, a little less: more stood its
// springs above the land hung beside them).
constexpr double kArmUpliftShare = 0.45;
// The slope ends this share of sea_depth down, on the ocean floor of the base mesh's sea.
constexpr double kAbyssShare = 0.6;
// A split under a lake deepens its floor by up to this slope times its edge: the coarse splits
// make the basin (up to about 300 m under a default planet's lakes), the fine ones its relief.
constexpr double kLakeFloorSlope = 0.002;

// The drainage model's rise of a new vertex over the corner it drains to, l metres away. A link
// at the capped slope has its rise spread by `spread` (in [−1, 1]) times kHangCapSpread.
double hung_rise(const Rules& rules, double l, const Rules::Region& region, double spread = 0.0) {
  const double slope = rules.def.min_drain_slope * std::pow(l / 1000.0, -kHangConcavity);
  const double share = slope > kHangSteepest ? kHangCapSpread * spread : 0.0;
  return std::min(kHangSteepest, slope) * l * std::pow(region.ruggedness, kHangRuggedness) *
         (1.0 + region.uplift / kHangUpliftScale) * (1.0 + share);
}

// Unit vector in the tangent plane at p closest to direction v (zero if v is radial).
std::array<float, 3> tangent_at(const Vec3d& p, const Vec3d& v) {
  const Vec3d t = sub(v, scale(p, dot(v, p)));
  const double n = std::sqrt(dot(t, t));
  if (!(n > 0.0)) return {0.0f, 0.0f, 0.0f};
  return {static_cast<float>(t[0] / n), static_cast<float>(t[1] / n), static_cast<float>(t[2] / n)};
}

Vec3d to_vec(const std::array<float, 3>& t) {
  return {static_cast<double>(t[0]), static_cast<double>(t[1]), static_cast<double>(t[2])};
}

// The smooth ground of the level being split (smooth_surface.hpp) at p, a point of the diamond
// (a, b; t, d) whose four corners are dry: what a new vertex there is predicted from.
double smooth_ground_at(const Rules& rules, const Vertex& a, const Vertex& b, const Vertex& t,
                        const Vertex& d, const Vec3d& p) {
  const std::array<const Vertex*, 3> tri = det(a.p, b.p, p) >= 0.0
                                               ? std::array<const Vertex*, 3>{&a, &b, &t}
                                               : std::array<const Vertex*, 3>{&b, &a, &d};
  return clough_tocher(tri, barycentric(tri[0]->p, tri[1]->p, tri[2]->p, p), rules.radius);
}

// The split of diamond (a, b; t, d) with a, b in canonical order (see split_diamond).
SplitResult split_ordered(const Rules& rules, int level, const Vertex& a, const Vertex& b,
                          const Vertex& t, const Vertex& d, EdgeType base, FaceType face_t,
                          FaceType face_d) {
  const PlanetDefinition& def = rules.def;
  SplitResult r{};
  Vertex& m = r.m;
  m.seed = mix64(a.seed + b.seed);
  Random random(m.seed);
  const double xi = random.uniform(0.25, 0.75), eta = random.uniform(0.25, 0.75);
  const double g1 = random.uniform(), g2 = random.uniform();
  r.half_a = r.half_b = base;
  // A face's spoke takes its kind: sea, lake or land.
  const auto spoke = [](FaceType face) {
    return face == FaceType::sea    ? EdgeType::sea
           : face == FaceType::lake ? EdgeType::lake
                                    : EdgeType::land;
  };
  r.spoke_t = spoke(face_t);
  r.spoke_d = spoke(face_d);

  const Vec3d mid = normalize(add(a.p, b.p));
  // Keeps the new vertex where the four new triangles are all positively oriented with room to
  // spare (the diamond's kernel), pulling it towards the base's midpoint (which always is) if
  // needed: the hierarchy stays a valid triangulation, so rivers (edges) can never cross.
  const double area_t = det(a.p, b.p, t.p), area_d = det(b.p, a.p, d.p);
  const double margin = 0.05 * std::min(area_t, area_d);
  auto place = [&](const Vec3d& raw) {
    for (double s : {1.0, 0.5, 0.25, 0.125}) {
      const Vec3d q = normalize(add(mid, scale(sub(raw, mid), s)));
      if (det(t.p, a.p, q) > margin && det(b.p, t.p, q) > margin && det(d.p, b.p, q) > margin &&
          det(a.p, d.p, q) > margin) {
        return q;
      }
    }
    return mid;
  };
  // Eq. 2: a randomised weighted sum of the diamond's vertices, lifted to the sphere (eq. 1).
  const double wa = (1 - eta) * xi, wt = (1 - eta) * (1 - xi), wd = eta * xi, wb = eta * (1 - xi);
  const Vec3d eq2 =
      normalize(add(add(scale(a.p, wa), scale(t.p, wt)), add(scale(d.p, wd), scale(b.p, wb))));
  auto offset = [&](double share) { return normalize(add(mid, scale(sub(eq2, mid), share))); };
  const double l_ab = rules.radius * angle(a.p, b.p);
  const bool hung = def.relief_model == ReliefModel::drainage;
  const bool dry_diamond = !wet(a) && !wet(b) && !wet(t) && !wet(d);
  // Dry: the water surface stays below the ground, so a river's water meets its banks inside
  // the triangles next to it instead of flooding them. The water surface of a dry vertex only
  // says how far a neighbour's water reaches towards it: one riverbed slope (s_rb) per metre of
  // edge below the ground makes a river of depth d end about d / s_rb from its vertex at every
  // level, instead of flooding a fixed fraction of ever larger triangles at coarse levels.
  auto dry_water = [&](double water) {
    return std::min(water,
                    m.ground - std::max(def.riverbed_edge_height, l_ab * def.min_riverbed_slope));
  };

  // Metres from m to each corner of the diamond, once m is placed; the angles are kept for the
  // rest of the split (SplitResult::corner_angle).
  const Vertex* corner[4] = {&a, &b, &t, &d};
  auto corner_lengths = [&] {
    std::array<double, 4> length{};
    for (std::size_t i = 0; i < 4; ++i) {
      r.corner_angle[i] = angle(m.p, corner[i]->p);
      length[i] = rules.radius * r.corner_angle[i];
    }
    r.has_corner_angles = true;
    return length;
  };
  // Land: the distance to the coast through the nearest corner, in the vertex's hectometres.
  auto reach_coast = [&](const std::array<double, 4>& length) {
    double metres = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 4; ++i) metres = std::min(metres, coast_distance(*corner[i]) + length[i]);
    m.coast_hm = static_cast<std::uint16_t>(std::min(65535.0, std::round(metres / 100.0)));
  };

  if (level < rules.base_level) {  // base shape: geometry only; §4 labels it afterwards
    const Vec3d centre = normalize(add(add(a.p, b.p), add(t.p, d.p)));
    m.p = place(normalize(add(add(mid, scale(sub(centre, mid), kBaseShapePull)),
                              scale(sub(eq2, centre), kBaseShapeJitter))));
    m.flags = kSea;
    m.ground = def.sea_level - def.sea_depth;
    m.water = def.sea_level;
    return r;
  }

  switch (base) {
    case EdgeType::sea: {
      m.p = mid;  // §5.3: sea vertices sit at the centre of the edge
      m.flags = kSea;
      m.water = def.sea_level;
      // Continental shelves: sea vertices carry their distance to the coast (Vertex::
      // drainage_area), through the nearest corner. Within shelf_width the floor is no deeper
      // than the shelf (half of shelf_depth at the coast, all of it at its edge); beyond, the
      // continental slope keeps it at least kContinentalSlope × the distance past the edge deeper,
      // down to the ocean floor (kAbyssShare of sea_depth), below which it is free.
      const std::array<double, 4> length = corner_lengths();
      double coast = std::numeric_limits<double>::infinity();
      for (int i = 0; i < 4; ++i) {
        const Vertex& c = *corner[i];
        const double from = (c.flags & kSea) != 0 ? static_cast<double>(c.drainage_area) : 0.0;
        coast = std::min(coast, from + length[i]);
      }
      m.drainage_area = static_cast<float>(coast);
      if (level >= rules.sea_finest_level) {
        // Below the open sea's finest level the floor is its surface there: a sea split only
        // adds the mean of its edge's ends, so the open sea's triangles of that level are the
        // sea floor whatever their refinement, and a triangle beside one that is refined
        // further meets it along their edge (to the micrometre of the gnomonic projections).
        m.ground = 0.5 * (a.ground + b.ground);
        return r;
      }
      m.ground = 0.5 * (a.ground + b.ground) + 0.3 * rules.roughness(l_ab) * (2.0 * g1 - 1.0);
      if (def.shelf_width > 0.0 && coast < def.shelf_width) {
        const double shelf = def.shelf_depth * (0.5 + 0.5 * coast / def.shelf_width);
        m.ground = std::max(m.ground, def.sea_level - shelf);
      } else if (def.shelf_width > 0.0) {
        const double slope = def.shelf_depth + kContinentalSlope * (coast - def.shelf_width);
        const double deepest = def.sea_level - std::min(slope, kAbyssShare * def.sea_depth);
        m.ground = std::min(m.ground, deepest + 0.3 * rules.roughness(l_ab) * (2.0 * g2 - 1.0));
      }
      m.ground = std::clamp(m.ground, def.sea_level - def.sea_depth, def.sea_level - 1.0);
      return r;
    }
    case EdgeType::coast: {
      m.p = place(eq2);
      m.flags = kCoast;
      m.ground = m.water = def.sea_level;
      return r;
    }
    case EdgeType::shore: {  // a lake's coast: at its water, as wiggly as the sea's
      m.p = place(eq2);
      m.flags = kLand | kLake;
      m.ground = m.water = 0.5 * (a.water + b.water);
      reach_coast(corner_lengths());
      return r;
    }
    case EdgeType::lake: {  // the floor under a lake: below the mean of its corners, deeper
      m.p = place(offset(kLandOffset));  // the longer its edge (lakes.hpp)
      m.flags = kLand | kLake;
      m.water = 0.5 * (a.water + b.water);
      m.ground = std::min(0.25 * (a.ground + b.ground + t.ground + d.ground), m.water - 1.0) -
                 kLakeFloorSlope * l_ab * g1;
      reach_coast(corner_lengths());
      return r;
    }
    case EdgeType::river: {
      // Eq. 7: between the two apexes; eq. 8–9 bias ξ towards the Hermite midpoint of the river
      // (tangents point downstream; ev1 of eq. 9 is the upstream end).
      const bool a_up = a.water > b.water || (a.water == b.water && a.seed < b.seed);
      const Vertex& up = a_up ? a : b;
      const Vertex& down = a_up ? b : a;
      double x = xi;
      if (l_ab < def.min_river_length) {
        const Vec3d vs = add(scale(add(up.p, down.p), 0.5),
                             scale(sub(to_vec(up.tangent), to_vec(down.tangent)),
                                   std::sqrt(dot(sub(up.p, down.p), sub(up.p, down.p))) / 4.0));
        const Vec3d td = sub(d.p, t.p);
        const double xs = dot(sub(vs, t.p), td) / dot(td, td);
        x = std::clamp(xs + (xi - 0.5) * 0.5, 0.25, 0.75);
      }
      x = 0.5 + kRiverOffset * (x - 0.5);
      m.p = place(normalize(add(scale(t.p, 1.0 - x), scale(d.p, x))));
      m.flags = kLand | kRiver;
      reach_coast(corner_lengths());
      m.ground = 0.5 * (a.ground + b.ground);
      m.water = 0.5 * (a.water + b.water);
      m.drainage_area = up.drainage_area;
      m.tangent = tangent_at(
          m.p,
          add(add(to_vec(up.tangent), to_vec(down.tangent)),
              scale(sub(down.p, up.p),
                    2.0 / std::max(1e-300, std::sqrt(dot(sub(down.p, up.p), sub(down.p, up.p)))))));
      return r;
    }
    case EdgeType::drain: {
      // Between its ends in height too, so both halves drain downhill: the upper end keeps a
      // strictly lower neighbour at every level.
      const double level_a = outflow_level(a), level_b = outflow_level(b);
      const bool a_up = level_a > level_b || (level_a == level_b && a.seed < b.seed);
      const double high = a_up ? level_a : level_b, low = a_up ? level_b : level_a;
      m.p = place(offset(hung ? kLandOffset * kHangDrainOffset : kLandOffset));
      m.flags = kLand;
      reach_coast(corner_lengths());
      m.detail = static_cast<float>(rules.region(m.p, coast_distance(m)).ruggedness);
      // The angles from m to the upper end and the lower one (a and b are corners 0 and 1).
      const double to_up = r.corner_angle[a_up ? 0 : 1], to_down = r.corner_angle[a_up ? 1 : 0];
      if (hung) {  // the split point's share of the drop, so that both halves fall as steeply
        m.ground = low + (high - low) * std::clamp(to_down / (to_up + to_down), kDrainMargin,
                                                   1.0 - kDrainMargin);
      } else if (dry_diamond) {
        // On the smooth surface, kept within the middle of the drop.
        m.ground =
            std::clamp(smooth_ground_at(rules, a, b, t, d, m.p), low + kDrainMargin * (high - low),
                       high - kDrainMargin * (high - low));
      } else {  // the split point's share of the drop follows its place, jittered a little
        const double f = std::clamp(to_down / (to_up + to_down) + 0.1 * (2.0 * g1 - 1.0),
                                    kDrainMargin, 1.0 - kDrainMargin);
        m.ground = low + (high - low) * f;
      }
      m.water = dry_water(0.5 * (a.water + b.water));
      return r;
    }
    case EdgeType::land:
      break;
  }

  // A continent vertex (§5.3 step 6).
  m.p = place(offset(kLandOffset));
  const std::array<double, 4> length = corner_lengths();
  reach_coast(length);
  m.water = 0.25 * (a.water + b.water + t.water + d.water);

  // A new river arm: an edge longer than l_rmin may gain a spring that flows to the lowest
  // neighbouring river vertex, if it fits below every non-river neighbour (eq. 10).
  if (l_ab > def.min_river_length) {
    int river = -1;
    for (int i = 0; i < 4; ++i) {
      if ((corner[i]->flags & kRiver) != 0 &&
          (river < 0 || corner[i]->water < corner[river]->water)) {
        river = i;
      }
    }
    if (river >= 0) {
      // The drainage model's springs climb as its land does, and with the uplift: at the river
      // slope, an arm 100 km long stood 100 m above the land hung beside it on a wall.
      const Vertex& joins = *corner[river];
      double lower = joins.water + length[river] * def.min_river_slope;
      if (hung) {
        const Rules::Region here = rules.region(m.p, coast_distance(m));
        lower = joins.water + hung_rise(rules, length[river], here) +
                kArmUpliftShare * std::max(0.0, here.uplift - rules.region(joins.p).uplift);
      }
      double upper = def.sea_level + def.max_river_altitude;
      for (int i = 0; i < 4; ++i) {
        if (wet(*corner[i])) continue;
        upper = std::min(
            upper, corner[i]->ground -
                       std::min(length[i] * def.min_riverbed_slope,
                                def.riverbed_edge_height + length[i] * def.min_slope_near_river));
      }
      if (lower < upper) {
        m.flags = kLand | kRiver;
        // A spring: water = ground; the drainage model's at its least rise, or it stands on a
        // wall above the land.
        m.ground = m.water = hung ? lower : lower + (upper - lower) * 0.25 * g1;
        m.tangent = tangent_at(m.p, sub(corner[river]->p, m.p));
        EdgeType* to[4] = {&r.half_a, &r.half_b, &r.spoke_t, &r.spoke_d};
        *to[river] = EdgeType::river;
        return r;
      }
    }
  }

  m.flags = kLand;
  // The region scales the fractal's roughness here, eq. 5's mountains and the detail below.
  const Rules::Region region = rules.region(m.p, coast_distance(m));
  const double rugged = region.ruggedness;
  m.detail = static_cast<float>(rugged);
  EdgeType* to[4] = {&r.half_a, &r.half_b, &r.spoke_t, &r.spoke_d};
  // Drainage at every level: the new vertex drains along the edge to its lowest corner and
  // stands above it by a rise at least, so it is not a pit now, and the drain split above keeps
  // it from becoming one after any later split.
  int receiver = 0;
  double lowest = outflow_level(a);
  for (int i = 1; i < 4; ++i) {
    const double level_i = outflow_level(*corner[i]);
    if (level_i < lowest) receiver = i, lowest = level_i;
  }
  if (hung && receiver < 2) {
    // The drainage model turns a drain that would run on along the edge being split (to its
    // lower end, corner 0 or 1) across it, to the lower opposite corner, where that stands below
    // the edge's other end and at most kTurnAbove of a rise above the lowest corner: drains
    // that ran on along old edges made straight valleys into the lowest corners, level after
    // level, which gathered stars of them (planet.md "Relief models").
    const int apex = outflow_level(t) <= outflow_level(d) ? 2 : 3;
    const double apex_level = outflow_level(*corner[apex]);
    if (apex_level < outflow_level(*corner[1 - receiver]) &&
        apex_level - lowest <= kTurnAbove * hung_rise(rules, length[apex], region)) {
      receiver = apex;
      lowest = apex_level;
    }
  }
  if (hung) {
    const double rise = hung_rise(rules, length[receiver], region, 2.0 * g2 - 1.0);
    m.ground = lowest + rise;
    for (const Vertex* c : corner) {
      if ((c->flags & kLake) != 0) {
        m.ground = std::max(m.ground, outflow_level(*c) + kHangAboveLake * rise);
      }
    }
    *to[receiver] = EdgeType::drain;
    m.water = dry_water(m.water);
    return r;
  }
  // The estimate: eq. 5 for a mountain vertex between rivers, else the surface under the new
  // position (the smooth one among dry corners, eq. 2's weights beside water) displaced by the
  // fractal's roughness at this edge length.
  double estimate = (dry_diamond ? smooth_ground_at(rules, a, b, t, d, m.p)
                                 : wa * a.ground + wt * t.ground + wd * d.ground + wb * b.ground) +
                    rugged * rules.roughness(l_ab) * (2.0 * g1 - 1.0);
  if (wet(a) && wet(b)) {
    int highest = -1;
    for (int i = 0; i < 4; ++i) {
      if ((corner[i]->flags & (kRiver | kCoast | kLake)) != 0 &&
          (highest < 0 || corner[i]->ground > corner[highest]->ground)) {
        highest = i;
      }
    }
    if (highest >= 0) {
      estimate = corner[highest]->ground + rugged * def.mountain_slope * length[highest] * g2;
    }
  }
  // Mountain belts and plateaus, level by level: the part of their uplift at m that the level
  // above does not carry already (dry corners carry theirs, water none), so that the coarse
  // levels raise whole ranges and rivers keep their beds through them. The finer levels inherit
  // it.
  if (l_ab >= rules.uplift_finest_edge() && (def.belt_height > 0.0 || def.plateau_height > 0.0)) {
    const double weight[4] = {wa, wb, wt, wd};
    double carried = 0.0;
    for (int i = 0; i < 4; ++i) {
      if (!wet(*corner[i])) carried += weight[i] * rules.region(corner[i]->p).uplift;
    }
    estimate += region.uplift - carried;
  }
  // Eq. 11: above every river or water neighbour by the riverbed rules; eq. 12: within the
  // ground slope of the others. Where they conflict, the river's valley wins.
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 4; ++i) {
    const Vertex& c = *corner[i];
    if (wet(c)) {
      lo = std::max(
          lo, std::min(c.ground + length[i] * def.min_riverbed_slope,
                       c.water + def.riverbed_edge_height + length[i] * def.min_slope_near_river));
    } else {
      lo = std::max(lo, c.ground - length[i] * def.max_ground_slope);
      hi = std::min(hi, c.ground + length[i] * def.max_ground_slope);
    }
  }
  hi = std::min(hi, def.sea_level + def.max_mountain_altitude);
  m.ground = lo > hi ? lo : std::clamp(estimate, lo, hi);
  m.ground = std::max(m.ground, lowest + rules.drain_rise(length[receiver], rugged));
  *to[receiver] = EdgeType::drain;
  m.water = dry_water(m.water);
  return r;
}

}  // namespace

SplitResult split_diamond(const Rules& rules, int level, const Vertex& a, const Vertex& b,
                          const Vertex& t, const Vertex& d, EdgeType base, FaceType face_t,
                          FaceType face_d) {
  // Canonical roles: ev1 is the end with the smaller seed (positions break a tie), so both
  // triangles of a diamond compute the same vertex.
  const bool swap = a.seed > b.seed || (a.seed == b.seed && a.p > b.p);
  const Vertex& ev1 = swap ? b : a;
  const Vertex& ev2 = swap ? a : b;
  const Vertex& apex1 = swap ? d : t;  // the apex of the triangle (ev1, ev2, apex1)
  const Vertex& apex2 = swap ? t : d;
  SplitResult r = split_ordered(rules, level, ev1, ev2, apex1, apex2, base, swap ? face_d : face_t,
                                swap ? face_t : face_d);
  if (swap) {
    std::swap(r.half_a, r.half_b);
    std::swap(r.spoke_t, r.spoke_d);
  }
  // Only dry land's slopes are read (the smooth surface's corners are all dry). The fan around m
  // is ev2, apex1, ev1, apex2 counter-clockwise (Hierarchy::locate_child), summed from the same
  // corner whichever triangle of the diamond asks, so the same bits.
  if (!wet(r.m)) ground_slope(r.m) = fan_slope(r.m, {&ev2, &apex1, &ev1, &apex2}, rules.radius);
  if (!wet(r.m) && rules.def.relief_model == ReliefModel::drainage) {
    // No steeper than its gentlest secant to a lower corner: the cubic of a vertex hung far
    // below a fan of high neighbours would otherwise dip under its own drain a sample away.
    double secant = std::numeric_limits<double>::infinity();
    // Every dry vertex's split measured its corners, split_ordered's (a, b, t, d), which are
    // these in this order.
    assert(r.has_corner_angles);
    const std::array<const Vertex*, 4> corner = {&ev1, &ev2, &apex1, &apex2};
    for (std::size_t i = 0; i < 4; ++i) {
      const double drop = r.m.ground - outflow_level(*corner[i]);
      if (drop > 0.0) secant = std::min(secant, drop / (rules.radius * r.corner_angle[i]));
    }
    std::array<float, 3>& slope = ground_slope(r.m);
    const double steepness = std::sqrt(static_cast<double>(slope[0]) * slope[0] +
                                       static_cast<double>(slope[1]) * slope[1] +
                                       static_cast<double>(slope[2]) * slope[2]);
    if (steepness > secant) {
      for (float& component : slope) component = static_cast<float>(component * secant / steepness);
    }
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Hierarchy

void Hierarchy::make_octahedron(std::uint64_t seed) {
  vertices.clear();
  tris.clear();
  const Vec3d axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (std::uint64_t i = 0; i < 6; ++i) {
    Vertex v;
    v.p = axes[i];
    v.seed = mix64(seed * 6 + i);
    vertices.push_back(v);
  }
  // Face index ((sx < 0)·2 + (sy < 0))·2 + (sz < 0): root_face relies on this order.
  for (int sx = 0; sx < 2; ++sx) {
    for (int sy = 0; sy < 2; ++sy) {
      for (int sz = 0; sz < 2; ++sz) {
        const auto x = static_cast<std::uint32_t>(sx), y = static_cast<std::uint32_t>(2 + sy),
                   z = static_cast<std::uint32_t>(4 + sz);
        Tri f;
        // Counter-clockwise seen from outside when the octant's sign product is positive;
        // the base is the equatorial edge, shared with the mirror face across the equator.
        f.v = ((sx + sy + sz) % 2 == 0) ? std::array<std::uint32_t, 3>{x, y, z}
                                        : std::array<std::uint32_t, 3>{y, x, z};
        tris.push_back(f);
      }
    }
  }
  for (std::size_t f = 0; f < tris.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t from = tris[f].v[static_cast<std::size_t>(k)];
      const std::uint32_t to = tris[f].v[static_cast<std::size_t>((k + 1) % 3)];
      for (std::size_t g = 0; g < tris.size(); ++g) {
        for (int j = 0; j < 3; ++j) {
          if (tris[g].v[static_cast<std::size_t>(j)] == to &&
              tris[g].v[static_cast<std::size_t>((j + 1) % 3)] == from) {
            tris[f].nb[static_cast<std::size_t>(k)] = static_cast<std::int32_t>(g);
          }
        }
      }
    }
  }
}

std::int32_t Hierarchy::root_face(const Vec3d& p) const {
  return ((p[0] < 0 ? 1 : 0) * 2 + (p[1] < 0 ? 1 : 0)) * 2 + (p[2] < 0 ? 1 : 0);
}

SplitResult Hierarchy::compute_split(std::int32_t t) const {
  const Tri& T = tris[static_cast<std::size_t>(t)];
  assert(T.nb[0] >= 0);
  const Tri& P = tris[static_cast<std::size_t>(T.nb[0])];
  return split_diamond(*rules_, T.level, vertices[T.v[0]], vertices[T.v[1]], vertices[T.v[2]],
                       vertices[P.v[2]], T.edge[0], T.face, P.face);
}

void Hierarchy::apply_split(std::int32_t t, const SplitResult& s) {
  const Tri T = tris[static_cast<std::size_t>(t)];
  const std::int32_t p = T.nb[0];
  const Tri P = tris[static_cast<std::size_t>(p)];
  assert(P.v[0] == T.v[1] && P.v[1] == T.v[0] && T.child[0] < 0 && P.child[0] < 0);
  const auto m = static_cast<std::uint32_t>(vertices.size());
  vertices.push_back(s.m);
  const auto n = static_cast<std::int32_t>(tris.size());
  const std::int32_t tc0 = n, tc1 = n + 1, pc0 = n + 2, pc1 = n + 3;
  const auto level = static_cast<std::uint8_t>(T.level + 1);
  auto make = [&](std::array<std::uint32_t, 3> v, std::array<EdgeType, 3> e,
                  std::array<std::int32_t, 3> nb, FaceType face, std::int32_t parent,
                  std::uint8_t which) {
    Tri c;
    c.v = v;
    c.edge = e;
    c.nb = nb;
    c.face = face;
    c.parent = parent;
    c.which = which;
    c.level = level;
    tris.push_back(c);
  };
  const std::uint32_t a = T.v[0], b = T.v[1], c = T.v[2], d = P.v[2];
  make({c, a, m}, {T.edge[2], s.half_a, s.spoke_t}, {-1, pc1, tc1}, T.face, t, 0);
  make({b, c, m}, {T.edge[1], s.spoke_t, s.half_b}, {-1, tc0, pc0}, T.face, t, 1);
  make({d, b, m}, {P.edge[2], s.half_b, s.spoke_d}, {-1, tc1, pc1}, P.face, p, 0);
  make({a, d, m}, {P.edge[1], s.spoke_d, s.half_a}, {-1, pc0, tc0}, P.face, p, 1);
  tris[static_cast<std::size_t>(t)].child = {tc0, tc1};
  tris[static_cast<std::size_t>(p)].child = {pc0, pc1};
}

void Hierarchy::ensure_partner(std::int32_t t) {
  if (tris[static_cast<std::size_t>(t)].nb[0] >= 0) return;
  const Tri T = tris[static_cast<std::size_t>(t)];
  assert(T.parent >= 0);
  // The base of child 0 is the parent's edge 2, of child 1 its edge 1; those edges' neighbours
  // are always known, and the partner is that neighbour's child along the same edge.
  const std::int32_t g = tris[static_cast<std::size_t>(T.parent)].nb[T.which == 0 ? 2u : 1u];
  assert(g >= 0);
  ensure_split(g);
  const Tri& G = tris[static_cast<std::size_t>(g)];
  int k = -1;
  for (int j = 0; j < 3; ++j) {
    if (G.v[static_cast<std::size_t>(j)] == T.v[1] &&
        G.v[static_cast<std::size_t>((j + 1) % 3)] == T.v[0]) {
      k = j;
    }
  }
  assert(k == 1 || k == 2);
  const std::int32_t partner = G.child[k == 2 ? 0u : 1u];
  tris[static_cast<std::size_t>(t)].nb[0] = partner;
  tris[static_cast<std::size_t>(partner)].nb[0] = t;
}

void Hierarchy::ensure_split(std::int32_t t) {
  if (tris[static_cast<std::size_t>(t)].child[0] >= 0) return;
  ensure_partner(t);
  apply_split(t, compute_split(t));
}

std::int32_t Hierarchy::locate_child(std::int32_t t, const Vec3d& p) const {
  const Tri& T = tris[static_cast<std::size_t>(t)];
  const Tri& P = tris[static_cast<std::size_t>(T.nb[0])];
  const Vec3d& m = vertices[tris[static_cast<std::size_t>(T.child[0])].v[2]].p;
  const Vec3d& a = vertices[T.v[0]].p;
  const Vec3d& b = vertices[T.v[1]].p;
  const Vec3d& c = vertices[T.v[2]].p;
  const Vec3d& d = vertices[P.v[2]].p;
  // The four children fan around m in the order b, c, a, d (counter-clockwise); p lies in the
  // sector between rays m→X and m→Y when it is left of the first and right of the second. The
  // half-open tests give every point exactly one sector, decided by the same numbers in
  // whichever tile asks.
  // Each determinant is computed only when a test needs it (the same operands and the same
  // comparisons as computing all four first, so the same answer, in about half the work).
  const double lb = det(m, b, p), lc = det(m, c, p);
  if (lb >= 0 && lc < 0) return T.child[1];
  const double la = det(m, a, p);
  if (lc >= 0 && la < 0) return T.child[0];
  const double ld = det(m, d, p);
  if (la >= 0 && ld < 0) return P.child[1];
  if (ld >= 0 && lb < 0) return P.child[0];
  return T.child[0];  // only p = ±m (or NaN) gets here
}

bool Hierarchy::open_sea(std::int32_t t) const {
  const Tri& tri = tris[static_cast<std::size_t>(t)];
  if (tri.face != FaceType::sea || tri.level < rules_->sea_finest_level) return false;
  constexpr std::uint8_t kNotOpen = kCoast | kLand | kRiver | kLake;
  return std::none_of(tri.v.begin(), tri.v.end(),
                      [&](std::uint32_t v) { return (vertices[v].flags & kNotOpen) != 0; });
}

std::int32_t Hierarchy::open_sea_stop(std::int32_t t) const {
  if (!open_sea(t)) return -1;
  for (std::int32_t up = tris[static_cast<std::size_t>(t)].parent; up >= 0 && open_sea(up);
       up = tris[static_cast<std::size_t>(up)].parent) {
    t = up;
  }
  return t;
}

std::int32_t Hierarchy::locate(const Vec3d& p, int level) {
  std::int32_t t = root_face(p);
  while (tris[static_cast<std::size_t>(t)].level < level && !open_sea(t)) {
    ensure_split(t);
    t = locate_child(t, p);
  }
  return t;
}

}  // namespace planet
