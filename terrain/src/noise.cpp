#include "terrain/noise.hpp"

#include <algorithm>
#include <cmath>

namespace terrain::noise {
namespace {

inline int fast_floor(float x) {
  const int i = static_cast<int>(x);
  return i - static_cast<int>(x < static_cast<float>(i));
}

inline std::uint32_t u32(int v) { return static_cast<std::uint32_t>(v); }

// Quintic fade s(t) = 6t⁵ − 15t⁴ + 10t³ and s'(t) = 30t²(t − 1)², max s' = 1.875.
inline float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
inline float fade_slope(float t) { return 30.0f * t * t * (t * (t - 2.0f) + 1.0f); }

// Eight unit gradients at multiples of 45°, chosen by four hash bits: bit 2 picks a diagonal or an
// axis, bit 3 which axis, bits 0 and 1 the signs. Written as selects so batch loops vectorise.
constexpr float kDiag = 0.70710678f;
[[gnu::always_inline]] inline void grad8(std::uint32_t h, float& gx, float& gy) {
  // Pure arithmetic on the bits (no selects): GCC vectorises it.
  const float sx = static_cast<float>(1 - static_cast<int>((h & 1u) << 1));
  const float sy = static_cast<float>(1 - static_cast<int>(h & 2u));
  const float axis = static_cast<float>((h >> 2) & 1u);     // 0: diagonal, 1: axis-aligned
  const float x_axis = static_cast<float>((h >> 3) & 1u);   // which axis
  const float diagonal = 1.0f - axis;
  gx = sx * (diagonal * kDiag + axis * x_axis);
  gy = sy * (diagonal * kDiag + axis * (1.0f - x_axis));
}

// The 2D lattice hash: rows first, then columns, so a cell's four corners cost six hashes.
[[gnu::always_inline]] inline std::uint32_t row_hash(int j, std::uint32_t seed) {
  return hash(static_cast<std::uint32_t>(j) ^ seed);
}
[[gnu::always_inline]] inline std::uint32_t corner_hash(int i, std::uint32_t row) {
  return hash(static_cast<std::uint32_t>(i) ^ row);
}

// Twelve gradients towards the edge midpoints of a cube, normalised.
constexpr float kEdge = 0.70710678f;
constexpr float kGrad3[16][3] = {
    {kEdge, kEdge, 0},  {-kEdge, kEdge, 0},  {kEdge, -kEdge, 0},  {-kEdge, -kEdge, 0},
    {kEdge, 0, kEdge},  {-kEdge, 0, kEdge},  {kEdge, 0, -kEdge},  {-kEdge, 0, -kEdge},
    {0, kEdge, kEdge},  {0, -kEdge, kEdge},  {0, kEdge, -kEdge},  {0, -kEdge, -kEdge},
    {kEdge, kEdge, 0},  {-kEdge, kEdge, 0},  {0, -kEdge, kEdge},  {0, -kEdge, -kEdge}};

inline const float* grad3(int i, int j, int k, std::uint32_t seed) {
  return kGrad3[hash(u32(i), u32(j), u32(k), seed) & 15u];
}

// Scale factors making the documented ranges hold (docs/noise.md derives them):
// gradient noise with unit gradients stays within ±√(N)/2, so ×2/√N maps it to [−1, 1];
// simplex contributions are bounded per corner, summed over N+1 corners.
constexpr float kGradientScale2 = 1.41421356f;
constexpr float kGradientScale3 = 1.15470054f;
constexpr float kSimplexScale2 = 36.1f;   // 1 / (3 · max_r (½ − r²)⁴ r) rounded down
constexpr float kSimplexScale3 = 11.9f;   // 1 / (4 · max_r (0.6 − r²)⁴ r) rounded down

}  // namespace

namespace {

// Gradient noise at one point; always inlined so batch loops vectorise around it.
[[gnu::always_inline]] inline void gradient2_kernel(float x, float y, std::uint32_t seed, float& value,
                                                    float& dx, float& dy) {
  const int i = fast_floor(x), j = fast_floor(y);
  const float fx = x - static_cast<float>(i), fy = y - static_cast<float>(j);
  const std::uint32_t row0 = row_hash(j, seed), row1 = row_hash(j + 1, seed);
  float g00x, g00y, g10x, g10y, g01x, g01y, g11x, g11y;
  grad8(corner_hash(i, row0), g00x, g00y);
  grad8(corner_hash(i + 1, row0), g10x, g10y);
  grad8(corner_hash(i, row1), g01x, g01y);
  grad8(corner_hash(i + 1, row1), g11x, g11y);
  const float n00 = g00x * fx + g00y * fy;
  const float n10 = g10x * (fx - 1.0f) + g10y * fy;
  const float n01 = g01x * fx + g01y * (fy - 1.0f);
  const float n11 = g11x * (fx - 1.0f) + g11y * (fy - 1.0f);
  const float u = fade(fx), v = fade(fy);
  const float du = fade_slope(fx), dv = fade_slope(fy);
  const float nx0 = n00 + u * (n10 - n00);
  const float nx1 = n01 + u * (n11 - n01);
  // ∂/∂x: the fade's slope across the corner values plus the interpolated gradients.
  const float gx0 = g00x + u * (g10x - g00x);
  const float gx1 = g01x + u * (g11x - g01x);
  const float gy0 = g00y + u * (g10y - g00y);
  const float gy1 = g01y + u * (g11y - g01y);
  value = (nx0 + v * (nx1 - nx0)) * kGradientScale2;
  dx = (gx0 + v * (gx1 - gx0) + du * ((n10 - n00) + v * ((n11 - n01) - (n10 - n00)))) *
       kGradientScale2;
  dy = (gy0 + v * (gy1 - gy0) + dv * (nx1 - nx0)) * kGradientScale2;
}

// Simplex noise at one point (branch-free: corners outside the kernel add zero).
[[gnu::always_inline]] inline void simplex2_kernel(float x, float y, std::uint32_t seed, float& value,
                                                   float& dx, float& dy) {
  constexpr float kSkew = 0.36602540f;    // (√3 − 1) / 2
  constexpr float kUnskew = 0.21132487f;  // (3 − √3) / 6
  const float s = (x + y) * kSkew;
  const int i = fast_floor(x + s), j = fast_floor(y + s);
  const float t = static_cast<float>(i + j) * kUnskew;
  const float x0 = x - (static_cast<float>(i) - t), y0 = y - (static_cast<float>(j) - t);
  const int i1 = static_cast<int>(x0 > y0), j1 = 1 - i1;
  const float x1 = x0 - static_cast<float>(i1) + kUnskew, y1 = y0 - static_cast<float>(j1) + kUnskew;
  const float x2 = x0 - 1.0f + 2.0f * kUnskew, y2 = y0 - 1.0f + 2.0f * kUnskew;
  const std::uint32_t row0 = row_hash(j, seed), row1 = row_hash(j + 1, seed);
  const std::uint32_t row_mid = row0 ^ ((row0 ^ row1) & (0u - static_cast<std::uint32_t>(j1)));
  float v = 0.0f, gx = 0.0f, gy = 0.0f;
  auto corner = [&](float cx, float cy, std::uint32_t h) {
    const float a = std::max(0.5f - (cx * cx + cy * cy), 0.0f);
    float g0, g1;
    grad8(h, g0, g1);
    const float n = g0 * cx + g1 * cy;
    const float a2 = a * a, a4 = a2 * a2;
    v += a4 * n;
    // ∇(a⁴ n) = a⁴ g − 8 a³ n d
    gx += a4 * g0 - 8.0f * a2 * a * n * cx;
    gy += a4 * g1 - 8.0f * a2 * a * n * cy;
  };
  corner(x0, y0, corner_hash(i, row0));
  corner(x1, y1, corner_hash(i + i1, row_mid));
  corner(x2, y2, corner_hash(i + 1, row1));
  value = v * kSimplexScale2;
  dx = gx * kSimplexScale2;
  dy = gy * kSimplexScale2;
}

}  // namespace

Sample2 gradient2(float x, float y, std::uint32_t seed) {
  Sample2 s;
  gradient2_kernel(x, y, seed, s.value, s.dx, s.dy);
  return s;
}

Sample3 gradient3(float x, float y, float z, std::uint32_t seed) {
  const int i = fast_floor(x), j = fast_floor(y), k = fast_floor(z);
  const float f[3] = {x - static_cast<float>(i), y - static_cast<float>(j), z - static_cast<float>(k)};
  const float s[3] = {fade(f[0]), fade(f[1]), fade(f[2])};
  const float ds[3] = {fade_slope(f[0]), fade_slope(f[1]), fade_slope(f[2])};
  Sample3 out;
  for (int c = 0; c < 8; ++c) {
    const int cx = c & 1, cy = (c >> 1) & 1, cz = (c >> 2) & 1;
    const float* g = grad3(i + cx, j + cy, k + cz, seed);
    const float d[3] = {f[0] - static_cast<float>(cx), f[1] - static_cast<float>(cy),
                        f[2] - static_cast<float>(cz)};
    const float n = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
    const float w[3] = {cx ? s[0] : 1.0f - s[0], cy ? s[1] : 1.0f - s[1], cz ? s[2] : 1.0f - s[2]};
    const float dw[3] = {cx ? ds[0] : -ds[0], cy ? ds[1] : -ds[1], cz ? ds[2] : -ds[2]};
    const float weight = w[0] * w[1] * w[2];
    out.value += weight * n;
    out.dx += weight * g[0] + dw[0] * w[1] * w[2] * n;
    out.dy += weight * g[1] + w[0] * dw[1] * w[2] * n;
    out.dz += weight * g[2] + w[0] * w[1] * dw[2] * n;
  }
  out.value *= kGradientScale3;
  out.dx *= kGradientScale3;
  out.dy *= kGradientScale3;
  out.dz *= kGradientScale3;
  return out;
}

Sample2 simplex2(float x, float y, std::uint32_t seed) {
  Sample2 s;
  simplex2_kernel(x, y, seed, s.value, s.dx, s.dy);
  return s;
}

Sample3 simplex3(float x, float y, float z, std::uint32_t seed) {
  constexpr float kSkew = 1.0f / 3.0f, kUnskew = 1.0f / 6.0f;
  const float s = (x + y + z) * kSkew;
  const int i = fast_floor(x + s), j = fast_floor(y + s), k = fast_floor(z + s);
  const float t = static_cast<float>(i + j + k) * kUnskew;
  const float x0 = x - (static_cast<float>(i) - t), y0 = y - (static_cast<float>(j) - t),
              z0 = z - (static_cast<float>(k) - t);
  // Rank the offsets to find the simplex's corner order.
  int o1[3], o2[3];
  if (x0 >= y0) {
    if (y0 >= z0) { o1[0] = 1; o1[1] = 0; o1[2] = 0; o2[0] = 1; o2[1] = 1; o2[2] = 0; }
    else if (x0 >= z0) { o1[0] = 1; o1[1] = 0; o1[2] = 0; o2[0] = 1; o2[1] = 0; o2[2] = 1; }
    else { o1[0] = 0; o1[1] = 0; o1[2] = 1; o2[0] = 1; o2[1] = 0; o2[2] = 1; }
  } else {
    if (y0 < z0) { o1[0] = 0; o1[1] = 0; o1[2] = 1; o2[0] = 0; o2[1] = 1; o2[2] = 1; }
    else if (x0 < z0) { o1[0] = 0; o1[1] = 1; o1[2] = 0; o2[0] = 0; o2[1] = 1; o2[2] = 1; }
    else { o1[0] = 0; o1[1] = 1; o1[2] = 0; o2[0] = 1; o2[1] = 1; o2[2] = 0; }
  }
  const int corner[4][3] = {{0, 0, 0}, {o1[0], o1[1], o1[2]}, {o2[0], o2[1], o2[2]}, {1, 1, 1}};
  Sample3 out;
  for (int c = 0; c < 4; ++c) {
    const float off = kUnskew * static_cast<float>(c);
    const float d[3] = {x0 - static_cast<float>(corner[c][0]) + off,
                        y0 - static_cast<float>(corner[c][1]) + off,
                        z0 - static_cast<float>(corner[c][2]) + off};
    const float a = 0.6f - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (a <= 0.0f) continue;
    const float* g = grad3(i + corner[c][0], j + corner[c][1], k + corner[c][2], seed);
    const float n = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
    const float a2 = a * a, a4 = a2 * a2;
    out.value += a4 * n;
    out.dx += a4 * g[0] - 8.0f * a2 * a * n * d[0];
    out.dy += a4 * g[1] - 8.0f * a2 * a * n * d[1];
    out.dz += a4 * g[2] - 8.0f * a2 * a * n * d[2];
  }
  out.value *= kSimplexScale3;
  out.dx *= kSimplexScale3;
  out.dy *= kSimplexScale3;
  out.dz *= kSimplexScale3;
  return out;
}

float lipschitz(Basis basis, int dimensions) {
  // Proven (conservative) bounds of |∇|, derived in docs/noise.md.
  if (basis == Basis::gradient) return dimensions == 2 ? 6.8f : 8.0f;
  return dimensions == 2 ? 8.6f : 7.8f;
}

float octave_weight(int i, float octaves) {
  const float t = octaves - static_cast<float>(i);
  if (t >= 1.0f) return 1.0f;
  if (t <= 0.0f) return 0.0f;
  const float s = 1.0f - t * t;
  return 1.0f - s * s * s;
}

float visible_octaves(const FractalParams& p, float spacing) {
  const float all = static_cast<float>(p.octaves);
  if (spacing <= 0.0f) return all;
  const double n = std::log(1.0 / (2.0 * static_cast<double>(spacing) * p.frequency)) /
                       std::log(static_cast<double>(p.lacunarity)) +
                   1.0;
  return std::clamp(static_cast<float>(n), 0.0f, all);
}

namespace {

constexpr std::size_t kMaxBatch = 64;

Sample2 basis2(Basis b, float x, float y, std::uint32_t seed) {
  return b == Basis::simplex ? simplex2(x, y, seed) : gradient2(x, y, seed);
}

int octave_count(const FractalParams& p, float octaves) {
  return std::min(p.octaves, static_cast<int>(std::ceil(octaves)));
}

}  // namespace

Sample2 fractal2(const FractalParams& p, Vec2 point, float octaves) {
  if (p.kind == Fractal::fbm || p.kind == Fractal::ridged) {
    Sample2 s;
    fractal2(p, &point.x, &point.y, 1, octaves, &s.value, &s.dx, &s.dy);
    return s;
  }
  const float gain = std::pow(p.lacunarity, -p.hurst);
  const int count = octave_count(p, octaves);
  float frequency = p.frequency, amplitude = p.amplitude;
  Sample2 sum;
  // Ridged/hybrid: each octave is weighted by the previous one's signal (Musgrave).
  float weight = 1.0f, wx = 0.0f, wy = 0.0f;
  // Warped: rotation angle and translation driven by the height so far (docs/noise.md).
  float angle = 0.0f, ax = 0.0f, ay = 0.0f;
  Vec2 shift{0, 0};
  float sx_x = 0.0f, sx_y = 0.0f, sy_x = 0.0f, sy_y = 0.0f;  // ∇shift.x, ∇shift.y
  const float roughness = 1.0f / (p.lacunarity * p.hurst);
  for (int i = 0; i < count; ++i) {
    const float ow = octave_weight(i, octaves);
    const std::uint32_t seed = hash(p.seed, static_cast<std::uint32_t>(i));
    if (p.kind == Fractal::warped) {
      const float c = std::cos(angle), s = std::sin(angle);
      const float px = frequency * (c * point.x - s * point.y) + shift.x;
      const float py = frequency * (s * point.x + c * point.y) + shift.y;
      const Sample2 n = basis2(p.basis, px, py, seed);
      // ∂(px, py)/∂p: rotation, plus the angle's and shift's dependence on p through the height.
      const float rx = -s * point.x - c * point.y, ry = c * point.x - s * point.y;  // ∂/∂angle
      const float jxx = frequency * (c + rx * ax) + sx_x, jxy = frequency * (-s + rx * ay) + sx_y;
      const float jyx = frequency * (s + ry * ax) + sy_x, jyy = frequency * (c + ry * ay) + sy_y;
      const float a = amplitude * ow;
      sum.value += a * n.value;
      sum.dx += a * (n.dx * jxx + n.dy * jyx);
      sum.dy += a * (n.dx * jxy + n.dy * jyy);
      // Update the warp from the height accumulated so far, in units of the first amplitude.
      const float h = p.amplitude > 0.0f ? sum.value / p.amplitude : 0.0f;
      const float hx = p.amplitude > 0.0f ? sum.dx / p.amplitude : 0.0f;
      const float hy = p.amplitude > 0.0f ? sum.dy / p.amplitude : 0.0f;
      angle += p.warp_c1 * roughness * h + p.warp_c2;
      ax += p.warp_c1 * roughness * hx;
      ay += p.warp_c1 * roughness * hy;
      const float next = frequency * p.lacunarity;
      const float ratio = p.lacunarity;  // shifts are in octave units: rescale to the next octave
      shift = {ratio * (shift.x + p.warp_c3.x * h), ratio * (shift.y + p.warp_c3.y * h)};
      sx_x = ratio * (sx_x + p.warp_c3.x * hx);
      sx_y = ratio * (sx_y + p.warp_c3.x * hy);
      sy_x = ratio * (sy_x + p.warp_c3.y * hx);
      sy_y = ratio * (sy_y + p.warp_c3.y * hy);
      frequency = next;
    } else {
      const Sample2 n = basis2(p.basis, frequency * point.x, frequency * point.y, seed);
      if (p.kind == Fractal::fbm) {
        const float a = amplitude * ow;
        sum.value += a * n.value;
        sum.dx += a * frequency * n.dx;
        sum.dy += a * frequency * n.dy;
      } else {
        // signal = (offset − |η|)²
        const float sign = n.value < 0.0f ? -1.0f : 1.0f;
        const float base = p.ridge_offset - sign * n.value;
        const float signal = p.kind == Fractal::ridged ? base * base : n.value + p.ridge_offset;
        const float dsx = p.kind == Fractal::ridged ? -2.0f * base * sign * frequency * n.dx
                                                    : frequency * n.dx;
        const float dsy = p.kind == Fractal::ridged ? -2.0f * base * sign * frequency * n.dy
                                                    : frequency * n.dy;
        const float a = amplitude * ow;
        sum.value += a * signal * weight;
        sum.dx += a * (dsx * weight + signal * wx);
        sum.dy += a * (dsy * weight + signal * wy);
        // Next weight: clamp(signal · gain, 0, 1) (ridged) or clamp(weight · signal · 0.5, 0, 1)
        // (hybrid); its gradient vanishes where clamped.
        const float raw = p.kind == Fractal::ridged ? signal * p.ridge_gain
                                                    : weight * signal * 0.5f;
        const float rx = p.kind == Fractal::ridged ? dsx * p.ridge_gain
                                                   : 0.5f * (wx * signal + weight * dsx);
        const float ry = p.kind == Fractal::ridged ? dsy * p.ridge_gain
                                                   : 0.5f * (wy * signal + weight * dsy);
        const bool inside = raw > 0.0f && raw < 1.0f;
        weight = std::clamp(raw, 0.0f, 1.0f);
        wx = inside ? rx : 0.0f;
        wy = inside ? ry : 0.0f;
      }
      frequency *= p.lacunarity;
    }
    amplitude *= gain;
  }
  return sum;
}

namespace {

// Per-octave constants, computed once per call with the same multiplications in every path.
struct Octaves {
  int count = 0;
  float frequency[24];
  float amplitude[24];  // includes the LoD octave weight
  std::uint32_t seed[24];
};

Octaves octave_table(const FractalParams& p, float octaves) {
  Octaves t;
  t.count = octave_count(p, octaves);
  const float gain = std::pow(p.lacunarity, -p.hurst);
  float frequency = p.frequency, amplitude = p.amplitude;
  for (int i = 0; i < t.count; ++i) {
    t.frequency[i] = frequency;
    t.amplitude[i] = amplitude * octave_weight(i, octaves);
    t.seed[i] = hash(p.seed, static_cast<std::uint32_t>(i));
    frequency *= p.lacunarity;
    amplitude *= gain;
  }
  return t;
}

// Octave-outer, point-inner loops over structure-of-arrays data: the inner loops have no
// branches and vectorise; the AVX2 clone adds 8-wide integer multiplies for the hash. Results
// are identical across clones (no FMA contraction, same operation order).
template <bool kSimplex>
__attribute__((target_clones("avx2", "default"))) void fbm_batch(
    const Octaves& t, const float* x, const float* y, std::size_t n, float* value, float* dx,
    float* dy) {
  for (std::size_t k = 0; k < n; ++k) value[k] = dx[k] = dy[k] = 0.0f;
  for (int o = 0; o < t.count; ++o) {
    const float f = t.frequency[o], a = t.amplitude[o];
    const std::uint32_t seed = t.seed[o];
    for (std::size_t k = 0; k < n; ++k) {
      float v, gx, gy;
      if constexpr (kSimplex) {
        simplex2_kernel(x[k] * f, y[k] * f, seed, v, gx, gy);
      } else {
        gradient2_kernel(x[k] * f, y[k] * f, seed, v, gx, gy);
      }
      value[k] += a * v;
      dx[k] += a * f * gx;
      dy[k] += a * f * gy;
    }
  }
}

// Musgrave's ridged multifractal: signal = (offset − |η|)², each octave weighted by
// w = clamp(previous signal · gain, 0, 1) (w = 1 for the first); gradients by the chain rule.
template <bool kSimplex>
__attribute__((target_clones("avx2", "default"))) void ridged_batch(
    const Octaves& t, float offset, float ridge_gain, const float* x, const float* y,
    std::size_t n, float* value, float* dx, float* dy) {
  float weight[kMaxBatch], wx[kMaxBatch], wy[kMaxBatch];
  for (std::size_t k = 0; k < n; ++k) {
    value[k] = dx[k] = dy[k] = 0.0f;
    weight[k] = 1.0f;
    wx[k] = wy[k] = 0.0f;
  }
  for (int o = 0; o < t.count; ++o) {
    const float f = t.frequency[o], a = t.amplitude[o];
    const std::uint32_t seed = t.seed[o];
    for (std::size_t k = 0; k < n; ++k) {
      float v, gx, gy;
      if constexpr (kSimplex) {
        simplex2_kernel(x[k] * f, y[k] * f, seed, v, gx, gy);
      } else {
        gradient2_kernel(x[k] * f, y[k] * f, seed, v, gx, gy);
      }
      const float sign = std::copysign(1.0f, v);
      const float base = offset - sign * v;
      const float signal = base * base;
      const float sx = -2.0f * base * sign * f * gx;
      const float sy = -2.0f * base * sign * f * gy;
      value[k] += a * signal * weight[k];
      dx[k] += a * (sx * weight[k] + signal * wx[k]);
      dy[k] += a * (sy * weight[k] + signal * wy[k]);
      const float raw = signal * ridge_gain;
      const float inside = static_cast<float>((raw > 0.0f) & (raw < 1.0f));
      weight[k] = std::min(std::max(raw, 0.0f), 1.0f);
      wx[k] = inside * (sx * ridge_gain);
      wy[k] = inside * (sy * ridge_gain);
    }
  }
}

}  // namespace

void fractal2(const FractalParams& p, const float* x, const float* y, std::size_t n, float octaves,
              float* value, float* dx, float* dy) {
  const bool simplex = p.basis == Basis::simplex;
  if (p.kind == Fractal::fbm || p.kind == Fractal::ridged) {
    const Octaves t = octave_table(p, octaves);
    for (std::size_t start = 0; start < n; start += kMaxBatch) {
      const std::size_t m = std::min(kMaxBatch, n - start);
      const float* xs = x + start;
      const float* ys = y + start;
      float* v = value + start;
      float* gx = dx + start;
      float* gy = dy + start;
      if (p.kind == Fractal::fbm) {
        simplex ? fbm_batch<true>(t, xs, ys, m, v, gx, gy) : fbm_batch<false>(t, xs, ys, m, v, gx, gy);
      } else if (simplex) {
        ridged_batch<true>(t, p.ridge_offset, p.ridge_gain, xs, ys, m, v, gx, gy);
      } else {
        ridged_batch<false>(t, p.ridge_offset, p.ridge_gain, xs, ys, m, v, gx, gy);
      }
    }
    return;
  }
  for (std::size_t k = 0; k < n; ++k) {
    const Sample2 s = fractal2(p, {x[k], y[k]}, octaves);
    value[k] = s.value;
    dx[k] = s.dx;
    dy[k] = s.dy;
  }
}

void fractal3(const FractalParams& p, const float* x, const float* y, const float* z, std::size_t n,
              float octaves, float* value, float* dx, float* dy, float* dz) {
  const float gain = std::pow(p.lacunarity, -p.hurst);
  const int count = octave_count(p, octaves);
  for (std::size_t k = 0; k < n; ++k) {
    float frequency = p.frequency, amplitude = p.amplitude;
    Sample3 sum;
    for (int i = 0; i < count; ++i) {
      const std::uint32_t seed = hash(p.seed, static_cast<std::uint32_t>(i));
      const Sample3 s = p.basis == Basis::simplex
                            ? simplex3(frequency * x[k], frequency * y[k], frequency * z[k], seed)
                            : gradient3(frequency * x[k], frequency * y[k], frequency * z[k], seed);
      const float a = amplitude * octave_weight(i, octaves);
      sum.value += a * s.value;
      sum.dx += a * frequency * s.dx;
      sum.dy += a * frequency * s.dy;
      sum.dz += a * frequency * s.dz;
      frequency *= p.lacunarity;
      amplitude *= gain;
    }
    value[k] = sum.value;
    dx[k] = sum.dx;
    dy[k] = sum.dy;
    dz[k] = sum.dz;
  }
}

Interval fractal_range(const FractalParams& p, float octaves) {
  const float gain = std::pow(p.lacunarity, -p.hurst);
  const int count = octave_count(p, octaves);
  float amplitude = p.amplitude, lo = 0.0f, hi = 0.0f;
  for (int i = 0; i < count; ++i) {
    const float a = amplitude * octave_weight(i, octaves);
    if (p.kind == Fractal::ridged) {
      // signal = (offset − |η|)² with |η| ≤ 1, weighted by w ∈ [0, 1].
      const float top = std::max((p.ridge_offset - 1.0f) * (p.ridge_offset - 1.0f),
                                 p.ridge_offset * p.ridge_offset);
      hi += a * top;
    } else if (p.kind == Fractal::hybrid) {
      lo += a * std::min(0.0f, p.ridge_offset - 1.0f);
      hi += a * (p.ridge_offset + 1.0f);
    } else {
      lo -= a;
      hi += a;
    }
    amplitude *= gain;
  }
  return {lo * 1.0001f - 1e-6f, hi * 1.0001f + 1e-6f};
}

float fractal_lipschitz(const FractalParams& p, float octaves, float radius) {
  const float gain = std::pow(p.lacunarity, -p.hurst);
  const int count = octave_count(p, octaves);
  const float eta = lipschitz(p.basis, 2);
  float amplitude = p.amplitude, frequency = p.frequency;
  float bound = 0.0f;
  if (p.kind == Fractal::fbm) {
    for (int i = 0; i < count; ++i) {
      bound += amplitude * octave_weight(i, octaves) * frequency * eta;
      amplitude *= gain;
      frequency *= p.lacunarity;
    }
  } else if (p.kind == Fractal::ridged || p.kind == Fractal::hybrid) {
    // Term i: a_i (|∇signal| · w + signal · |∇w|); |∇w| ≤ |∇raw| of the previous octave.
    // |offset − |η|| ≤ max(|offset − 1|, offset) since |η| ≤ 1.
    const float base = std::max(std::abs(p.ridge_offset - 1.0f), p.ridge_offset);
    const float top = p.kind == Fractal::ridged ? base * base : p.ridge_offset + 1.0f;
    const float dsignal_per_freq = p.kind == Fractal::ridged ? 2.0f * base * eta : eta;
    float weight_slope = 0.0f;
    for (int i = 0; i < count; ++i) {
      const float signal_slope = dsignal_per_freq * frequency;
      bound += amplitude * octave_weight(i, octaves) * (signal_slope + top * weight_slope);
      weight_slope = p.kind == Fractal::ridged ? signal_slope * p.ridge_gain
                                               : 0.5f * (weight_slope * top + signal_slope);
      amplitude *= gain;
      frequency *= p.lacunarity;
    }
  } else {
    // Warped: octave i's Jacobian ≤ f_i (1 + r |∇angle|) + |∇shift|, with |∇angle| and |∇shift|
    // driven by the bound of |∇h| so far (h in units of the first amplitude).
    const float roughness = 1.0f / (p.lacunarity * p.hurst);
    const float c3 = length(p.warp_c3);
    float angle_slope = 0.0f, shift_slope = 0.0f;
    for (int i = 0; i < count; ++i) {
      const float jacobian = frequency * (1.0f + radius * angle_slope) + shift_slope;
      bound += amplitude * octave_weight(i, octaves) * eta * jacobian;
      const float h_slope = p.amplitude > 0.0f ? bound / p.amplitude : 0.0f;
      angle_slope += std::abs(p.warp_c1) * roughness * h_slope;
      shift_slope = p.lacunarity * (shift_slope + c3 * h_slope);
      amplitude *= gain;
      frequency *= p.lacunarity;
    }
  }
  return bound * 1.0001f;
}

}  // namespace terrain::noise
