// Image primitives (Génevaux et al. 2015, §4.2): a bilinear heightfield over the unit square in
// (u, v) with a C1 weight, and the inverse bilinear map that places it on a convex quadrangle.
// Evaluation reads a packed float record through a base pointer and integer offsets only, so that
// it ports to GLSL unchanged (a storage buffer of floats plus a base index). The curve mapping
// lives in the curve module: it produces (u, v) and their gradients, and composes with the
// evaluators here exactly like QuadMap does (see chain()).
#pragma once

#include <cstddef>
#include <vector>

#include "terrain/image_io.hpp"
#include "terrain/math.hpp"
#include "terrain/result.hpp"

namespace terrain {

/// Wyvill-type C1 ramp w(t) = 1 − (1 − t²)³ on [0, 1], 0 below, 1 above. w(0) = 0, w(1) = 1 and
/// w'(0) = w'(1) = 0, so the clamped ramp is C1 on the whole line.
float wyvill_ramp(float t);
/// w'(t) = 6 t (1 − t²)² on [0, 1], 0 elsewhere.
float wyvill_ramp_slope(float t);
/// max |w'| = w'(1/√5) = 96 / (25 √5) ≈ 1.7173002 (w'' = 6 (1 − t²)(1 − 5t²) vanishes at 1/√5;
/// the paper's 96√5/125 is the same number). Rounded up by 6e-6 relative so that it also bounds
/// the float evaluation of w', which can land a few ulps above the exact maximum.
inline constexpr float kWyvillRampMaxSlope = 1.71731f;

/// A scalar and its partial derivatives with respect to (u, v).
struct UvSample {
  float value = 0.0f;
  float du = 0.0f;
  float dv = 0.0f;
};

/// (u, v) of a world point and the gradients ∇u, ∇v with respect to the point (the rows of the
/// inverse Jacobian ∂(u, v)/∂p).
struct UvMap {
  float u = 0.0f;
  float v = 0.0f;
  Vec2 du;
  Vec2 dv;
  bool inside = false;  ///< the point lies in the mapped domain (closed)
};

/// Chain rule: the gradient of a (u, v) field with respect to the world point.
inline Vec2 chain(const UvSample& s, const UvMap& m) {
  return s.du * m.du + s.dv * m.dv;
}

/// How a raster becomes heights and weights.
struct HeightfieldParams {
  float offset = 0.0f;     ///< height = offset + scale · sample
  float scale = 1.0f;      ///< may be negative or zero
  float margin_u = 0.05f;  ///< width of the border fall-off in u, in (0, 0.5]
  float margin_v = 0.05f;  ///< width of the border fall-off in v, in (0, 0.5]
  /// Heights by Catmull-Rom bicubic interpolation (C1, through the samples) instead of bilinear.
  bool cubic = false;
};

/// Offsets inside a packed heightfield record (floats; integers are stored exactly as floats).
namespace heightfield_layout {
inline constexpr std::size_t kColumns = 0;    ///< n
inline constexpr std::size_t kRows = 1;       ///< m
inline constexpr std::size_t kOffset = 2;     ///< height offset
inline constexpr std::size_t kScale = 3;      ///< height scale
inline constexpr std::size_t kMarginU = 4;    ///< border fall-off width in u
inline constexpr std::size_t kMarginV = 5;    ///< border fall-off width in v
inline constexpr std::size_t kHasWeight = 6;  ///< 1 when a weight grid follows the heights
inline constexpr std::size_t kCubic = 7;      ///< 1: heights bicubic (Catmull-Rom), 0: bilinear
inline constexpr std::size_t kHeader = 8;     ///< samples start here
}  // namespace heightfield_layout

/// Height at (u, v) from a packed record starting at pool[base]: bilinear in the samples, or
/// Catmull-Rom bicubic when the record says so (C1; the tangent at a sample is half the
/// difference of its two neighbours, indices clamped to the grid), (u, v) clamped to [0, 1]²
/// (constant extension, zero derivative across the clamp). Sample (i, j) sits
/// at u = i/(n−1), v = j/(m−1), with j the raster row (v = 0 is the top, north row). On a cell
/// edge the derivative is that of the cell chosen by floor, clamped to the last cell.
UvSample heightfield_height(const float* pool, std::size_t base, float u, float v);

/// Weight at (u, v) from a packed record: α = w(clamp(ω, 0, 1)) · b(u, v), with ω the bilinear
/// weight grid (ω ≡ 1 without one) and b the border fall-off
///   b(u, v) = w(min(u, 1 − u) / margin_u) · w(min(v, 1 − v) / margin_v)
/// (w clamped as above). b is 1 inside the margins, 0 on and outside the square's boundary, and
/// C1: away from the corners it equals w(distance to the boundary / margin); in the corners the
/// product replaces the min of the two distances, whose gradient jumps across the diagonal.
/// Composing ω with w flattens the kinks the clamp to [0, 1] would otherwise leave.
UvSample heightfield_weight(const float* pool, std::size_t base, float u, float v);

/// A bilinear heightfield with its bounds, holding its own packed record.
class Heightfield {
 public:
  /// Validates the raster (at least 2×2, at most 2^24 samples, finite) and the parameters.
  static Result<Heightfield> create(const Raster& raster, const HeightfieldParams& params = {});

  int columns() const { return columns_; }
  int rows() const { return rows_; }
  bool has_weight() const { return has_weight_; }
  const HeightfieldParams& params() const { return params_; }

  UvSample height(float u, float v) const { return heightfield_height(record_.data(), 0, u, v); }
  UvSample weight(float u, float v) const { return heightfield_weight(record_.data(), 0, u, v); }

  /// sup |∂h/∂u| = |scale| · (n−1) · max |h(i+1, j) − h(i, j)|: inside a cell ∂h/∂u is a convex
  /// combination of the cell's two horizontal differences times n−1. Bicubic: 2.5 times that
  /// (a Catmull-Rom segment's slope is at most twice the largest neighbour difference D, at
  /// t = 1/2: 6t(1−t)·D + |1−4t+3t²|·D + |3t²−2t|·D; the weights across sum to at most 1.25 in
  /// absolute value).
  float lipschitz_u() const { return lipschitz_u_; }
  /// sup |∂h/∂v| = |scale| · (m−1) · max |h(i, j+1) − h(i, j)|.
  float lipschitz_v() const { return lipschitz_v_; }
  /// Lipschitz bound of the height wrt (u, v): sqrt(λu² + λv²). This is §7.3.1's
  /// √2 · max(neighbour difference) / l taken per axis: the paper bounds both partials by the
  /// larger of the two, so ours is never larger and is smaller when one axis is smoother or the
  /// grid spacing differs between axes (n ≠ m). It holds on the whole plane because clamping to
  /// the square is 1-Lipschitz.
  float lipschitz() const { return lipschitz_; }
  /// Lipschitz bound of the weight wrt (u, v): W'·|∇ω|max + W'·max(1/margin_u, 1/margin_v), with
  /// W' = kWyvillRampMaxSlope and |∇ω|max the per-axis bound above on the raw weight grid (both
  /// factors lie in [0, 1], so |∇(ab)| ≤ |∇a| + |∇b|). heightfield.cpp explains why the product
  /// fall-off's slope is bounded by W'/margin rather than √2·W'/margin.
  float weight_lipschitz() const { return weight_lipschitz_; }
  /// Range of heights: bilinear values are convex combinations of the samples; bicubic ones
  /// overshoot by at most 1.5625 (1.25² of the weights) times half the samples' spread about
  /// its middle.
  Interval height_range() const { return range_; }

  /// Number of floats pack() appends.
  std::size_t packed_size() const { return record_.size(); }
  /// Appends the record (layout in heightfield_layout) to `pool`; it starts at the old size.
  void pack(std::vector<float>& pool) const;

 private:
  Heightfield() = default;

  int columns_ = 0;
  int rows_ = 0;
  bool has_weight_ = false;
  HeightfieldParams params_;
  float lipschitz_u_ = 0.0f;
  float lipschitz_v_ = 0.0f;
  float lipschitz_ = 0.0f;
  float weight_lipschitz_ = 0.0f;
  Interval range_;
  std::vector<float> record_;
};

/// Offsets inside a packed quad record.
namespace quad_layout {
inline constexpr std::size_t kCorners = 0;      ///< ax, ay, bx, by, cx, cy, dx, dy
inline constexpr std::size_t kOrientation = 8;  ///< +1 counter-clockwise, −1 clockwise
inline constexpr std::size_t kSize = 9;
}  // namespace quad_layout

/// Inverse bilinear map of a packed quad record (see QuadMap::inverse).
UvMap quad_inverse(const float* pool, std::size_t base, Vec2 p);

/// A convex quadrangle a, b, c, d carrying the unit square: a ↔ (0, 0), b ↔ (1, 0), c ↔ (1, 1),
/// d ↔ (0, 1), p(u, v) = a + u (b − a) + v (d − a) + u v (a − b + c − d). The corners may go round
/// counter-clockwise or clockwise; the orientation is stored. Since v = 0 is raster row 0 (north),
/// an upright image wants a = north-west, b = north-east, c = south-east, d = south-west, which
/// is clockwise in (x east, y north).
class QuadMap {
 public:
  /// Refuses non-finite corners, coincident corners, collinear corners (an angle within about
  /// 0.01° of 0 or 180°) and non-convex or self-intersecting corner orders.
  static Result<QuadMap> create(Vec2 a, Vec2 b, Vec2 c, Vec2 d);

  /// Corner k in order a, b, c, d.
  Vec2 corner(int k) const { return corners_[k & 3]; }
  /// +1 for counter-clockwise corners, −1 for clockwise.
  float orientation() const { return orientation_; }
  /// p(u, v), the forward bilinear map (not clamped).
  Vec2 forward(float u, float v) const;
  /// Columns ∂p/∂u and ∂p/∂v of the forward Jacobian at (u, v).
  void forward_jacobian(float u, float v, Vec2& dp_du, Vec2& dp_dv) const;

  /// (u, v) of p and its gradients. Inside the quad: the inverse of forward(), from the closed
  /// form of the quadratic in v with the root on the quad's side of the fold (Jacobian
  /// determinant of the quad's sign), written so that neither the root formula cancels nor a
  /// vanishing k2 divides (parallelograms, where the quadratic becomes linear), then two Newton
  /// steps on the forward map, which recover the digits the discriminant loses near the narrow
  /// end of strongly tapered quads. The error is within a few ulps of p times ‖J⁻¹‖. Outside:
  /// (u, v) of the nearest point of the quad's boundary, which extends the map continuously (for
  /// the unit square it is exactly clamping) and keeps it Lipschitz on the whole plane with the
  /// same constant; the border weight is 0 there.
  UvMap inverse(Vec2 p) const;

  /// sup over the plane of the spectral norm of ∂(u, v)/∂p. Inside, ‖J⁻¹‖ is the max of
  /// |adj(J) w| / det J over unit w; adj(J) and det J are affine in (u, v), so each term is
  /// quasi-convex and the sup over the square is attained at a corner: the bound is the max over
  /// the four corners of σmax(J)/|det J|. Outside, the nearest-point projection is 1-Lipschitz,
  /// and the edge parameters' gradients 1/|edge| are below the corner values.
  float inverse_jacobian_bound() const { return inverse_jacobian_bound_; }
  /// Bounding box of the corners.
  Box2 bounds() const;

  void pack(std::vector<float>& pool) const;

 private:
  QuadMap() = default;

  Vec2 corners_[4];
  float orientation_ = 1.0f;
  float inverse_jacobian_bound_ = 0.0f;
  float record_[quad_layout::kSize] = {};
};

}  // namespace terrain
