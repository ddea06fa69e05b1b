#include "planet/smooth_surface.hpp"

namespace planet {

namespace {

// The slope as metres of height per unit of the unit sphere's chords.
Vec3d scaled_slope(const Vertex& v, double radius) {
  return {v.slope[0] * radius, v.slope[1] * radius, v.slope[2] * radius};
}

// The Bézier ordinate next to u on the way to point x (a third of the way, on u's tangent plane).
double toward(const Vertex& u, const Vec3d& slope_u, const Vec3d& x) {
  return u.ground + dot(slope_u, sub(x, u.p)) / 3.0;
}

}  // namespace

double edge_cubic(const Vertex& u, const Vertex& v, double s, double radius) {
  const double e_uv = toward(u, scaled_slope(u, radius), v.p);
  const double e_vu = toward(v, scaled_slope(v, radius), u.p);
  const double r = 1.0 - s;
  return r * r * r * u.ground + 3.0 * r * r * s * e_uv + 3.0 * r * s * s * e_vu +
         s * s * s * v.ground;
}

double clough_tocher(const std::array<const Vertex*, 3>& corner, const std::array<double, 3>& w,
                     double radius) {
  const std::array<Vec3d, 3> slope = {scaled_slope(*corner[0], radius),
                                      scaled_slope(*corner[1], radius),
                                      scaled_slope(*corner[2], radius)};
  const Vec3d centroid = scale(add(add(corner[0]->p, corner[1]->p), corner[2]->p), 1.0 / 3.0);
  // Ordinates shared by the three cubic patches around the centroid.
  std::array<std::array<double, 3>, 3> edge{};  // edge[i][j]: next to corner i towards j
  std::array<double, 3> spoke_near{};           // on corner i's spoke, next to the corner
  for (std::size_t i = 0; i < 3; ++i) {
    for (std::size_t j = 0; j < 3; ++j) {
      if (i != j) edge[i][j] = toward(*corner[i], slope[i], corner[j]->p);
    }
    spoke_near[i] = toward(*corner[i], slope[i], centroid);
  }
  // The middle ordinate of the patch on edge (i, j): the one that makes the derivative across the
  // edge, taken perpendicular to it, linear along it (a function of the edge's ends only).
  std::array<double, 3> face{};  // face[k]: the patch on the edge opposite corner k
  for (std::size_t k = 0; k < 3; ++k) {
    const std::size_t i = (k + 1) % 3, j = (k + 2) % 3;
    const Vec3d along = sub(corner[i]->p, corner[j]->p);
    // The foot of the centroid on the edge is alpha·x_i + (1 − alpha)·x_j.
    const double alpha = dot(sub(centroid, corner[j]->p), along) / dot(along, along);
    const double at_i = spoke_near[i] - alpha * corner[i]->ground - (1.0 - alpha) * edge[i][j];
    const double at_j = spoke_near[j] - alpha * edge[j][i] - (1.0 - alpha) * corner[j]->ground;
    face[k] = 0.5 * (at_i + at_j) + alpha * edge[i][j] + (1.0 - alpha) * edge[j][i];
  }
  // Inner ordinates: C1 across the spokes between the patches.
  std::array<double, 3> spoke_far{};  // on corner i's spoke, next to the centroid
  for (std::size_t i = 0; i < 3; ++i) {
    spoke_far[i] = (spoke_near[i] + face[(i + 1) % 3] + face[(i + 2) % 3]) / 3.0;
  }
  const double centre = (spoke_far[0] + spoke_far[1] + spoke_far[2]) / 3.0;

  // The patch holding the point: the one on the edge opposite the smallest coordinate.
  std::size_t k = 0;
  if (w[1] < w[k]) k = 1;
  if (w[2] < w[k]) k = 2;
  const std::size_t i = (k + 1) % 3, j = (k + 2) % 3;
  const double bi = w[i] - w[k], bj = w[j] - w[k], bc = 3.0 * w[k];
  return corner[i]->ground * bi * bi * bi + corner[j]->ground * bj * bj * bj +
         centre * bc * bc * bc + 3.0 * edge[i][j] * bi * bi * bj + 3.0 * edge[j][i] * bi * bj * bj +
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
