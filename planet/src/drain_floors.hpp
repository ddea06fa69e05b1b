// The floors of the drainage relief model (planet.md "Relief models"): along every drain edge and
// valley edge of the level a sample is taken at, the ground is lowered towards the edge's own
// height, so that the valleys of the level drain along their edges instead of between the
// corners' cubics.
// One function says what one edge does to one point; a lone sample applies it to the floored
// edges it walks to (floor_by_walk), a grid to the edges it draws (Sampler::grid), and both
// take the minimum, which does not depend on the order, so they agree to the bit.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "planet/mesh.hpp"

namespace planet::floors {

/// How far a floor reaches and how it is shaped at one level: within `full` metres of its
/// drain it lowers the ground all the way, out to `reach` less and less (a smoothstep), and it
/// climbs away from its axis as d²/(2·reach): no part of it is planar (docs/planet.md "Relief
/// models": with a linear profile beyond half a sample, the floors' planar strips failed the
/// flat-facet test).
struct FloorShape {
  double reach = 0.0;
  double full = 0.0;
  double radius = 0.0;
  /// Where the ground meets a floor it is eased onto it over the floor's rise across this
  /// many metres (so that the surface keeps its slope there: C1).
  double ease = 0.0;
  double half_over_reach = 0.0;  ///< 1 / (2·reach)
  double over_fade = 0.0;        ///< 1 / (reach − full)
  /// `reach` in unit-sphere chords.
  double reach_chord() const { return reach / radius; }
  /// A little beyond the reach in chords, for deciding which edges and samples to look at, so
  /// that rounding never leaves out one that lowered() would lower.
  double search_chord() const { return reach_chord() * (1.0 + 1e-6); }
};

/// A level's shape: a reach of a sample and a half (samples half an edge apart, as tiles of the
/// level take them), lowering fully within half of it, eased over half a sample.
inline FloorShape floor_shape(const Rules& rules, int level) {
  const double sample = 0.5 * rules.edge_length(level);
  FloorShape shape;
  shape.reach = 1.5 * sample;
  shape.full = 0.5 * shape.reach;
  shape.ease = 0.5 * sample;
  shape.radius = rules.radius;
  shape.half_over_reach = 0.5 / shape.reach;
  shape.over_fade = 1.0 / (shape.reach - shape.full);
  return shape;
}

/// A drain edge, from its end with the smaller seed (positions break a tie) whichever triangle
/// it is seen from, so that every caller computes the same bits.
struct DrainSegment {
  Vec3d a{}, ab{};
  double inverse_length2 = 0.0;  ///< 1 / |ab|² (unit-sphere chords), 0 for a point
  double ground = 0.0;           ///< at a
  double drop = 0.0;             ///< ground at b minus ground at a
  /// Metres the floor climbs per metre away from its axis: the drain's own slope and a little
  /// more, so that the floor never rises across faster than its axis falls along.
  double cross = 0.0;
  /// The ground's height above the floor within which it is eased onto it, and 1 / twice that.
  double ease = 0.0, half_over_ease = 0.0;
};

inline DrainSegment drain_segment(const Vertex& u, const Vertex& v, const FloorShape& shape) {
  const double radius = shape.radius;
  const bool swap = u.seed > v.seed || (u.seed == v.seed && u.p > v.p);
  const Vertex& a = swap ? v : u;
  const Vertex& b = swap ? u : v;
  DrainSegment s;
  s.a = a.p;
  s.ab = sub(b.p, a.p);
  const double length2 = dot(s.ab, s.ab);
  s.inverse_length2 = length2 > 0.0 ? 1.0 / length2 : 0.0;
  s.ground = a.ground;
  s.drop = b.ground - a.ground;
  s.cross = 1e-4 + std::abs(s.drop) / (std::sqrt(length2) * radius);
  s.ease = s.cross * shape.ease;
  s.half_over_ease = 0.5 / s.ease;
  return s;
}

/// The ground at p once the floor of drain `e` has lowered it (`ground` itself out of reach or
/// where the floor stands higher). Every quantity is computed and the result selected, without
/// branches, so that a grid's rows of points vectorise (Sampler::draw_floors): the value is the
/// same either way, and a branch per point mispredicted often enough to double its cost.
/// Where p lies beside drain `e`: the share `f` of the way from its end a to its end b of p's
/// foot on the chord, and p's offset `off` from that foot (unit-sphere chords).
struct Foot {
  double f = 0.0;
  Vec3d off{};
};

inline Foot foot_on(const DrainSegment& e, const Vec3d& p) {
  const Vec3d ap = sub(p, e.a);
  const double f = clamp01(dot(ap, e.ab) * e.inverse_length2);
  return {f, sub(ap, scale(e.ab, f))};
}

inline double lowered(double ground, const DrainSegment& e, const Vec3d& p,
                      const FloorShape& shape) {
  const auto [f, off] = foot_on(e, p);
  const double d = std::sqrt(dot(off, off)) * shape.radius;
  // The floor stands on its axis and climbs away from it, fading out towards the reach.
  const double floor = e.ground + f * e.drop + e.cross * (d * d * shape.half_over_reach);
  const double above = ground - floor;
  const double fade = 1.0 - smoothstep((d - shape.full) * shape.over_fade);
  const double weight = d <= shape.full ? 1.0 : fade;
  // Lowered by `above` less half the ease, eased in quadratically where the floor is near.
  const double eased = above * above * e.half_over_ease;
  const double lowering = above < e.ease ? eased : above - 0.5 * e.ease;
  // Below the floor (so above its axis, too) and within reach.
  return d < shape.reach && above > 0.0 ? ground - weight * lowering : ground;
}

/// Whether edge k of `tri` (a triangle of the level, its partner known) carries a floor: a
/// drain edge, or a valley edge — a land edge whose two opposite corners, one in each triangle
/// beside it, both stand higher than both of its ends. A valley edge is not a drain (its upper
/// end drains along another edge), but the level's surface is a valley along it all the same,
/// and without a floor its cubic bulges above the line between its ends: at zoom 8 four in five
/// of the pits that the drains' floors left lay on valley edges (docs/analysis.md "Generation
/// 20"). It depends on the edge's diamond only, so a grid and a lone sample agree on it.
inline bool floored_edge(const Hierarchy& hierarchy, const Tri& tri, std::size_t k) {
  if (tri.edge[k] == EdgeType::drain) return true;
  if (tri.edge[k] != EdgeType::land || tri.nb[k] < 0) return false;
  const std::uint32_t a = tri.v[k], b = tri.v[(k + 1) % 3];
  const Tri& across = hierarchy.tris[static_cast<std::size_t>(tri.nb[k])];
  std::uint32_t opposite = across.v[0];
  for (const std::uint32_t v : across.v) {
    if (v != a && v != b) opposite = v;
  }
  const auto level = [&](std::uint32_t v) { return outflow_level(hierarchy.vertices[v]); };
  const double top = std::max(level(a), level(b));
  return level(tri.v[(k + 2) % 3]) > top && level(opposite) > top;
}

/// Metres from p to the chord of edge (u, v), for deciding where a walk goes: the walk crosses
/// every edge nearer than the reach (a little more, so that rounding never stops it short).
inline bool within_reach(const Vec3d& u, const Vec3d& v, const Vec3d& p, const FloorShape& shape) {
  const Vec3d uv = sub(v, u), up = sub(p, u);
  const double l2 = dot(uv, uv);
  const double f = std::clamp(l2 > 0.0 ? dot(up, uv) / l2 : 0.0, 0.0, 1.0);
  const Vec3d off = sub(up, scale(uv, f));
  const double limit = shape.search_chord();
  return dot(off, off) <= limit * limit;
}

/// The ground at p, in leaf `leaf` of its level, with every floor of the level applied: a walk
/// over the triangles the reach touches. The triangles a disc meets are connected through the
/// edges it meets, so the walk finds every drain edge within reach. `visited` is scratch.
double floor_by_walk(Hierarchy& hierarchy, std::int32_t leaf, const Vec3d& p, double ground,
                     const FloorShape& shape, std::vector<std::int32_t>& visited);

}  // namespace planet::floors
