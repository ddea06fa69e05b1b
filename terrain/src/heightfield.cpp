// Bilinear heightfields and the convex quadrangle mapping of image primitives.
//
// Everything evaluated per sample reads a packed float record through `pool[base + k]` with
// integer k and uses only fixed loops (no recursion, no other pointers), so the functions
// translate line by line to GLSL. The bounds (Lipschitz constants, value range, inverse Jacobian
// norm) are computed once in double at creation and rounded up.
//
// Slope of the border fall-off. With s = min(u, 1 − u)/margin_u and t = min(v, 1 − v)/margin_v,
// b = w(s) w(t) and
//   |∇b|² = (w'(s) w(t) / margin_u)² + (w(s) w'(t) / margin_v)²
//         ≤ max(1/margin_u, 1/margin_v)² · (w'(s)² w(t)² + w(s)² w'(t)²).
// Each term alone is at most W'² (w ≤ 1, |w'| ≤ W'), which gives the easy bound √2·W'/margin. The
// sum is in fact at most W'², reached at (s, t) = (1/√5, 1): where w'(s) is large w(s) is small
// (w(1/√5) = 0.488), and w' vanishes where w reaches 1. This is a numerical finding, not a
// proof: the max over a 2001² grid of [0, 1]² sits at (0.447, 1) and equals W' to 1e-6, the
// tests repeat that on a 1501² grid and check |α(p) − α(q)| ≤ λ|p − q| on dense random pairs.
// So the bound used is W'·max(1/margin_u, 1/margin_v), the same as for w(distance to the
// boundary / margin), whose gradient would instead jump across the corner diagonals.
#include "terrain/heightfield.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <string>

namespace terrain {
namespace {

namespace hl = heightfield_layout;

// Clamp to [0, 1]; NaN goes to 0 so that index arithmetic stays in range.
float clamp01(float x) {
  return x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f;
}

// Rounds a non-negative double bound up to a float that is still a bound.
float round_up(double x) {
  const auto f = static_cast<float>(x);
  return static_cast<double>(f) >= x ? f
                                     : std::nextafter(f, std::numeric_limits<float>::infinity());
}

// Bilinear interpolation of the n×m grid stored row-major at pool[grid ...]. (u, v) are clamped to
// the unit square; the derivative across a clamp is 0. The cell is chosen by floor and clamped to
// the last one, so u = 1 uses cell n−2 with fx = 1.
UvSample bilinear(const float* pool, std::size_t grid, int n, int m, float u, float v) {
  const float x = clamp01(u) * static_cast<float>(n - 1);
  const float y = clamp01(v) * static_cast<float>(m - 1);
  // x, y ≥ 0, so truncation is floor.
  const int i = std::min(static_cast<int>(x), n - 2);
  const int j = std::min(static_cast<int>(y), m - 2);
  const float fx = x - static_cast<float>(i);
  const float fy = y - static_cast<float>(j);
  const std::size_t k00 = grid + static_cast<std::size_t>(j) * static_cast<std::size_t>(n) +
                          static_cast<std::size_t>(i);
  const std::size_t k01 = k00 + static_cast<std::size_t>(n);
  const float h00 = pool[k00];
  const float h10 = pool[k00 + 1];
  const float h01 = pool[k01];
  const float h11 = pool[k01 + 1];
  // Convex-combination form: exact at the samples (fx, fy ∈ {0, 1}).
  const float top = (1.0f - fx) * h00 + fx * h10;
  const float bottom = (1.0f - fx) * h01 + fx * h11;
  UvSample s;
  s.value = (1.0f - fy) * top + fy * bottom;
  if (u >= 0.0f && u <= 1.0f) {
    s.du = static_cast<float>(n - 1) * ((1.0f - fy) * (h10 - h00) + fy * (h11 - h01));
  }
  if (v >= 0.0f && v <= 1.0f) s.dv = static_cast<float>(m - 1) * (bottom - top);
  return s;
}

/// Catmull-Rom weights of the four samples around t in [0, 1] (from one before the cell to one
/// after) and their derivatives. Written op by op as gpu/glsl/nodes.glsl's hf_cubic_weights.
struct CubicWeights {
  float w[4];
  float d[4];
};

CubicWeights cubic_weights(float t) {
  const float t2 = t * t;
  const float t3 = t2 * t;
  CubicWeights c{};
  c.w[0] = (2.0f * t2 - t3 - t) * 0.5f;
  c.w[1] = (3.0f * t3 - 5.0f * t2 + 2.0f) * 0.5f;
  c.w[2] = (4.0f * t2 - 3.0f * t3 + t) * 0.5f;
  c.w[3] = (t3 - t2) * 0.5f;
  c.d[0] = (4.0f * t - 3.0f * t2 - 1.0f) * 0.5f;
  c.d[1] = (9.0f * t2 - 10.0f * t) * 0.5f;
  c.d[2] = (8.0f * t - 9.0f * t2 + 1.0f) * 0.5f;
  c.d[3] = (3.0f * t2 - 2.0f * t) * 0.5f;
  return c;
}

// Catmull-Rom bicubic over a grid of n × m floats at pool[grid]; clamping as bilinear().
UvSample bicubic(const float* pool, std::size_t grid, int n, int m, float u, float v) {
  const float x = clamp01(u) * static_cast<float>(n - 1);
  const float y = clamp01(v) * static_cast<float>(m - 1);
  const int i = std::min(static_cast<int>(x), n - 2);
  const int j = std::min(static_cast<int>(y), m - 2);
  const CubicWeights cx = cubic_weights(x - static_cast<float>(i));
  const CubicWeights cy = cubic_weights(y - static_cast<float>(j));
  float value = 0.0f, along_u = 0.0f, along_v = 0.0f;
  for (int r = 0; r < 4; ++r) {
    const int row = std::clamp(j - 1 + r, 0, m - 1);
    const std::size_t at = grid + static_cast<std::size_t>(row) * static_cast<std::size_t>(n);
    float row_value = 0.0f, row_slope = 0.0f;
    for (int c = 0; c < 4; ++c) {
      const float h = pool[at + static_cast<std::size_t>(std::clamp(i - 1 + c, 0, n - 1))];
      row_value = row_value + cx.w[c] * h;
      row_slope = row_slope + cx.d[c] * h;
    }
    value = value + cy.w[r] * row_value;
    along_u = along_u + cy.w[r] * row_slope;
    along_v = along_v + cy.d[r] * row_value;
  }
  UvSample s;
  s.value = value;
  if (u >= 0.0f && u <= 1.0f) s.du = static_cast<float>(n - 1) * along_u;
  if (v >= 0.0f && v <= 1.0f) s.dv = static_cast<float>(m - 1) * along_v;
  return s;
}

// The Wyvill-type ramp and its slope at once.
struct Ramp {
  float value = 0.0f;
  float slope = 0.0f;
};

Ramp ramp(float t) {
  if (!(t > 0.0f)) return {0.0f, 0.0f};  // also NaN
  if (t >= 1.0f) return {1.0f, 0.0f};
  const float q = 1.0f - t * t;
  return {1.0f - q * q * q, 6.0f * t * q * q};
}

// The fall-off along one axis: w(min(x, 1 − x) / margin) and its derivative wrt x.
Ramp border_ramp(float x, float margin) {
  const bool low = x < 0.5f;
  const Ramp r = ramp((low ? x : 1.0f - x) / margin);
  return {r.value, (low ? r.slope : -r.slope) / margin};
}

std::size_t to_size(int x) {
  return static_cast<std::size_t>(x);
}

const char* const kCornerNames[4] = {"a", "b", "c", "d"};

}  // namespace

float wyvill_ramp(float t) {
  return ramp(t).value;
}
float wyvill_ramp_slope(float t) {
  return ramp(t).slope;
}

UvSample heightfield_height(const float* pool, std::size_t base, float u, float v) {
  const int n = static_cast<int>(pool[base + hl::kColumns]);
  const int m = static_cast<int>(pool[base + hl::kRows]);
  const float offset = pool[base + hl::kOffset];
  const float scale = pool[base + hl::kScale];
  const UvSample s = pool[base + hl::kCubic] > 0.5f
                         ? bicubic(pool, base + hl::kHeader, n, m, u, v)
                         : bilinear(pool, base + hl::kHeader, n, m, u, v);
  return {offset + scale * s.value, scale * s.du, scale * s.dv};
}

UvSample heightfield_weight(const float* pool, std::size_t base, float u, float v) {
  const int n = static_cast<int>(pool[base + hl::kColumns]);
  const int m = static_cast<int>(pool[base + hl::kRows]);
  const Ramp bu = border_ramp(u, pool[base + hl::kMarginU]);
  const Ramp bv = border_ramp(v, pool[base + hl::kMarginV]);
  UvSample border{bu.value * bv.value, bu.slope * bv.value, bu.value * bv.slope};
  if (!(pool[base + hl::kHasWeight] > 0.5f)) return border;

  const std::size_t grid = base + hl::kHeader + to_size(n) * to_size(m);
  const UvSample omega = bilinear(pool, grid, n, m, u, v);
  // The ramp clamps ω to [0, 1] and has zero slope at both ends, so the clamp leaves no kink.
  const Ramp a = ramp(omega.value);
  return {a.value * border.value, a.value * border.du + border.value * a.slope * omega.du,
          a.value * border.dv + border.value * a.slope * omega.dv};
}

Result<Heightfield> Heightfield::create(const Raster& raster, const HeightfieldParams& params) {
  const int n = raster.width;
  const int m = raster.height;
  if (n < 2 || m < 2) {
    return Error{"heightfield needs at least 2x2 samples, got " + std::to_string(n) + "x" +
                     std::to_string(m),
                 ""};
  }
  const std::int64_t count = std::int64_t{n} * std::int64_t{m};
  // Counts and indices stay exact in the float record (and in 32-bit GLSL ints).
  if (count > (std::int64_t{1} << 24)) {
    return Error{"heightfield has " + std::to_string(count) + " samples; at most 16777216 fit", ""};
  }
  const std::size_t size = static_cast<std::size_t>(count);
  if (raster.samples.size() != size) {
    return Error{"heightfield raster holds " + std::to_string(raster.samples.size()) +
                     " samples for " + std::to_string(n) + "x" + std::to_string(m),
                 ""};
  }
  if (!raster.weights.empty() && raster.weights.size() != size) {
    return Error{"heightfield weight grid holds " + std::to_string(raster.weights.size()) +
                     " samples for " + std::to_string(n) + "x" + std::to_string(m),
                 ""};
  }
  if (!std::isfinite(params.offset) || !std::isfinite(params.scale)) {
    return Error{"heightfield offset and scale must be finite", ""};
  }
  for (const float margin : {params.margin_u, params.margin_v}) {
    // Above 0.5 the fall-offs from opposite borders would meet at the kink of min(x, 1 − x).
    if (!(margin > 0.0f && margin <= 0.5f)) {
      return Error{"heightfield border margin must lie in (0, 0.5], got " + std::to_string(margin),
                   ""};
    }
  }
  const bool has_weight = !raster.weights.empty();
  for (std::size_t k = 0; k < size; ++k) {
    const bool bad_height = !std::isfinite(raster.samples[k]);
    if (bad_height || (has_weight && !std::isfinite(raster.weights[k]))) {
      return Error{std::string("heightfield ") + (bad_height ? "height" : "weight") +
                       " sample at pixel (x=" + std::to_string(k % to_size(n)) +
                       ", y=" + std::to_string(k / to_size(n)) + ") is not finite",
                   ""};
    }
  }

  // Largest neighbour differences per axis (in sample units) of a grid.
  auto max_differences = [&](const std::vector<float>& grid, double& along_u, double& along_v) {
    along_u = 0.0;
    along_v = 0.0;
    for (int j = 0; j < m; ++j) {
      for (int i = 0; i < n; ++i) {
        const double h = grid[to_size(j) * to_size(n) + to_size(i)];
        if (i + 1 < n) {
          along_u = std::max(along_u, std::abs(grid[to_size(j) * to_size(n) + to_size(i + 1)] - h));
        }
        if (j + 1 < m) {
          along_v = std::max(along_v, std::abs(grid[to_size(j + 1) * to_size(n) + to_size(i)] - h));
        }
      }
    }
  };

  Heightfield hf;
  hf.columns_ = n;
  hf.rows_ = m;
  hf.has_weight_ = has_weight;
  hf.params_ = params;

  double du = 0.0;
  double dv = 0.0;
  max_differences(raster.samples, du, dv);
  const double scale = std::abs(static_cast<double>(params.scale));
  // Bicubic slopes reach 2 × 1.25 times the largest difference (heightfield.hpp).
  const double interpolation = params.cubic ? 2.5 : 1.0;
  const double lu = interpolation * scale * du * (n - 1);
  const double lv = interpolation * scale * dv * (m - 1);
  // A few ulps of headroom: the float evaluation rounds each difference and product.
  constexpr double kHeadroom = 1.0 + 1e-5;
  hf.lipschitz_u_ = round_up(lu * kHeadroom);
  hf.lipschitz_v_ = round_up(lv * kHeadroom);
  hf.lipschitz_ = round_up(std::sqrt(lu * lu + lv * lv) * kHeadroom);

  const double slope = kWyvillRampMaxSlope;
  double weight_lipschitz = slope * std::max(1.0 / params.margin_u, 1.0 / params.margin_v);
  if (has_weight) {
    double wu = 0.0;
    double wv = 0.0;
    max_differences(raster.weights, wu, wv);
    const double gu = wu * (n - 1);
    const double gv = wv * (m - 1);
    weight_lipschitz += slope * std::sqrt(gu * gu + gv * gv);
  }
  hf.weight_lipschitz_ = round_up(weight_lipschitz * kHeadroom);

  const auto [lo, hi] = std::minmax_element(raster.samples.begin(), raster.samples.end());
  const double a = params.offset + static_cast<double>(params.scale) * *lo;
  const double b = params.offset + static_cast<double>(params.scale) * *hi;
  const double pad = 1e-6 * std::max({std::abs(a), std::abs(b), 1e-30});
  hf.range_ = {static_cast<float>(std::min(a, b) - pad), static_cast<float>(std::max(a, b) + pad)};
  if (params.cubic) {
    const double middle = 0.5 * (a + b);
    const double half = 0.5 * std::abs(b - a) * 1.5625;
    hf.range_ = {static_cast<float>(middle - half - pad), static_cast<float>(middle + half + pad)};
  }

  std::vector<float>& r = hf.record_;
  r.assign(hl::kHeader, 0.0f);
  r[hl::kColumns] = static_cast<float>(n);
  r[hl::kRows] = static_cast<float>(m);
  r[hl::kOffset] = params.offset;
  r[hl::kScale] = params.scale;
  r[hl::kMarginU] = params.margin_u;
  r[hl::kMarginV] = params.margin_v;
  r[hl::kCubic] = params.cubic ? 1.0f : 0.0f;
  r[hl::kHasWeight] = has_weight ? 1.0f : 0.0f;
  r.insert(r.end(), raster.samples.begin(), raster.samples.end());
  if (has_weight) r.insert(r.end(), raster.weights.begin(), raster.weights.end());
  return hf;
}

void Heightfield::pack(std::vector<float>& pool) const {
  pool.insert(pool.end(), record_.begin(), record_.end());
}

UvMap quad_inverse(const float* pool, std::size_t base, Vec2 p) {
  namespace ql = quad_layout;
  Vec2 corner[4];
  for (std::size_t k = 0; k < 4; ++k) {
    corner[k] = {pool[base + ql::kCorners + 2 * k], pool[base + ql::kCorners + 2 * k + 1]};
  }
  const float sigma = pool[base + ql::kOrientation];

  bool inside = true;
  for (std::size_t k = 0; k < 4; ++k) {
    const Vec2 edge = corner[(k + 1) & 3] - corner[k];
    if (sigma * cross(edge, p - corner[k]) < 0.0f) inside = false;
  }

  UvMap map;
  map.inside = inside;
  if (inside) {
    const Vec2 a = corner[0];
    const Vec2 e = corner[1] - a;
    const Vec2 f = corner[3] - a;
    const Vec2 g = (corner[2] - corner[3]) - e;  // a − b + c − d
    const Vec2 h = p - a;
    // h = u e + v f + u v g. Eliminating u gives k2 v² + k1 v + k0 = 0, whose derivative at a
    // root equals the Jacobian determinant det[e + v g, f + u g]. The quad's own root is the one
    // where that determinant has the quad's sign: 2 k2 v + k1 = σ √Δ.
    const float k2 = cross(g, f);
    const float k1 = cross(e, f) + cross(h, g);
    const float k0 = cross(h, e);
    const float root = std::sqrt(std::max(k1 * k1 - 4.0f * k0 * k2, 0.0f));
    float v = 0.0f;
    if (sigma * k1 > 0.0f) {
      // −k1 and −σ√Δ have the same sign: no cancellation, and no division by a small k2
      // (a parallelogram has k2 = 0 and this is then the linear root −k0/k1).
      v = 2.0f * k0 / (-k1 - sigma * root);
    } else if (k2 != 0.0f) {
      // −k1 and σ√Δ have the same sign; inside the quad this branch implies |k2| > 0.
      v = (-k1 + sigma * root) / (2.0f * k2);
    }
    v = clamp01(v);
    Vec2 ev = e + v * g;  // ∂p/∂u at this v; non-zero for v ∈ [0, 1]
    float u = clamp01(dot(h - v * f, ev) / dot(ev, ev));
    // Where det J is small next to |k1| (strongly tapered quads, near the narrow end) the
    // discriminant cancels and v keeps only a few digits. Newton steps on the forward map are
    // conditioned by J itself, so two of them bring (u, v) to the accuracy the float inputs allow.
    Vec2 fu = f + u * g;  // ∂p/∂v
    for (int iteration = 0; iteration < 2; ++iteration) {
      const Vec2 residual = (u * e + v * fu) - h;  // p(u, v) − p, relative to a
      const float inv_det = 1.0f / cross(ev, fu);
      u = clamp01(u - cross(residual, fu) * inv_det);
      v = clamp01(v - cross(ev, residual) * inv_det);
      ev = e + v * g;
      fu = f + u * g;
    }
    const float det = cross(ev, fu);
    map.u = u;
    map.v = v;
    map.du = Vec2{fu.y, -fu.x} * (1.0f / det);
    map.dv = Vec2{-ev.y, ev.x} * (1.0f / det);
    return map;
  }

  // Outside: the nearest point of the boundary, and the derivative of its edge parameter (zero
  // where the nearest point is a corner).
  float best = std::numeric_limits<float>::infinity();
  for (std::size_t k = 0; k < 4; ++k) {
    const Vec2 start = corner[k];
    const Vec2 edge = corner[(k + 1) & 3] - start;
    const float inv_len2 = 1.0f / dot(edge, edge);
    const float t_raw = dot(p - start, edge) * inv_len2;
    const float t = clamp01(t_raw);
    const Vec2 off = p - (start + t * edge);
    const float dist2 = dot(off, off);
    if (dist2 < best) {
      best = dist2;
      const Vec2 grad = (t_raw > 0.0f && t_raw < 1.0f) ? edge * inv_len2 : Vec2{};
      // Edges in order: ab (v = 0, u = t), bc (u = 1, v = t), cd (v = 1, u = 1 − t),
      // da (u = 0, v = 1 − t).
      map.u = k == 0 ? t : (k == 1 ? 1.0f : (k == 2 ? 1.0f - t : 0.0f));
      map.v = k == 0 ? 0.0f : (k == 1 ? t : (k == 2 ? 1.0f : 1.0f - t));
      map.du = k == 0 ? grad : (k == 2 ? -grad : Vec2{});
      map.dv = k == 1 ? grad : (k == 3 ? -grad : Vec2{});
    }
  }
  return map;
}

Result<QuadMap> QuadMap::create(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  const Vec2 corners[4] = {a, b, c, d};
  for (int k = 0; k < 4; ++k) {
    if (!std::isfinite(corners[k].x) || !std::isfinite(corners[k].y)) {
      return Error{std::string("quad corner ") + kCornerNames[k] + " is not finite", ""};
    }
  }
  // Edges and turns in double: the checks must not depend on float rounding of the inputs.
  double ex[4];
  double ey[4];
  double len[4];
  double longest = 0.0;
  for (int k = 0; k < 4; ++k) {
    ex[k] = static_cast<double>(corners[(k + 1) & 3].x) - corners[k].x;
    ey[k] = static_cast<double>(corners[(k + 1) & 3].y) - corners[k].y;
    len[k] = std::hypot(ex[k], ey[k]);
    longest = std::max(longest, len[k]);
  }
  for (int k = 0; k < 4; ++k) {
    if (!(len[k] > 1e-6 * longest)) {
      return Error{std::string("quad is degenerate: corners ") + kCornerNames[k] + " and " +
                       kCornerNames[(k + 1) & 3] + " coincide",
                   ""};
    }
  }
  // turn[k] = cross(incoming edge, outgoing edge) at corner k = det J at that corner of the square.
  double turn[4];
  double sine[4];
  int positive = 0;
  int negative = 0;
  constexpr double kMinSine = 1e-4;  // about 0.006°
  for (int k = 0; k < 4; ++k) {
    const int in = (k + 3) & 3;
    turn[k] = ex[in] * ey[k] - ey[in] * ex[k];
    sine[k] = turn[k] / (len[in] * len[k]);
    positive += sine[k] > kMinSine ? 1 : 0;
    negative += sine[k] < -kMinSine ? 1 : 0;
  }
  if (positive > 0 && negative > 0) {
    // Name a corner that turns against the majority (or the first one on a tie).
    const bool odd_is_negative = negative <= positive;
    int odd = 0;
    while (odd_is_negative ? !(sine[odd] < -kMinSine) : !(sine[odd] > kMinSine)) ++odd;
    return Error{std::string("quad is not convex: it turns the other way at corner ") +
                     kCornerNames[odd] + " (corners must go round a convex quadrangle in order)",
                 ""};
  }
  for (int k = 0; k < 4; ++k) {
    if (!(std::abs(sine[k]) > kMinSine)) {
      return Error{std::string("quad is degenerate: corners ") + kCornerNames[(k + 3) & 3] + ", " +
                       kCornerNames[k] + " and " + kCornerNames[(k + 1) & 3] + " are collinear",
                   ""};
    }
  }

  QuadMap quad;
  for (int k = 0; k < 4; ++k) quad.corners_[k] = corners[k];
  quad.orientation_ = positive == 4 ? 1.0f : -1.0f;

  // The forward Jacobian at each corner of the square has the two edges meeting there as columns
  // (up to sign). ‖J⁻¹‖₂ = σmax/|det| with σmax = (√(F² + 2|det|) + √(F² − 2|det|)) / 2.
  double bound = 0.0;
  for (int k = 0; k < 4; ++k) {
    const int in = (k + 3) & 3;
    const double frob2 = len[in] * len[in] + len[k] * len[k];
    const double det = std::abs(turn[k]);
    const double sigma_max =
        0.5 * (std::sqrt(frob2 + 2.0 * det) + std::sqrt(std::max(frob2 - 2.0 * det, 0.0)));
    bound = std::max({bound, sigma_max / det, 1.0 / len[k]});
  }
  // Headroom for float evaluation of the Jacobian.
  quad.inverse_jacobian_bound_ = round_up(bound * (1.0 + 1e-5));

  for (std::size_t k = 0; k < 4; ++k) {
    quad.record_[quad_layout::kCorners + 2 * k] = corners[k].x;
    quad.record_[quad_layout::kCorners + 2 * k + 1] = corners[k].y;
  }
  quad.record_[quad_layout::kOrientation] = quad.orientation_;
  return quad;
}

Vec2 QuadMap::forward(float u, float v) const {
  const Vec2 a = corners_[0];
  const Vec2 e = corners_[1] - a;
  const Vec2 f = corners_[3] - a;
  const Vec2 g = (corners_[2] - corners_[3]) - e;
  return a + u * e + v * f + (u * v) * g;
}

void QuadMap::forward_jacobian(float u, float v, Vec2& dp_du, Vec2& dp_dv) const {
  const Vec2 e = corners_[1] - corners_[0];
  const Vec2 f = corners_[3] - corners_[0];
  const Vec2 g = (corners_[2] - corners_[3]) - e;
  dp_du = e + v * g;
  dp_dv = f + u * g;
}

UvMap QuadMap::inverse(Vec2 p) const {
  return quad_inverse(record_, 0, p);
}

Box2 QuadMap::bounds() const {
  Box2 box;
  for (const Vec2& corner : corners_) box = box.with(corner);
  return box;
}

void QuadMap::pack(std::vector<float>& pool) const {
  pool.insert(pool.end(), std::begin(record_), std::end(record_));
}

}  // namespace terrain
