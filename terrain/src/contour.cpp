// Star-shaped contours: a periodic shape-preserving quadratic spline for R(θ), smoothstep blending
// between sector profiles, and the bounds the Lipschitz derivation of docs/geometry.md §3 needs.
#include "terrain/contour.hpp"
#include "geometry_util.hpp"
#include "terrain/portable_math.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

namespace terrain {
namespace {

using geometry_util::num;
using geometry_util::preset_error;
using geometry_util::round_down;
using geometry_util::round_up;

constexpr float kTwoPi = 6.28318530717958647692f;
constexpr double kTwoPiD = 2.0 * std::numbers::pi;

struct RadiusSample {
  float value;
  float slope;  // dR/dθ
};

/// Periodic radius spline from nodes (R_k, m_k), m in dR/du, u = θ·K/(2π). Same two-half
/// quadratic as profile_eval with unit spacing.
RadiusSample radius_eval(const float* node, int count, float theta) {
  const float scale = static_cast<float>(count) / kTwoPi;
  float u = theta * scale;
  u -= static_cast<float>(count) * std::floor(u / static_cast<float>(count));  // wrap to [0, K)
  const int k = std::min(static_cast<int>(u), count - 1);
  const int k1 = k + 1 == count ? 0 : k + 1;
  const float f = u - static_cast<float>(k);
  const float r0 = node[2 * k], m0 = node[2 * k + 1];
  const float r1 = node[2 * k1], m1 = node[2 * k1 + 1];
  const float mb = 2.0f * (r1 - r0) - 0.5f * (m0 + m1);
  const bool right = f > 0.5f;
  const float y = right ? r1 : r0;
  const float s0 = right ? m1 : m0;
  const float q = right ? m1 - mb : mb - m0;
  const float w = right ? f - 1.0f : f;
  return {y + (s0 + q * w) * w, (s0 + 2.0f * q * w) * scale};
}

}  // namespace

Result<Contour> Contour::build(Vec2 centre, float orientation, std::span<const float> radii,
                               std::span<const Profile> profiles) {
  if (!std::isfinite(centre.x) || !std::isfinite(centre.y))
    return Error{"the contour centre is not finite (NaN or infinity)", "/centre"};
  if (!std::isfinite(orientation))
    return Error{"the contour orientation is not finite (NaN or infinity)", "/orientation"};
  const std::size_t count = radii.size();
  if (count < static_cast<std::size_t>(kMinRadii) || count > static_cast<std::size_t>(kMaxRadii))
    return Error{"a contour needs 3 to 256 radii, got " + std::to_string(count), "/radii"};
  for (std::size_t k = 0; k < count; ++k)
    if (!(radii[k] > 0.0f) || !std::isfinite(radii[k]))
      return Error{"contour radius " + std::to_string(k) + " must be positive and finite, got " +
                       num(radii[k]),
                   "/radii/" + std::to_string(k)};
  if (profiles.empty() || profiles.size() > static_cast<std::size_t>(kMaxProfiles))
    return Error{"a contour needs 1 to 64 profiles, got " + std::to_string(profiles.size()),
                 "/profiles"};
  for (std::size_t j = 0; j < profiles.size(); ++j) {
    const std::string where = "/profiles/" + std::to_string(j);
    const ProfilePoint first = profiles[j].points().front();
    if (first.d < 0.0f)
      return Error{"contour profile " + std::to_string(j) + " starts at rho = " + num(first.d) +
                       "; profiles are functions of the normalised radius rho >= 0",
                   where};
    // Profiles start with slope 0, so c(0) = h_0 exactly whether d_0 is 0 or beyond it.
    const float h0 = profiles[0].points().front().h;
    if (first.h != h0)
      return Error{"contour profile " + std::to_string(j) + " has value " + num(first.h) +
                       " at rho = 0 but profile 0 has " + num(h0) +
                       "; all sector profiles must agree at the centre, otherwise the "
                       "elevation would have an unbounded gradient there",
                   where};
  }

  Contour out;
  out.centre_ = centre;
  out.orientation_ = orientation;
  out.radii_.assign(radii.begin(), radii.end());
  out.profiles_.assign(profiles.begin(), profiles.end());

  // Periodic harmonic-mean slopes (dR/du): zero at local extrema, ≤ 2·min|δ| elsewhere, so every
  // interval is monotone and R stays within [min R_k, max R_k] > 0.
  std::vector<float>& m = out.radius_slopes_;
  m.assign(count, 0.0f);
  for (std::size_t k = 0; k < count; ++k) {
    const double r_prev = radii[(k + count - 1) % count];
    const double r_next = radii[(k + 1) % count];
    const double a = radii[k] - r_prev, b = r_next - radii[k];
    if (!(a * b > 0.0)) continue;
    const double limit = 2.0 * std::min(std::abs(a), std::abs(b));
    float s = static_cast<float>(2.0 * a * b / (a + b));
    while (std::abs(static_cast<double>(s)) > limit) s = std::nextafter(s, 0.0f);
    m[k] = s;
  }
  double max_du = 0.0;
  Interval rr;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t k1 = (k + 1) % count;
    const double mb = 2.0 * (static_cast<double>(radii[k1]) - radii[k]) - 0.5 * (m[k] + m[k1]);
    max_du = std::max({max_du, std::abs(static_cast<double>(m[k])), std::abs(mb)});
    rr = rr.hull(Interval::point(radii[k]));
  }
  out.radius_range_ = rr;
  out.max_radius_slope_ = round_up(max_du * static_cast<double>(count) / kTwoPiD);

  out.max_rho_ = 0.0f;
  for (const Profile& p : out.profiles_) out.max_rho_ = std::max(out.max_rho_, p.domain().hi);
  const std::size_t sectors = out.profiles_.size();
  out.neighbour_slope_gap_.assign(sectors, 0.0f);
  if (sectors > 1)
    for (std::size_t j = 0; j < sectors; ++j)
      out.neighbour_slope_gap_[j] =
          profile_difference_max_slope(out.profiles_[j], out.profiles_[(j + 1) % sectors]);
  out.lipschitz_ = out.lipschitz_for(Interval{0.0f, std::numeric_limits<float>::infinity()}, 0.0f);

  std::vector<float>& pk = out.packed_;
  const double phi = orientation;
  pk.insert(pk.end(), {centre.x, centre.y, static_cast<float>(std::cos(phi)),
                       static_cast<float>(std::sin(phi)), static_cast<float>(count),
                       static_cast<float>(sectors)});
  for (std::size_t k = 0; k < count; ++k) pk.insert(pk.end(), {radii[k], m[k]});
  const std::size_t offsets = pk.size();
  pk.resize(offsets + sectors);
  for (std::size_t j = 0; j < sectors; ++j) {
    pk[offsets + j] = static_cast<float>(pk.size());
    out.profiles_[j].pack(pk);
  }
  return out;
}

float Contour::radius(float theta) const {
  return radius_eval(packed_.data() + 6, radius_count(), theta).value;
}

float Contour::radius_slope(float theta) const {
  return radius_eval(packed_.data() + 6, radius_count(), theta).slope;
}

Interval Contour::range() const {
  Interval out;
  for (const Profile& p : profiles_) out = out.hull(p.range());
  return out;
}

Interval Contour::range(const Box2& box) const {
  if (box.empty()) return {};
  const Interval r = box.distance_range(centre_);
  const Interval rho{r.lo / radius_range_.hi, r.hi / radius_range_.lo};
  Interval out;
  for (const Profile& p : profiles_) out = out.hull(p.range(rho));
  return out;
}

float Contour::lipschitz(const Box2& box) const {
  if (box.empty()) return 0.0f;
  const Interval r = box.distance_range(centre_);
  return std::min(lipschitz_,
                  lipschitz_for(Interval{r.lo / radius_range_.hi, r.hi / radius_range_.lo}, r.lo));
}

// |∇c| ≤ sqrt((L_ρ/R_min)² + (L_ρ·R'_max/R_min² + L_θ)²), where the e_r and e_θ components are
// bounded separately (they are orthogonal):
//   ∇c = (c_ρ/R) e_r + (−c_ρ R'/R² + c_θ/r) e_θ,
// L_ρ bounds |c_ρ| (a convex combination of profile slopes) and L_θ bounds |c_θ|/r through
// |c_j+1(ρ) − c_j(ρ)| ≤ K_j ρ (equal values at ρ = 0), ρ/r = 1/R, |w'| ≤ 1.5·M/(2π); over a box
// also through |c_j+1 − c_j| ≤ D_j(ρ interval) and r ≥ r_min.
float Contour::lipschitz_for(Interval rho, float r_min) const {
  const double r_lo = radius_range_.lo;
  double l_rho = 0.0;
  for (const Profile& p : profiles_) l_rho = std::max(l_rho, static_cast<double>(p.max_slope(rho)));
  double l_theta = 0.0;
  const std::size_t sectors = profiles_.size();
  if (sectors > 1) {
    for (std::size_t j = 0; j < sectors; ++j) {
      double gap = neighbour_slope_gap_[j] / r_lo;
      if (r_min > 0.0f) {
        const Interval diff = profile_difference(profiles_[j], profiles_[(j + 1) % sectors], rho);
        const double far = std::max(std::abs(diff.lo), std::abs(diff.hi)) / r_min;
        gap = std::min(gap, far);
      }
      l_theta = std::max(l_theta, gap);
    }
    l_theta *= 1.5 * static_cast<double>(sectors) / kTwoPiD;
  }
  const double radial = l_rho / r_lo;
  const double tangential = l_rho * max_radius_slope_ / (r_lo * r_lo) + l_theta;
  return round_up(std::sqrt(radial * radial + tangential * tangential) * (1.0 + 1e-6));
}

ContourSample Contour::sample(Vec2 p) const {
  return contour_eval(packed_.data(), p);
}

void Contour::pack(std::vector<float>& pool) const {
  pool.insert(pool.end(), packed_.begin(), packed_.end());
}

ContourSample contour_eval(const float* packed, Vec2 p) {
  const Vec2 centre{packed[0], packed[1]};
  const float cs = packed[2], sn = packed[3];
  const int count = static_cast<int>(packed[4]);
  const int sectors = static_cast<int>(packed[5]);
  const float* node = packed + 6;
  const float* offsets = node + 2 * count;

  ContourSample out;
  const Vec2 l = p - centre;
  out.r = length(l);
  // Angle in the contour's frame (rotation by −orientation), wrapped to [0, 2π). The portable
  // atan2 (not libm's) so that the GPU kernels compute the very same angle.
  float theta = portable_atan2(-sn * l.x + cs * l.y, cs * l.x + sn * l.y);
  if (theta < 0.0f) theta += kTwoPi;
  if (theta >= kTwoPi) theta = 0.0f;  // −tiny + 2π can round up to 2π
  out.theta = theta;
  const RadiusSample rs = radius_eval(node, count, theta);
  out.radius = rs.value;
  out.radius_slope = rs.slope;
  out.rho = out.r / rs.value;

  // Sector blend: smoothstep weight of the fractional sector index (C1 across sector borders).
  const float sector_scale = static_cast<float>(sectors) / kTwoPi;
  const float v = theta * sector_scale;
  const int j = std::min(static_cast<int>(v), sectors - 1);
  const int j1 = j + 1 == sectors ? 0 : j + 1;
  const float t = v - static_cast<float>(j);
  const float weight = t * t * (3.0f - 2.0f * t);
  const float weight_slope = 6.0f * t * (1.0f - t) * sector_scale;  // d weight / dθ
  const ProfileSample a = profile_eval(packed + static_cast<int>(offsets[j]), out.rho);
  const ProfileSample b = profile_eval(packed + static_cast<int>(offsets[j1]), out.rho);
  const float diff = b.value - a.value;
  out.value = a.value + weight * diff;
  out.d_rho = a.slope + weight * (b.slope - a.slope);
  out.d_theta = sectors > 1 ? weight_slope * diff : 0.0f;
  if (out.r > 0.0f) {
    // ∇r = e_r, ∇θ = e_θ / r, ∇ρ = (e_r − (R'/R) e_θ) / R.
    const Vec2 er = l * (1.0f / out.r);
    const Vec2 et{-er.y, er.x};
    const float inv_r = 1.0f / rs.value;
    out.grad = er * (out.d_rho * inv_r) +
               et * (out.d_theta / out.r - out.d_rho * rs.slope * inv_r * inv_r);
  }
  return out;
}

Result<Profile> lake_profile(float depth, float shore_width) {
  if (!(depth >= 0.0f) || !std::isfinite(depth))
    return preset_error("lake", "depth", "must be finite and >= 0", depth);
  if (!(shore_width > 0.0f && shore_width < 1.0f))
    return preset_error("lake", "shore_width", "must be in (0, 1) (a fraction of the radius)",
                        shore_width);
  const ProfilePoint p[] = {{0.0f, -depth}, {1.0f - shore_width, -0.2f * depth}, {1.0f, 0.0f}};
  return Profile::custom(p);
}

Result<Profile> crater_profile(float depth, float rim_height, float rim_width) {
  if (!(depth >= 0.0f) || !std::isfinite(depth))
    return preset_error("crater", "depth", "must be finite and >= 0", depth);
  if (!(rim_height >= 0.0f) || !std::isfinite(rim_height))
    return preset_error("crater", "rim_height", "must be finite and >= 0", rim_height);
  if (!(rim_width > 0.0f) || !std::isfinite(rim_width))
    return preset_error("crater", "rim_width", "must be positive and finite (in rho units)",
                        rim_width);
  const ProfilePoint p[] = {
      {0.0f, -depth}, {0.5f, -0.9f * depth}, {1.0f, rim_height}, {1.0f + rim_width, 0.0f}};
  return Profile::custom(p);
}

Result<Profile> plateau_profile(float height, float cliff_width) {
  if (!std::isfinite(height)) return preset_error("plateau", "height", "must be finite", height);
  if (!(cliff_width > 0.0f && cliff_width < 2.0f))
    return preset_error("plateau", "cliff_width", "must be in (0, 2) (rho units)", cliff_width);
  const ProfilePoint p[] = {
      {0.0f, height}, {1.0f - 0.5f * cliff_width, height}, {1.0f + 0.5f * cliff_width, 0.0f}};
  return Profile::custom(p);
}

}  // namespace terrain
