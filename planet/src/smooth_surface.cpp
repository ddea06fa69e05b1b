#include "planet/smooth_surface.hpp"

namespace planet {

namespace {

// The slope times `scale`; with the radius, metres of height per unit of the unit sphere's chords.
Vec3d scaled_slope(const Vertex& v, double scale) {
  const std::array<float, 3>& slope = ground_slope(v);
  return {slope[0] * scale, slope[1] * scale, slope[2] * scale};
}

}  // namespace

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
