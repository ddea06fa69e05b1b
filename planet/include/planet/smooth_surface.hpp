// The smooth ground of dry land (issue 20 item 4): a C1 surface over the mesh instead of flat
// facets. Every dry vertex carries the slope of its ground (ground_slope), estimated when it is
// made from the fan of four triangles around it; a triangle whose corners are all dry is filled
// with the Clough–Tocher cubic of its corners' heights and slopes (Farin 1986: three cubic Bézier
// patches around the centroid, the cross-edge derivative linear along each edge). Along an edge
// that cubic depends on the edge's two ends only, and so does the cross-edge derivative, so two
// triangles sharing an edge meet with the same height and the same slope.
//
// Splits predict a new dry vertex from this surface (refine.cpp), so refinement adds detail to a
// smooth surface rather than to the facets of the level above: without it a level's triangles
// survive every later level as flat facets with creases along their edges. Land triangles with
// wet corners blend the same cubic into a valley floor beside the water (ValleyFloor).
#pragma once

#include <array>
#include <optional>

#include "planet/mesh.hpp"

namespace planet {

/// A dry vertex's ground slope (metres per metre, tangent at its position): kept in
/// Vertex::tangent, which rivers use for their downstream direction.
inline const std::array<float, 3>& ground_slope(const Vertex& v) {
  return v.tangent;
}
inline std::array<float, 3>& ground_slope(Vertex& v) {
  return v.tangent;
}

/// True when every corner is dry land (not wet): the triangles the cubic fills.
inline bool all_dry(const std::array<const Vertex*, 3>& corner) {
  return !wet(*corner[0]) && !wet(*corner[1]) && !wet(*corner[2]);
}

/// The Clough–Tocher cubic of a triangle (corners counter-clockwise or not), from the corners'
/// ground and slope; `radius` in metres. Made once, it is evaluated at any number of points of
/// the triangle (a sampler keeps its last leaf's).
struct CloughTocher {
  CloughTocher(const std::array<const Vertex*, 3>& corner, double radius);
  /// The height at gnomonic barycentric coordinates w.
  double operator()(const std::array<double, 3>& w) const;

  // The Bézier ordinates: f at the corners; next to corner i, towards the next corner, towards
  // the previous one, on its spoke to the centroid and next to the centroid; face[k] in the
  // middle of the patch on the edge opposite corner k; the centroid.
  std::array<double, 3> f{}, to_next{}, to_previous{}, spoke_near{}, spoke_far{}, face{};
  double centre = 0.0;
};

/// The Clough–Tocher height at gnomonic barycentric coordinates w of the triangle.
inline double clough_tocher(const std::array<const Vertex*, 3>& corner,
                            const std::array<double, 3>& w, double radius) {
  return CloughTocher(corner, radius)(w);
}

/// The ground of a land triangle with wet corners (river, coast or lake) and dry ones: a valley
/// floor beside the water that blends into the smooth surface (planet.md "Detail, surface type
/// and water"). Its two cubics depend on the corners only, so it is made once per triangle and
/// evaluated at any number of its points (a sampler keeps its last leaf's).
class ValleyFloor {
 public:
  ValleyFloor(const std::array<const Vertex*, 3>& corner, double radius);
  /// The height at gnomonic barycentric coordinates w.
  double operator()(const std::array<double, 3>& w) const;

 private:
  std::array<double, 3> ground_{};
  std::array<bool, 3> wet_{};
  /// Only with wet and dry corners both: else the triangle is filled linearly.
  std::optional<CloughTocher> dryness_, side_;
};

/// The slope (metres per metre, tangent at m) of a new vertex from its four neighbours `ring`,
/// counter-clockwise around it: the area-weighted mean of the gradients of the four triangles
/// (m, ring[k], ring[k + 1]).
std::array<float, 3> fan_slope(const Vertex& m, const std::array<const Vertex*, 4>& ring,
                               double radius);

}  // namespace planet
