// 1D cross-section profiles for curve and contour primitives (Génevaux et al. 2015, §4.1): a C1,
// shape-preserving piecewise-quadratic function c(d) of a signed distance (curves, metres) or of a
// normalised radius (contours). Construction validates user parameters; evaluation reads only a
// flat float block so the same code ports to GLSL. See docs/geometry.md for the exact formulas.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "terrain/math.hpp"
#include "terrain/result.hpp"

namespace terrain {

/// A control point of a profile: relative elevation h at abscissa d.
struct ProfilePoint {
  float d = 0.0f;
  float h = 0.0f;
};

/// Value c(d) and slope c'(d) of a profile.
struct ProfileSample {
  float value = 0.0f;
  float slope = 0.0f;
};

/// Value of (1 − t)·c_a(d) + t·c_b(d) and its partial derivatives.
struct ProfileBlendSample {
  float value = 0.0f;
  float slope = 0.0f;  ///< ∂/∂d = lerp of the two slopes
  float dt = 0.0f;     ///< ∂/∂t = c_b(d) − c_a(d)
};

/// A C1 piecewise-quadratic profile through control points (d_k, h_k), constant beyond the first
/// and last points. Each interval [d_k, d_k+1] holds two quadratics joined at its midpoint; the
/// slopes at the control points follow a harmonic-mean rule, zero at local extrema and at both
/// ends, so the profile never leaves [min(h_k, h_k+1), max(h_k, h_k+1)] on an interval.
class Profile {
 public:
  static constexpr int kMinPoints = 2;
  static constexpr int kMaxPoints = 64;

  /// Any profile: 2..64 points with finite coordinates and strictly increasing d.
  static Result<Profile> custom(std::span<const ProfilePoint> points);
  /// Narrow V-ish channel of total width `width` and depth `depth`, soft banks at ±width/2.
  static Result<Profile> stream(float width, float depth);
  /// U-shaped channel: a bed of width `width` (−0.9·depth at its edges, −depth in the middle),
  /// banks rising to 0 at ±(width/2 + bank_width).
  static Result<Profile> river(float width, float depth, float bank_width);
  /// River whose thalweg moves towards a steep cut bank; asymmetry in [−1, 1], positive puts the
  /// cut bank on the left (d > 0) and the gentle point bar on the right. 0 gives river().
  static Result<Profile> meander(float width, float depth, float bank_width, float asymmetry);
  /// Road: carriageway |d| ≤ carriageway/2 at 0 (raised by `crown` at the centre line),
  /// shoulders at 0 up to width/2, a level (0) embankment zone up to width/2 + embankment that
  /// marks where the curve node's weight ramps the terrain onto the road.
  static Result<Profile> road(float width, float carriageway, float embankment, float crown = 0.0f);

  /// Value and slope at d (clamped to the domain: constant outside, slope 0).
  ProfileSample sample(float d) const;
  float value(float d) const { return sample(d).value; }
  float slope(float d) const { return sample(d).slope; }

  /// [d_0, d_n−1].
  Interval domain() const;
  /// max(|d_0|, |d_n−1|): beyond this distance from the skeleton the profile is constant.
  float half_extent() const;
  /// Exact range of c over all d (= [min h_k, max h_k]).
  Interval range() const;
  /// Exact range of c over d ∈ interval (empty for an empty interval).
  Interval range(Interval d) const;
  /// Exact max |c'| over all d.
  float max_slope() const;
  /// Exact max |c'| over d ∈ interval (0 for an empty interval).
  float max_slope(Interval d) const;

  std::span<const ProfilePoint> points() const { return points_; }
  /// Slopes m_k at the control points (as stored and evaluated).
  std::span<const float> slopes() const { return slopes_; }

  /// Floats appended by pack(): 1 + 3n.
  std::size_t packed_size() const { return packed_.size(); }
  /// Appends [n, d_0, h_0, m_0, …, d_n−1, h_n−1, m_n−1]; evaluate with profile_eval().
  void pack(std::vector<float>& pool) const;

 private:
  Profile(std::vector<ProfilePoint> points, std::vector<float> slopes);
  static Result<Profile> channel(const char* name, float width, float depth, float bank_width,
                                 float asymmetry);

  std::vector<ProfilePoint> points_;
  std::vector<float> slopes_;
  std::vector<float> packed_;  // evaluation always goes through the packed form
};

/// Evaluates a packed profile (the block written by Profile::pack) at d.
ProfileSample profile_eval(const float* packed, float d);
/// Evaluates lerp(c_a, c_b, t) at d from two packed profiles.
ProfileBlendSample profile_blend_eval(const float* a, const float* b, float d, float t);

/// Exact range of c_b(d) − c_a(d) over all d.
Interval profile_difference(const Profile& a, const Profile& b);
/// Exact range of c_b(d) − c_a(d) over d ∈ interval.
Interval profile_difference(const Profile& a, const Profile& b, Interval d);
/// Exact max |c_b'(d) − c_a'(d)| over all d.
float profile_difference_max_slope(const Profile& a, const Profile& b);

}  // namespace terrain
