// Contour primitives' geometry (Génevaux et al. 2015, §4.1): a star-shaped closed curve given in
// polar form around a centre, r = R(θ), and radial profiles c(ρ) of the normalised radius
// ρ = |p − c| / R(θ), interpolated between equally spaced angular sectors. Evaluation reads only
// a flat float block and ports to GLSL. See docs/geometry.md §3.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "terrain/math.hpp"
#include "terrain/profile.hpp"
#include "terrain/result.hpp"

namespace terrain {

/// Polar coordinates of a point and the interpolated profile value c(ρ, θ) with its gradient.
struct ContourSample {
  float r = 0.0f;             ///< |p − centre|
  float theta = 0.0f;         ///< angle from the orientation, counter-clockwise, in [0, 2π)
  float radius = 0.0f;        ///< R(θ)
  float radius_slope = 0.0f;  ///< dR/dθ
  float rho = 0.0f;           ///< r / R(θ)
  float value = 0.0f;         ///< c(ρ, θ)
  float d_rho = 0.0f;         ///< ∂c/∂ρ
  float d_theta = 0.0f;       ///< ∂c/∂θ
  Vec2 grad;                  ///< ∇c with respect to p (0 at the centre)
};

/// A star-shaped contour with sector profiles.
class Contour {
 public:
  static constexpr int kMinRadii = 3;
  static constexpr int kMaxRadii = 256;
  static constexpr int kMaxProfiles = 64;

  /// radii: R_k at θ_k = 2πk/K from the orientation (K in 3..256, all finite and > 0);
  /// profiles: functions of ρ ≥ 0 for the sectors θ_j = 2πj/M (M in 1..64), all with the same
  /// value at ρ = 0. Errors point at "/radii/k", "/profiles/j", "/centre", "/orientation".
  static Result<Contour> build(Vec2 centre, float orientation, std::span<const float> radii,
                               std::span<const Profile> profiles);

  Vec2 centre() const { return centre_; }
  /// Angle (radians, counter-clockwise from +x) of the direction θ = 0.
  float orientation() const { return orientation_; }
  int radius_count() const { return static_cast<int>(radii_.size()); }
  int profile_count() const { return static_cast<int>(profiles_.size()); }
  std::span<const Profile> profiles() const { return profiles_; }
  /// Slopes of the periodic radius spline at the nodes, in dR/du with u = θ·K/(2π).
  std::span<const float> radius_slopes() const { return radius_slopes_; }

  /// R(θ) (θ from the orientation, any real value; periodic).
  float radius(float theta) const;
  /// dR/dθ.
  float radius_slope(float theta) const;
  /// Exact range of R(θ) (= [min R_k, max R_k]: the scheme never overshoots).
  Interval radius_range() const { return radius_range_; }
  /// Exact max |dR/dθ|.
  float max_radius_slope() const { return max_radius_slope_; }
  /// Largest profile abscissa: for ρ beyond it every sector profile is constant.
  float max_rho() const { return max_rho_; }
  /// A box holding every point with ρ(p) ≤ rho.
  Box2 bounds(float rho) const { return Box2::around(centre_, rho * radius_range_.hi); }

  /// Range of c over the plane.
  Interval range() const;
  /// Range of c over a box (a superset: the hull of the profiles over the box's ρ interval).
  Interval range(const Box2& box) const;
  /// Lipschitz bound of c(ρ(p), θ(p)) over the plane (docs/geometry.md §3.4).
  float lipschitz() const { return lipschitz_; }
  /// Lipschitz bound over a box (never above lipschitz()).
  float lipschitz(const Box2& box) const;

  ContourSample sample(Vec2 p) const;

  /// Floats appended by pack(): 6 + 2K + M + Σ profile sizes.
  std::size_t packed_size() const { return packed_.size(); }
  /// Appends [cx, cy, cos φ, sin φ, K, M, (R_k, m_k)…, profile offsets…, profile blocks…];
  /// offsets are relative to the first float of this block.
  void pack(std::vector<float>& pool) const;

 private:
  Contour() = default;
  float lipschitz_for(Interval rho, float r_min) const;

  Vec2 centre_;
  float orientation_ = 0.0f;
  std::vector<float> radii_;
  std::vector<float> radius_slopes_;
  std::vector<Profile> profiles_;
  std::vector<float> neighbour_slope_gap_;  // max |c_j+1' − c_j'| per sector pair
  std::vector<float> packed_;
  Interval radius_range_;
  float max_radius_slope_ = 0.0f;
  float max_rho_ = 0.0f;
  float lipschitz_ = 0.0f;
};

/// Evaluates a packed contour (the block written by Contour::pack) at p.
ContourSample contour_eval(const float* packed, Vec2 p);

/// Radial presets (functions of ρ; 0 is the level of the surrounding terrain).
/// Lake: bowl, −depth at the centre, −0.2·depth at ρ = 1 − shore_width, 0 for ρ ≥ 1.
Result<Profile> lake_profile(float depth, float shore_width);
/// Crater: floor −depth at the centre, −0.9·depth at ρ = 0.5, rim crest +rim_height at ρ = 1,
/// back to 0 at ρ = 1 + rim_width.
Result<Profile> crater_profile(float depth, float rim_height, float rim_width);
/// Plateau: flat top at `height` for ρ ≤ 1 − cliff_width/2, cliff down to 0 at
/// ρ = 1 + cliff_width/2 (height/2 on the contour itself); cliff_width in (0, 2).
Result<Profile> plateau_profile(float height, float cliff_width);

}  // namespace terrain
