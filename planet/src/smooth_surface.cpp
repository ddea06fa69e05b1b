#include "planet/smooth_surface.hpp"

namespace planet {

namespace {

// The slope times `scale`; with the radius, metres of height per unit of the unit sphere's chords.
Vec3d scaled_slope(const Vertex& v, double scale) {
  const std::array<float, 3>& slope = ground_slope(v);
  return {slope[0] * scale, slope[1] * scale, slope[2] * scale};
}

// Valley floors along rivers and coasts, at every level. In a land triangle with wet corners
// (river or coast) and dry ones, the ground rises only kFloorRise of the way from the wet
// corners' level to the smooth surface over the first kFloorWidth of the way (in the dryness D
// below, 0 at wet corners and 1 at dry ones), then blends into the smooth surface with weight
// smoothstep((D − kFloorWidth) / (1 − kFloorWidth)). D is a cubic that is C1 across every edge;
// until generation 15 it was the dry corners' total barycentric weight, whose slope jumps across
// every spoke from a wet corner, and the blend creased there (issue 20 item 4). A piecewise-linear
// V whose sides are steeper than the river it holds leaves the samples beside a channel narrower
// than a sample lower than all eight neighbours (pits at every zoom: docs/analysis.md); a floor
// about a sample wide drains them into it. The smooth surface here is the Clough–Tocher cubic of
// the corners with the wet ones level (no slope): along the dry corners' edge it is the cubic and
// cross-edge slope of those two corners alone, which the all-dry triangle across that edge shares,
// and the blend's weight arrives there flat, so the valley side meets the dry land with the same
// height and slope (C1) — until generation 13 it climbed there linearly and left a crease. Along
// every other edge both triangles see the same two corners with the same weights, so the surface
// stays continuous.
constexpr double kFloorWidth = 0.5;
constexpr double kFloorRise = 0.001;

}  // namespace

ValleyFloor::ValleyFloor(const std::array<const Vertex*, 3>& corner, double radius) {
  bool any_wet = false, any_dry = false;
  for (std::size_t k = 0; k < 3; ++k) {
    ground_[k] = corner[k]->ground;
    wet_[k] = wet(*corner[k]);
    (wet_[k] ? any_wet : any_dry) = true;
  }
  if (!any_wet || !any_dry) return;
  // Two copies of the corners, level (no slope) where it matters. `marks` carry the dryness: the
  // Clough–Tocher cubic of 0 at the wet corners and 1 at the dry ones, level at every corner.
  // Along an edge it depends on that edge's two ends only, so two triangles sharing a spoke from
  // a wet corner see the same dryness with the same slope across it. `side` carries the smooth
  // surface with the wet corners level: what the valley side climbs to.
  std::array<Vertex, 3> mark{}, level{};
  std::array<const Vertex*, 3> marks{}, side = corner;
  for (std::size_t k = 0; k < 3; ++k) {
    mark[k] = *corner[k];
    mark[k].ground = wet_[k] ? 0.0 : 1.0;
    ground_slope(mark[k]) = {0.0f, 0.0f, 0.0f};
    marks[k] = &mark[k];
    if (!wet_[k]) continue;
    level[k] = *corner[k];
    ground_slope(level[k]) = {0.0f, 0.0f, 0.0f};
    side[k] = &level[k];
  }
  dryness_.emplace(marks, radius);
  side_.emplace(side, radius);
}

double ValleyFloor::operator()(const std::array<double, 3>& w) const {
  double wet_weight = 0.0, wet_sum = 0.0, dry_weight = 0.0, dry_sum = 0.0;
  for (std::size_t k = 0; k < 3; ++k) {
    if (wet_[k]) {
      wet_weight += w[k];
      wet_sum += w[k] * ground_[k];
    } else {
      dry_weight += w[k];
      dry_sum += w[k] * ground_[k];
    }
  }
  if (!dryness_ || !(wet_weight > 0.0) || !(dry_weight > 0.0)) return wet_sum + dry_sum;
  const double wet_level = wet_sum / wet_weight;
  const double share = (*dryness_)(w);
  const double smooth = (*side_)(w);
  const double floor = wet_level + kFloorRise * share * (smooth - wet_level);
  if (share <= kFloorWidth) return floor;
  // The valley side: from the floor to the smooth surface, which it reaches with the surface's
  // slope at the dry corners (C1 with the all-dry triangle across their edge).
  return floor + smoothstep((share - kFloorWidth) / (1.0 - kFloorWidth)) * (smooth - floor);
}

CloughTocher::CloughTocher(const std::array<const Vertex*, 3>& corner, double radius) {
  // Per corner i, with j = i + 1 and k = i + 2 (mod 3): the edge to the next corner, x_j − x_i,
  // and the corner's slope scaled by radius / 3 (Bézier ordinates sit a third of the way).
  std::array<Vec3d, 3> next{}, slope{};
  for (std::size_t i = 0; i < 3; ++i) {
    next[i] = sub(corner[(i + 1) % 3]->p, corner[i]->p);
    slope[i] = scaled_slope(*corner[i], radius / 3.0);
    f[i] = corner[i]->ground;
  }
  // Ordinates next to corner i: towards the next corner, towards the previous one, and on its
  // spoke to the centroid (c − x_i is the mean of the two edges from x_i over 3).
  for (std::size_t i = 0; i < 3; ++i) {
    const double along_next = dot(slope[i], next[i]);
    const double along_previous = -dot(slope[i], next[(i + 2) % 3]);
    to_next[i] = f[i] + along_next;
    to_previous[i] = f[i] + along_previous;
    spoke_near[i] = f[i] + (along_next + along_previous) / 3.0;
  }
  // The middle ordinate of the patch on edge (i, j = i + 1), face[k] with k the opposite corner:
  // the one that makes the derivative across the edge, taken perpendicular to it, linear along
  // it (a function of the edge's ends only). The foot of the centroid on the edge is
  // alpha·x_i + (1 − alpha)·x_j, alpha = (1 + (x_k − x_j)·(x_i − x_j) / |x_i − x_j|²) / 3, where
  // x_k − x_j = next[j] and x_i − x_j = −next[i].
  for (std::size_t i = 0; i < 3; ++i) {
    const std::size_t j = (i + 1) % 3, k = (i + 2) % 3;
    const double alpha = (1.0 - dot(next[j], next[i]) / dot(next[i], next[i])) / 3.0;
    const double at_i = spoke_near[i] - alpha * f[i] - (1.0 - alpha) * to_next[i];
    const double at_j = spoke_near[j] - alpha * to_previous[j] - (1.0 - alpha) * f[j];
    face[k] = 0.5 * (at_i + at_j) + alpha * to_next[i] + (1.0 - alpha) * to_previous[j];
  }
  // Inner ordinates: C1 across the spokes between the patches.
  for (std::size_t i = 0; i < 3; ++i) {
    spoke_far[i] = (spoke_near[i] + face[(i + 1) % 3] + face[(i + 2) % 3]) / 3.0;
  }
  centre = (spoke_far[0] + spoke_far[1] + spoke_far[2]) / 3.0;
}

double CloughTocher::operator()(const std::array<double, 3>& w) const {
  // The patch holding the point: the one on the edge opposite the smallest coordinate.
  std::size_t k = 0;
  if (w[1] < w[k]) k = 1;
  if (w[2] < w[k]) k = 2;
  const std::size_t i = (k + 1) % 3, j = (k + 2) % 3;
  const double bi = w[i] - w[k], bj = w[j] - w[k], bc = 3.0 * w[k];
  return f[i] * bi * bi * bi + f[j] * bj * bj * bj + centre * bc * bc * bc +
         3.0 * to_next[i] * bi * bi * bj + 3.0 * to_previous[j] * bi * bj * bj +
         3.0 * spoke_near[i] * bi * bi * bc + 3.0 * spoke_far[i] * bi * bc * bc +
         3.0 * spoke_near[j] * bj * bj * bc + 3.0 * spoke_far[j] * bj * bc * bc +
         6.0 * face[k] * bi * bj * bc;
}

std::array<float, 3> fan_slope(const Vertex& m, const std::array<const Vertex*, 4>& ring,
                               double radius) {
  // A planar triangle's gradient times twice its area is n × Σ h_i (x_{i+2} − x_{i+1}); with n
  // the tangent plane's normal at m for all four, the mean weighted by area is the sum of those
  // over the sum of the areas. Heights relative to m keep the sums small. Positions are on the
  // unit sphere, so the sum is divided by the radius for metres per metre.
  Vec3d weighted{0.0, 0.0, 0.0};
  double twice_area = 0.0;
  for (std::size_t f = 0; f < 4; ++f) {
    const Vertex& u = *ring[f];
    const Vertex& v = *ring[(f + 1) % 4];
    const double hu = u.ground - m.ground, hv = v.ground - m.ground;
    // Triangle (m, u, v): the term of m vanishes with its relative height 0.
    const Vec3d s = add(scale(sub(m.p, v.p), hu), scale(sub(u.p, m.p), hv));
    weighted = add(weighted, cross(m.p, s));
    twice_area += det(m.p, sub(u.p, m.p), sub(v.p, m.p));
  }
  if (!(twice_area != 0.0)) return {0.0f, 0.0f, 0.0f};
  const double k = 1.0 / (twice_area * radius);
  return {static_cast<float>(weighted[0] * k), static_cast<float>(weighted[1] * k),
          static_cast<float>(weighted[2] * k)};
}

}  // namespace planet
