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

// Eight unit gradients at multiples of 45°, picked by three hash bits.
constexpr float kDiag = 0.70710678f;
constexpr float kGrad2[8][2] = {{1, 0},  {kDiag, kDiag},   {0, 1},  {-kDiag, kDiag},
                                {-1, 0}, {-kDiag, -kDiag}, {0, -1}, {kDiag, -kDiag}};
// Twelve gradients towards the edge midpoints of a cube, normalised.
constexpr float kEdge = 0.70710678f;
constexpr float kGrad3[16][3] = {
    {kEdge, kEdge, 0},  {-kEdge, kEdge, 0},  {kEdge, -kEdge, 0},  {-kEdge, -kEdge, 0},
    {kEdge, 0, kEdge},  {-kEdge, 0, kEdge},  {kEdge, 0, -kEdge},  {-kEdge, 0, -kEdge},
    {0, kEdge, kEdge},  {0, -kEdge, kEdge},  {0, kEdge, -kEdge},  {0, -kEdge, -kEdge},
    {kEdge, kEdge, 0},  {-kEdge, kEdge, 0},  {0, -kEdge, kEdge},  {0, -kEdge, -kEdge}};

inline const float* grad2(int i, int j, std::uint32_t seed) {
  return kGrad2[hash(u32(i), u32(j), seed) & 7u];
}
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

Sample2 gradient2(float x, float y, std::uint32_t seed) {
  const int i = fast_floor(x), j = fast_floor(y);
  const float fx = x - static_cast<float>(i), fy = y - static_cast<float>(j);
  const float* g00 = grad2(i, j, seed);
  const float* g10 = grad2(i + 1, j, seed);
  const float* g01 = grad2(i, j + 1, seed);
  const float* g11 = grad2(i + 1, j + 1, seed);
  const float n00 = g00[0] * fx + g00[1] * fy;
  const float n10 = g10[0] * (fx - 1.0f) + g10[1] * fy;
  const float n01 = g01[0] * fx + g01[1] * (fy - 1.0f);
  const float n11 = g11[0] * (fx - 1.0f) + g11[1] * (fy - 1.0f);
  const float u = fade(fx), v = fade(fy);
  const float du = fade_slope(fx), dv = fade_slope(fy);
  const float nx0 = n00 + u * (n10 - n00);
  const float nx1 = n01 + u * (n11 - n01);
  const float value = nx0 + v * (nx1 - nx0);
  // ∂/∂x: the fade's slope across the corner values plus the interpolated gradients.
  const float gx0 = g00[0] + u * (g10[0] - g00[0]);
  const float gx1 = g01[0] + u * (g11[0] - g01[0]);
  const float gy0 = g00[1] + u * (g10[1] - g00[1]);
  const float gy1 = g01[1] + u * (g11[1] - g01[1]);
  const float dx = gx0 + v * (gx1 - gx0) + du * ((n10 - n00) + v * ((n11 - n01) - (n10 - n00)));
  const float dy = gy0 + v * (gy1 - gy0) + dv * (nx1 - nx0);
  return {value * kGradientScale2, dx * kGradientScale2, dy * kGradientScale2};
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
  constexpr float kSkew = 0.36602540f;    // (√3 − 1) / 2
  constexpr float kUnskew = 0.21132487f;  // (3 − √3) / 6
  const float s = (x + y) * kSkew;
  const int i = fast_floor(x + s), j = fast_floor(y + s);
  const float t = static_cast<float>(i + j) * kUnskew;
  const float x0 = x - (static_cast<float>(i) - t), y0 = y - (static_cast<float>(j) - t);
  const int i1 = x0 > y0 ? 1 : 0, j1 = 1 - i1;
  const float cx[3] = {x0, x0 - static_cast<float>(i1) + kUnskew, x0 - 1.0f + 2.0f * kUnskew};
  const float cy[3] = {y0, y0 - static_cast<float>(j1) + kUnskew, y0 - 1.0f + 2.0f * kUnskew};
  const int ci[3] = {i, i + i1, i + 1}, cj[3] = {j, j + j1, j + 1};
  Sample2 out;
  for (int c = 0; c < 3; ++c) {
    const float r2 = cx[c] * cx[c] + cy[c] * cy[c];
    const float a = 0.5f - r2;
    if (a <= 0.0f) continue;
    const float* g = grad2(ci[c], cj[c], seed);
    const float n = g[0] * cx[c] + g[1] * cy[c];
    const float a2 = a * a, a4 = a2 * a2;
    out.value += a4 * n;
    // ∇(a⁴ n) = a⁴ g − 8 a³ n d
    out.dx += a4 * g[0] - 8.0f * a2 * a * n * cx[c];
    out.dy += a4 * g[1] - 8.0f * a2 * a * n * cy[c];
  }
  return {out.value * kSimplexScale2, out.dx * kSimplexScale2, out.dy * kSimplexScale2};
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

Sample2 basis2(Basis b, float x, float y, std::uint32_t seed) {
  return b == Basis::simplex ? simplex2(x, y, seed) : gradient2(x, y, seed);
}

int octave_count(const FractalParams& p, float octaves) {
  return std::min(p.octaves, static_cast<int>(std::ceil(octaves)));
}

}  // namespace

Sample2 fractal2(const FractalParams& p, Vec2 point, float octaves) {
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

void fractal2(const FractalParams& p, const float* x, const float* y, std::size_t n, float octaves,
              float* value, float* dx, float* dy) {
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
