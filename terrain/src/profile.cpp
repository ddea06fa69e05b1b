// Shape-preserving C1 piecewise-quadratic profiles. Construction and bounds run in double on the
// stored float data, so every bound describes exactly the function the float evaluator computes
// (up to the evaluator's own rounding). See docs/geometry.md §1.
#include "terrain/profile.hpp"

#include "geometry_util.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>

namespace terrain {
namespace {

using geometry_util::num;
using geometry_util::preset_error;
using geometry_util::round_down;
using geometry_util::round_up;

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Value, slope and second derivative of the real-arithmetic profile defined by the stored nodes.
/// Mirrors profile_eval() operation by operation (in double), including the choice of half.
struct Exact {
  double value = 0.0;
  double slope = 0.0;
  double curvature = 0.0;
};

Exact eval_exact(std::span<const ProfilePoint> p, std::span<const float> m, double x) {
  const std::size_t n = p.size();
  if (x <= p[0].d) return {p[0].h, 0.0, 0.0};
  if (x >= p[n - 1].d) return {p[n - 1].h, 0.0, 0.0};
  std::size_t k = static_cast<std::size_t>(
      std::upper_bound(p.begin(), p.end(), x,
                       [](double v, const ProfilePoint& q) { return v < q.d; }) -
      p.begin() - 1);
  const double d0 = p[k].d, d1 = p[k + 1].d, h0 = p[k].h, h1 = p[k + 1].h;
  const double m0 = m[k], m1 = m[k + 1];
  const double big_h = d1 - d0;
  const double mb = 2.0 * (h1 - h0) / big_h - 0.5 * (m0 + m1);
  const bool right = x - d0 > 0.5 * big_h;
  const double y = right ? h1 : h0;
  const double s0 = right ? m1 : m0;
  const double q = right ? (m1 - mb) / big_h : (mb - m0) / big_h;
  const double w = right ? x - d1 : x - d0;
  return {y + (s0 + q * w) * w, s0 + 2.0 * q * w, 2.0 * q};
}

struct Term {
  const Profile* profile;
  double weight;
};

struct Extremes {
  double lo = kInf;
  double hi = -kInf;
  double max_abs_slope = 0.0;
};

/// Exact extremes of F = Σ weight_i · c_i over [lo, hi] (ends may be infinite). F is quadratic
/// between consecutive breakpoints (control points and interval midpoints of every term) and
/// constant outside all of them, so its extremes lie at breakpoints, at the clipped interval ends,
/// or at the vertex of a piece; F' is linear between breakpoints, so |F'| peaks at those points.
Extremes extremes(std::span<const Term> terms, double lo, double hi) {
  Extremes out;
  if (!(lo <= hi)) return out;
  std::vector<double> breaks;
  for (const Term& t : terms) {
    const auto p = t.profile->points();
    for (std::size_t k = 0; k < p.size(); ++k) {
      breaks.push_back(p[k].d);
      if (k + 1 < p.size()) breaks.push_back(0.5 * (static_cast<double>(p[k].d) + p[k + 1].d));
    }
  }
  std::sort(breaks.begin(), breaks.end());
  breaks.erase(std::unique(breaks.begin(), breaks.end()), breaks.end());
  const double a = std::clamp(lo, breaks.front(), breaks.back());
  const double b = std::clamp(hi, breaks.front(), breaks.back());
  std::vector<double> xs{a};
  for (double x : breaks)
    if (x > a && x < b) xs.push_back(x);
  if (b > a) xs.push_back(b);

  auto eval = [&](double x) {
    Exact e;
    for (const Term& t : terms) {
      const Exact c = eval_exact(t.profile->points(), t.profile->slopes(), x);
      e.value += t.weight * c.value;
      e.slope += t.weight * c.slope;
      e.curvature += t.weight * c.curvature;
    }
    return e;
  };
  auto take = [&](double v) {
    out.lo = std::min(out.lo, v);
    out.hi = std::max(out.hi, v);
  };
  // Outside the domain the slope is 0, so only points inside [a, b] contribute to |F'|. A point
  // at a domain end of one term but outside [lo, hi] never enters xs.
  for (std::size_t i = 0; i < xs.size(); ++i) {
    const Exact e = eval(xs[i]);
    take(e.value);
    out.max_abs_slope = std::max(out.max_abs_slope, std::abs(e.slope));
    if (i + 1 < xs.size()) {
      const double x0 = xs[i], x1 = xs[i + 1];
      const Exact mid = eval(0.5 * (x0 + x1));
      if (mid.curvature != 0.0) {
        const double vertex = x0 - e.slope / mid.curvature;
        if (vertex > x0 && vertex < x1) take(eval(vertex).value);
      }
    }
  }
  // A clipped end that left the domain still sees F' = 0 there; the domain-end breakpoint has
  // slope 0 anyway, so nothing is lost.
  return out;
}

constexpr Interval everything() {
  return {-std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity()};
}

Interval to_interval(const Extremes& e) {
  if (e.lo > e.hi) return {};
  return {round_down(e.lo), round_up(e.hi)};
}

}  // namespace

Profile::Profile(std::vector<ProfilePoint> points, std::vector<float> slopes)
    : points_(std::move(points)), slopes_(std::move(slopes)) {
  packed_.reserve(1 + 3 * points_.size());
  packed_.push_back(static_cast<float>(points_.size()));
  for (std::size_t k = 0; k < points_.size(); ++k) {
    packed_.push_back(points_[k].d);
    packed_.push_back(points_[k].h);
    packed_.push_back(slopes_[k]);
  }
}

Result<Profile> Profile::custom(std::span<const ProfilePoint> points) {
  if (points.size() < static_cast<std::size_t>(kMinPoints))
    return Error{"a profile needs at least 2 points, got " + std::to_string(points.size()),
                 "/points"};
  if (points.size() > static_cast<std::size_t>(kMaxPoints))
    return Error{"a profile has at most 64 points, got " + std::to_string(points.size()),
                 "/points"};
  for (std::size_t k = 0; k < points.size(); ++k) {
    const std::string where = "/points/" + std::to_string(k);
    if (!std::isfinite(points[k].d) || !std::isfinite(points[k].h))
      return Error{"profile point " + std::to_string(k) + " is not finite (NaN or infinity)",
                   where};
    if (k > 0 && !(points[k].d > points[k - 1].d))
      return Error{"profile abscissae must be strictly increasing: point " + std::to_string(k) +
                       " has d = " + num(points[k].d) + " after d = " + num(points[k - 1].d),
                   where};
  }
  const std::size_t n = points.size();
  std::vector<double> delta(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k)
    delta[k] = (static_cast<double>(points[k + 1].h) - points[k].h) /
               (static_cast<double>(points[k + 1].d) - points[k].d);
  // Zero slope at both ends (C1 with the constant extension) and at local extrema; elsewhere the
  // harmonic mean of the neighbouring secants, which is at most 2·min(|δ|) and so keeps every
  // interval monotone (the midpoint slope 2δ − (m0 + m1)/2 keeps the sign of δ).
  std::vector<float> slopes(n, 0.0f);
  for (std::size_t k = 1; k + 1 < n; ++k) {
    const double a = delta[k - 1], b = delta[k];
    if (!(a * b > 0.0)) continue;
    const double limit = 2.0 * std::min(std::abs(a), std::abs(b));
    float m = static_cast<float>(2.0 * a * b / (a + b));
    // Rounding to float must not break the bound that makes the intervals monotone.
    while (std::abs(static_cast<double>(m)) > limit) m = std::nextafter(m, 0.0f);
    slopes[k] = m;
  }
  return Profile(std::vector<ProfilePoint>(points.begin(), points.end()), std::move(slopes));
}

Result<Profile> Profile::stream(float width, float depth) {
  if (!(width > 0.0f) || !std::isfinite(width))
    return preset_error("stream", "width", "must be positive and finite", width);
  if (!(depth >= 0.0f) || !std::isfinite(depth))
    return preset_error("stream", "depth", "must be finite and >= 0", depth);
  const float w = 0.5f * width, q = 0.25f * width;
  const ProfilePoint p[] = {
      {-w, 0.0f}, {-q, -0.6f * depth}, {0.0f, -depth}, {q, -0.6f * depth}, {w, 0.0f}};
  return custom(p);
}

Result<Profile> Profile::river(float width, float depth, float bank_width) {
  return channel("river", width, depth, bank_width, 0.0f);
}

Result<Profile> Profile::meander(float width, float depth, float bank_width, float asymmetry) {
  return channel("meander", width, depth, bank_width, asymmetry);
}

Result<Profile> Profile::channel(const char* name, float width, float depth, float bank_width,
                                 float asymmetry) {
  if (!(width > 0.0f) || !std::isfinite(width))
    return preset_error(name, "width", "must be positive and finite", width);
  if (!(depth >= 0.0f) || !std::isfinite(depth))
    return preset_error(name, "depth", "must be finite and >= 0", depth);
  if (!(bank_width > 0.0f) || !std::isfinite(bank_width))
    return preset_error(name, "bank_width", "must be positive and finite", bank_width);
  if (!(asymmetry >= -1.0f && asymmetry <= 1.0f))
    return preset_error(name, "asymmetry", "must be in [-1, 1]", asymmetry);
  // Built for a cut bank on the left (d > 0) and mirrored for negative asymmetry.
  const float a = std::abs(asymmetry);
  const float w = 0.5f * width;
  ProfilePoint p[] = {
      {-(w + bank_width * (1.0f + a)), 0.0f},       // top of the gentle point bar
      {-w, -(0.9f - 0.6f * a) * depth},             // point bar rises as asymmetry grows
      {a * 0.25f * width, -depth},                  // thalweg moves towards the cut bank
      {w, -0.9f * depth},                           // toe of the cut bank
      {w + bank_width * (1.0f - 0.75f * a), 0.0f},  // cut bank top: steeper with asymmetry
  };
  if (asymmetry < 0.0f) {
    std::reverse(std::begin(p), std::end(p));
    for (ProfilePoint& q : p) q.d = -q.d;
  }
  return custom(p);
}

Result<Profile> Profile::road(float width, float carriageway, float embankment, float crown) {
  if (!(carriageway > 0.0f) || !std::isfinite(carriageway))
    return preset_error("road", "carriageway", "must be positive and finite", carriageway);
  if (!(width >= carriageway) || !std::isfinite(width))
    return preset_error("road", "width", "must be finite and >= carriageway", width);
  if (!(embankment > 0.0f) || !std::isfinite(embankment))
    return preset_error("road", "embankment", "must be positive and finite", embankment);
  if (!(crown >= 0.0f && crown <= 0.05f * carriageway))
    return preset_error("road", "crown", "must be in [0, 0.05 * carriageway]", crown);
  const float c = 0.5f * carriageway, w = 0.5f * width;
  std::vector<ProfilePoint> p;
  p.push_back({-(w + embankment), 0.0f});
  if (w > c) p.push_back({-w, 0.0f});
  p.push_back({-c, 0.0f});
  p.push_back({0.0f, crown});
  p.push_back({c, 0.0f});
  if (w > c) p.push_back({w, 0.0f});
  p.push_back({w + embankment, 0.0f});
  return custom(p);
}

ProfileSample Profile::sample(float d) const {
  return profile_eval(packed_.data(), d);
}

Interval Profile::domain() const {
  return {points_.front().d, points_.back().d};
}

float Profile::half_extent() const {
  return std::max(std::abs(points_.front().d), std::abs(points_.back().d));
}

Interval Profile::range() const {
  return range(everything());
}

Interval Profile::range(Interval d) const {
  const Term t[] = {{this, 1.0}};
  return to_interval(extremes(t, d.lo, d.hi));
}

float Profile::max_slope() const {
  return max_slope(everything());
}

float Profile::max_slope(Interval d) const {
  const Term t[] = {{this, 1.0}};
  return round_up(extremes(t, d.lo, d.hi).max_abs_slope);
}

void Profile::pack(std::vector<float>& pool) const {
  pool.insert(pool.end(), packed_.begin(), packed_.end());
}

ProfileSample profile_eval(const float* packed, float d) {
  const int n = static_cast<int>(packed[0]);
  const float* node = packed + 1;  // n triples (d, h, m)
  const float first = node[0];
  const float last = node[3 * (n - 1)];
  const float x = std::min(std::max(d, first), last);
  // Binary search for the interval [d_lo, d_lo+1] holding x (a bounded loop in GLSL).
  int lo = 0;
  int hi = n - 1;
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (node[3 * mid] <= x)
      lo = mid;
    else
      hi = mid;
  }
  const float* a = node + 3 * lo;
  const float* b = a + 3;
  const float big_h = b[0] - a[0];
  const float mb = 2.0f * (b[1] - a[1]) / big_h - 0.5f * (a[2] + b[2]);
  // Each half is written around its outer control point, so control values are reproduced
  // exactly: left half from (d_k, h_k, m_k), right half from (d_k+1, h_k+1, m_k+1).
  const bool right = x - a[0] > 0.5f * big_h;
  const float y = right ? b[1] : a[1];
  const float s0 = right ? b[2] : a[2];
  const float q = right ? (b[2] - mb) / big_h : (mb - a[2]) / big_h;
  const float w = right ? x - b[0] : x - a[0];
  ProfileSample out;
  out.value = y + (s0 + q * w) * w;
  out.slope = (d < first || d > last) ? 0.0f : s0 + 2.0f * q * w;
  return out;
}

ProfileBlendSample profile_blend_eval(const float* a, const float* b, float d, float t) {
  const ProfileSample sa = profile_eval(a, d);
  const ProfileSample sb = profile_eval(b, d);
  ProfileBlendSample out;
  out.dt = sb.value - sa.value;
  out.value = sa.value + t * out.dt;
  out.slope = sa.slope + t * (sb.slope - sa.slope);
  return out;
}

Interval profile_difference(const Profile& a, const Profile& b) {
  return profile_difference(a, b, everything());
}

Interval profile_difference(const Profile& a, const Profile& b, Interval d) {
  const Term t[] = {{&a, -1.0}, {&b, 1.0}};
  return to_interval(extremes(t, d.lo, d.hi));
}

float profile_difference_max_slope(const Profile& a, const Profile& b) {
  const Term t[] = {{&a, -1.0}, {&b, 1.0}};
  return round_up(extremes(t, -kInf, kInf).max_abs_slope);
}

}  // namespace terrain
