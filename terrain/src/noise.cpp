// Integer-hashed gradient and simplex noise with exact derivatives, and the fractal sums over them.
// docs/noise.md gives every formula; this file is the reference implementation of those formulas.
//
// Determinism: every hot-path operation is an IEEE add, multiply, compare or select (no libm, no
// division), the project builds with -ffp-contract=off, and the batch and single-point paths run
// the same always-inlined per-octave step functions in the same order, on floats or on GCC vectors
// of 8 or 16 floats (they differ only in how a lattice gradient is fetched: a permute of the
// gradient table in AVX2/AVX-512 vectors, bit operations in loops GCC vectorises, a table lookup
// in scalar code; all give the same gradients), so every version and the scalar path agree bit
// for bit.
#include "terrain/noise.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <type_traits>

#include "terrain/simd.hpp"

#define TERRAIN_NOISE_INLINE [[gnu::always_inline]] inline

namespace terrain::noise {
namespace {

// ---------------------------------------------------------------------------------------------
// Constants. docs/noise.md derives the scales and bounds; tests/terrain/noise_test.cpp certifies
// the numerical ones with an interval branch-and-bound.

// Lattice coordinates are clamped to ±2^26 before the float→int conversion so it never overflows
// (beyond 2^24 a float has no fractional part left, so nothing is lost).
constexpr float kCoordLimit = 67108864.0f;

// Gradient noise with unit gradients satisfies |n| ≤ √N / 2, so 2/√N maps it into [−1, 1]. Both
// floats are rounded below the real value.
constexpr float kGradientScale2 = 1.41421354f;  // √2
constexpr float kGradientScale3 = 1.15470052f;  // 2/√3
// Simplex noise: 1 / max Σ (½ − |d|²)⁴|d|, rounded down (certified maxima 0.0100802 and
// 0.00928906).
constexpr float kSimplexScale2 = 99.0f;
constexpr float kSimplexScale3 = 107.5f;

// Proven bounds of |∇| at unit frequency (certified values 3.0759, 3.5543, 7.3333, 7.7915, plus
// about 3% margin).
constexpr float kLipschitzGradient2 = 3.17f;
constexpr float kLipschitzGradient3 = 3.66f;
constexpr float kLipschitzSimplex2 = 7.55f;
constexpr float kLipschitzSimplex3 = 8.03f;

// Sixteen 2D gradient directions at odd multiples of π/16.
constexpr float kCos1 = 0.980785280f;  // cos(π/16)
constexpr float kSin1 = 0.195090322f;  // sin(π/16)
constexpr float kCos3 = 0.831469612f;  // cos(3π/16)
constexpr float kSin3 = 0.555570233f;  // sin(3π/16)
// The twelve 3D gradients (cube edge midpoints) have components ±1/√2 (rounded down) or 0.
constexpr float kEdge = 0.707106769f;

// Simplex skew factors.
constexpr float kSkew2 = 0.366025404f;    // F2 = (√3 − 1)/2
constexpr float kUnskew2 = 0.211324865f;  // G2 = (3 − √3)/6
constexpr float kSkew3 = 0.333333343f;    // F3 = 1/3
constexpr float kUnskew3 = 0.166666672f;  // G3 = 1/6
// The unskew n·G (n = i + j [+ k]) is split as n·H/2048 + n·(G − H/2048) with integer H: the
// first part is computed exactly in integers (its whole cells fold into the cell index), so the
// corner offsets x − i + n·G keep their precision far from the origin (error ≈ |n|·6e-12 instead
// of |n|·1e-8). Exact for |n|·H < 2^31, i.e. coordinates up to about ±2·10^6.
constexpr std::uint32_t kUnskew2Head = 433u;     // 2048·G2 ≈ 432.79
constexpr float kUnskew2Tail = -1.00915844e-4f;  // G2 − 433/2048
constexpr std::uint32_t kUnskew3Head = 341u;     // 2048·G3 ≈ 341.33
constexpr float kUnskew3Tail = 1.62760422e-4f;   // 1/6 − 341/2048

// Rotation of the warped fractal: sin and cos of 2πx on x ∈ [−½, ½] as
//   S(x) = x (¼ − x²) P(x²),   C(x) = (¼ − x²)² R(x²) − 1,
// exact zeros/extrema at ±½ so the periodic extension is C¹. Least-squares fits, |error| < 3e-7.
constexpr float kSinP[6] = {2.513274193e+01f,  -6.483582306e+01f, 6.707662964e+01f,
                            -3.849588013e+01f, 1.404966354e+01f,  -3.161602020e+00f};
constexpr float kCosR[6] = {3.200000000e+01f,  -5.982733154e+01f, 4.841119003e+01f,
                            -2.277238083e+01f, 7.045487404e+00f,  -1.393159151e+00f};
constexpr float kInvTau = 0.159154943f;   // 1/(2π)
constexpr float kTurnLimit = 4194304.0f;  // 2^22 turns: the reduction stays exact below this
// Bounds of |(C, S)| and |(C', S')|/(2π) over all inputs (1 + approximation error, rounded up).
constexpr double kRotationNorm = 1.0001;

constexpr int kMaxOctaves = 24;

// ---------------------------------------------------------------------------------------------
// Building blocks. All are branch-free (selects only) so loops around them vectorise.
//
// The 2D building blocks and per-octave steps are templates over the type of their operands:
// `float`, one point (the single-point path, and the batch loops that GCC vectorises itself), or
// a GCC vector of 8 or 16 floats (the AVX2 and AVX-512 batch paths, which fetch lattice gradients
// with a permute, something GCC's vectoriser cannot do). GCC's vector operators are the same IEEE
// operations lane by lane, so one source gives the same bits for all of them.

using Vec8 = float __attribute__((vector_size(32)));
using Vec8u = std::uint32_t __attribute__((vector_size(32)));
using Vec8i = std::int32_t __attribute__((vector_size(32)));
using Vec16 = float __attribute__((vector_size(64)));
using Vec16u = std::uint32_t __attribute__((vector_size(64)));
using Vec16i = std::int32_t __attribute__((vector_size(64)));

// The unsigned and signed integer lanes matching a float type, and back.
template <class F>
struct IntLanes;
template <>
struct IntLanes<float> {
  using U = std::uint32_t;
  using I = std::int32_t;
};
template <>
struct IntLanes<Vec8> {
  using U = Vec8u;
  using I = Vec8i;
};
template <>
struct IntLanes<Vec16> {
  using U = Vec16u;
  using I = Vec16i;
};
template <class T>
struct FloatLanes;
template <>
struct FloatLanes<std::uint32_t> {
  using F = float;
};
template <>
struct FloatLanes<Vec8u> {
  using F = Vec8;
};
template <>
struct FloatLanes<Vec8i> {
  using F = Vec8;
};
template <>
struct FloatLanes<Vec16u> {
  using F = Vec16;
};
template <>
struct FloatLanes<Vec16i> {
  using F = Vec16;
};
template <class F>
using BitsOf = typename IntLanes<F>::U;
template <class F>
using IntsOf = typename IntLanes<F>::I;

// Selects on floats are done on their bit patterns. Under the default -ftrapping-math GCC sinks
// float arithmetic that follows a float select into the branches and then refuses to if-convert
// them ("control flow in loop"); integer selects and masks vectorise.
template <class F>
TERRAIN_NOISE_INLINE constexpr BitsOf<F> bits_of(F x) {
  return std::bit_cast<BitsOf<F>>(x);
}
template <class U>
TERRAIN_NOISE_INLINE constexpr typename FloatLanes<U>::F from_bits(U b) {
  return std::bit_cast<typename FloatLanes<U>::F>(b);
}

// The value s in every lane.
template <class F>
TERRAIN_NOISE_INLINE F splat(float s) {
  return F{} + s;
}
// All ones where the sign bit of b is set (an arithmetic shift).
template <class U>
TERRAIN_NOISE_INLINE U sign_fill(U b) {
  using I = IntsOf<typename FloatLanes<U>::F>;
  return std::bit_cast<U>(std::bit_cast<I>(b) >> 31);
}
// std::min(a, b) of unsigned lanes and a constant. (The constant stays a scalar operand: GCC
// broadcasts it well, while an explicit splat of an unsigned vector is built lane by lane.)
template <class U>
TERRAIN_NOISE_INLINE U min_bits(U a, std::uint32_t b) {
  return b < a ? b : a;
}
// max(x, 0) (−0 and negative values give +0).
template <class F>
TERRAIN_NOISE_INLINE F positive_part(F x) {
  const BitsOf<F> b = bits_of(x);
  return from_bits(b & ~sign_fill(b));
}
// |x| clamped to `limit` ≥ 0 (NaN becomes ±limit), sign kept.
template <class F>
TERRAIN_NOISE_INLINE F clamp_magnitude(F x, float limit) {
  const BitsOf<F> b = bits_of(x);
  return from_bits((b & 0x80000000u) | min_bits(b & 0x7fffffffu, bits_of(limit)));
}
// x clamped to [0, 1] (non-negative floats order like their bit patterns).
template <class F>
TERRAIN_NOISE_INLINE F clamp01(F x) {
  return from_bits(min_bits(bits_of(positive_part(x)), bits_of(1.0f)));
}
// 1.0f where bit is 1, 0.0f where it is 0.
TERRAIN_NOISE_INLINE float unit_if(std::uint32_t bit) {
  return from_bits((0u - bit) & bits_of(1.0f));
}
template <class F>
TERRAIN_NOISE_INLINE F clamp_coord(F x) {
  return clamp_magnitude(x, kCoordLimit);
}

// floor() without libm: truncate, then step down for negative non-integers.
TERRAIN_NOISE_INLINE std::int32_t floor_to_int(float x) {
  const auto i = static_cast<std::int32_t>(x);
  return i - static_cast<std::int32_t>(x < static_cast<float>(i));
}
template <class F>
TERRAIN_NOISE_INLINE IntsOf<F> floor_to_int(F x) {
  const IntsOf<F> i = __builtin_convertvector(x, IntsOf<F>);
  return i + (x < __builtin_convertvector(i, F));  // a true vector comparison is −1
}
TERRAIN_NOISE_INLINE float to_float(std::int32_t i) {
  return static_cast<float>(i);
}
template <class I>
TERRAIN_NOISE_INLINE typename FloatLanes<I>::F to_float(I i) {
  return __builtin_convertvector(i, typename FloatLanes<I>::F);
}

template <class F>
TERRAIN_NOISE_INLINE F fade(F t) {
  return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
}
template <class F>
TERRAIN_NOISE_INLINE F fade_slope(F t) {
  return 30.0f * t * t * (t * (t - 2.0f) + 1.0f);
}

// Two's-complement bits of signed lanes.
TERRAIN_NOISE_INLINE std::uint32_t u32(std::int32_t v) {
  return static_cast<std::uint32_t>(v);
}
template <class I>
TERRAIN_NOISE_INLINE BitsOf<typename FloatLanes<I>::F> u32(I v) {
  return std::bit_cast<BitsOf<typename FloatLanes<I>::F>>(v);
}

template <class U>
TERRAIN_NOISE_INLINE U hash_lanes(U x) {
  return detail::lowbias32(x);
}

// Gradient of a 2D lattice point from the top four bits of its hash: bit 28 picks the angle pair
// (π/16 or 3π/16), bit 29 swaps the components, bits 30 and 31 are the signs.
TERRAIN_NOISE_INLINE constexpr void gradient_bits2(std::uint32_t h, float& gx, float& gy) {
  const std::uint32_t wide = 0u - ((h >> 28) & 1u);
  const std::uint32_t swap = 0u - ((h >> 29) & 1u);
  const std::uint32_t a = bits_of(kCos1) ^ ((bits_of(kCos1) ^ bits_of(kCos3)) & wide);
  const std::uint32_t b = bits_of(kSin1) ^ ((bits_of(kSin1) ^ bits_of(kSin3)) & wide);
  const std::uint32_t exchange = (a ^ b) & swap;
  gx = from_bits((a ^ exchange) ^ ((h << 1) & 0x80000000u));
  gy = from_bits((b ^ exchange) ^ (h & 0x80000000u));
}

// Gradient of a 3D lattice point: index ⌊12·(h>>16)/2^16⌋ in 0..11; index>>2 picks the zero
// component (z, y, x), bits 0 and 1 the signs of the other two.
TERRAIN_NOISE_INLINE constexpr void gradient_bits3(std::uint32_t h, float& gx, float& gy,
                                                   float& gz) {
  const std::uint32_t index = ((h >> 16) * 12u) >> 16;
  const std::uint32_t zero = index >> 2;
  const std::uint32_t s1 = bits_of(kEdge) | (index << 31);
  const std::uint32_t s2 = bits_of(kEdge) | ((index & 2u) << 30);
  // All-ones masks for zero == 0 and zero == 2 (zero ≤ 2, so (v − 1) >> 31 tests v == 0).
  const std::uint32_t z0 = 0u - ((zero - 1u) >> 31);
  const std::uint32_t z2 = 0u - (((zero ^ 2u) - 1u) >> 31);
  gx = from_bits(s1 & ~z2);
  gy = from_bits((s2 & z0) | (s1 & z2));
  gz = from_bits(s2 & ~z0);
}

// The same gradients as tables, built at compile time from the functions above (so the entries
// are the very same floats). Scalar code looks them up (two loads instead of a dozen bit
// operations); vectorised loops use the bit form, since a table lookup would need a gather.
struct Gradient2Table {
  float g[16][2];
};
struct Gradient3Table {
  float g[12][3];
};
constexpr Gradient2Table kGradient2Table = [] {
  Gradient2Table t{};
  for (std::uint32_t b = 0; b < 16; ++b) gradient_bits2(b << 28, t.g[b][0], t.g[b][1]);
  return t;
}();
constexpr Gradient3Table kGradient3Table = [] {
  Gradient3Table t{};
  // Index i comes from any h with ((h >> 16)·12) >> 16 = i, e.g. h = ⌈i·2^16/12⌉ << 16.
  for (std::uint32_t i = 0; i < 12; ++i) {
    gradient_bits3(((i * 65536u + 11u) / 12u) << 16, t.g[i][0], t.g[i][1], t.g[i][2]);
  }
  return t;
}();

// Where the kernels run, which decides how they fetch a lattice gradient (same results): one
// point with a table lookup (ScalarLanes), one point in a loop GCC vectorises, where a lookup would
// be a gather (BitLanes: bit operations), or 8 or 16 points in an AVX2 or AVX-512 vector
// (VectorLanes: the 2D table is held in registers and read with a permute).
struct ScalarLanes {
  using F = float;
};
struct BitLanes {
  using F = float;
};
template <class Vec>
struct VectorLanes {
  using F = Vec;
};

struct Gradient2Columns {
  alignas(64) float x[16];
  alignas(64) float y[16];
};
constexpr Gradient2Columns kGradient2Columns = [] {
  Gradient2Columns c{};
  for (std::size_t b = 0; b < 16; ++b) {
    c.x[b] = kGradient2Table.g[b][0];
    c.y[b] = kGradient2Table.g[b][1];
  }
  return c;
}();

// table[index mod lanes] per lane. GCC has the permute as a builtin; clang (the fuzz preset's
// compiler) spells it as a loop, which it turns into the same instruction where it can.
template <class F, class I>
TERRAIN_NOISE_INLINE F permute(F table, I index) {
#if defined(__clang__)
  constexpr int lanes = static_cast<int>(sizeof(F) / sizeof(float));
  F out{};
  for (int i = 0; i < lanes; ++i) out[i] = table[index[i] & (lanes - 1)];
  return out;
#else
  return __builtin_shuffle(table, index);
#endif
}

template <class L>
TERRAIN_NOISE_INLINE void gradient_of2(BitsOf<typename L::F> h, typename L::F& gx,
                                       typename L::F& gy) {
  if constexpr (std::is_same_v<L, ScalarLanes>) {
    const float* g = kGradient2Table.g[h >> 28];
    gx = g[0];
    gy = g[1];
  } else if constexpr (std::is_same_v<L, BitLanes>) {
    gradient_bits2(h, gx, gy);
  } else {
    // A permute reads its table modulo the lane count. With 16 lanes that is all four bits; with
    // 8 it is bits 28–30, which decide gx, and gy's magnitude, whose sign is bit 31.
    using F = typename L::F;
    F column_x, column_y;  // loop invariants: GCC keeps them in registers
    std::memcpy(&column_x, kGradient2Columns.x, sizeof column_x);
    std::memcpy(&column_y, kGradient2Columns.y, sizeof column_y);
    const auto index = std::bit_cast<IntsOf<F>>(h >> 28);
    gx = permute(column_x, index);
    gy = permute(column_y, index);
    if constexpr (sizeof(F) == 8 * sizeof(float)) gy = from_bits(bits_of(gy) ^ (h & 0x80000000u));
  }
}

template <class L>
TERRAIN_NOISE_INLINE void gradient_of3(std::uint32_t h, float& gx, float& gy, float& gz) {
  if constexpr (std::is_same_v<L, ScalarLanes>) {
    const float* g = kGradient3Table.g[((h >> 16) * 12u) >> 16];
    gx = g[0];
    gy = g[1];
    gz = g[2];
  } else {
    gradient_bits3(h, gx, gy, gz);
  }
}

// Per-seed lattice: the hash key, and a sub-cell offset in [0, 1)^3 added to every coordinate so
// that lattices of different octaves do not share their zero points.
struct Lattice {
  std::uint32_t key = 0;
  float ox = 0.0f;
  float oy = 0.0f;
  float oz = 0.0f;
};

Lattice lattice_of(std::uint32_t seed) {
  constexpr float kUnit = 1.0f / 65536.0f;
  const std::uint32_t key = hash(seed ^ 0xa511e9b3u);
  const std::uint32_t h = hash(key ^ 0x68e31da4u);
  const std::uint32_t h2 = hash(h);
  return {key, static_cast<float>(h & 0xffffu) * kUnit, static_cast<float>(h >> 16) * kUnit,
          static_cast<float>(h2 & 0xffffu) * kUnit};
}

// ---------------------------------------------------------------------------------------------
// Single-octave kernels on lattice coordinates (offset already added).

// Value and gradient of a 2D field at each lane.
template <class F>
struct Lanes2 {
  F value;
  F dx;
  F dy;
};

template <class L, class F = typename L::F>
TERRAIN_NOISE_INLINE Lanes2<F> gradient2_kernel(F x, F y, std::uint32_t key) {
  x = clamp_coord(x);
  y = clamp_coord(y);
  const auto ix = floor_to_int(x);
  const auto iy = floor_to_int(y);
  const F fx = x - to_float(ix);
  const F fy = y - to_float(iy);
  const BitsOf<F> ux = u32(ix);
  const BitsOf<F> uy = u32(iy);
  const BitsOf<F> row0 = hash_lanes(uy + key);
  const BitsOf<F> row1 = hash_lanes(uy + 1u + key);
  F g00x, g00y, g10x, g10y, g01x, g01y, g11x, g11y;
  gradient_of2<L>(hash_lanes(ux + row0), g00x, g00y);
  gradient_of2<L>(hash_lanes(ux + 1u + row0), g10x, g10y);
  gradient_of2<L>(hash_lanes(ux + row1), g01x, g01y);
  gradient_of2<L>(hash_lanes(ux + 1u + row1), g11x, g11y);
  const F fx1 = fx - 1.0f;
  const F fy1 = fy - 1.0f;
  const F n00 = g00x * fx + g00y * fy;
  const F n10 = g10x * fx1 + g10y * fy;
  const F n01 = g01x * fx + g01y * fy1;
  const F n11 = g11x * fx1 + g11y * fy1;
  const F u = fade(fx);
  const F v = fade(fy);
  const F du = fade_slope(fx);
  const F dv = fade_slope(fy);
  // n = n00 + u k1 + v k2 + uv k3 (bilinear blend of the four corner planes).
  const F k1 = n10 - n00;
  const F k2 = n01 - n00;
  const F k3 = (n00 - n10) - (n01 - n11);
  const F uv = u * v;
  const F value = n00 + u * k1 + v * k2 + uv * k3;
  const F gx = g00x + u * (g10x - g00x) + v * (g01x - g00x) + uv * ((g00x - g10x) - (g01x - g11x)) +
               du * (k1 + v * k3);
  const F gy = g00y + u * (g10y - g00y) + v * (g01y - g00y) + uv * ((g00y - g10y) - (g01y - g11y)) +
               dv * (k2 + u * k3);
  return {kGradientScale2 * value, kGradientScale2 * gx, kGradientScale2 * gy};
}

// One simplex corner: (½ − |d|²)₊⁴ (g·d) and its gradient, accumulated.
template <class L>
TERRAIN_NOISE_INLINE void simplex_corner2(float x, float y, std::uint32_t h, float& value,
                                          float& dx, float& dy) {
  float gx, gy;
  gradient_of2<L>(h, gx, gy);
  const float t = positive_part(0.5f - x * x - y * y);
  const float t2 = t * t;
  const float t4 = t2 * t2;
  const float gd = gx * x + gy * y;
  const float k = -8.0f * t2 * t * gd;
  value += t4 * gd;
  dx += t4 * gx + k * x;
  dy += t4 * gy + k * y;
}

template <class L>
TERRAIN_NOISE_INLINE Lanes2<float> simplex2_kernel(float x, float y, std::uint32_t key) {
  x = clamp_coord(x);
  y = clamp_coord(y);
  const float s = (x + y) * kSkew2;
  const std::int32_t i = floor_to_int(x + s);
  const std::int32_t j = floor_to_int(y + s);
  const std::int32_t n = i + j;
  const std::uint32_t head = u32(n) * kUnskew2Head;
  const std::int32_t whole = static_cast<std::int32_t>(head) >> 11;  // ⌊n·H/2048⌋
  const float part = static_cast<float>(head & 2047u) * (1.0f / 2048.0f);
  const float tail = static_cast<float>(n) * kUnskew2Tail;
  const float x0 = ((x - static_cast<float>(i - whole)) + part) + tail;
  const float y0 = ((y - static_cast<float>(j - whole)) + part) + tail;
  // Lower triangle (x0 > y0): second corner (1, 0); upper: (0, 1).
  const auto i1 = static_cast<std::uint32_t>(x0 > y0);
  const float x1 = x0 - unit_if(i1) + kUnskew2;
  const float y1 = y0 - unit_if(1u - i1) + kUnskew2;
  const float x2 = x0 + (2.0f * kUnskew2 - 1.0f);
  const float y2 = y0 + (2.0f * kUnskew2 - 1.0f);
  const std::uint32_t ui = u32(i);
  const std::uint32_t uj = u32(j);
  const std::uint32_t row0 = hash(uj + key);
  const std::uint32_t row1 = hash(uj + 1u + key);
  const std::uint32_t h0 = hash(ui + row0);
  const std::uint32_t h1 = hash(ui + i1 + (row1 ^ ((row0 ^ row1) & (0u - i1))));
  const std::uint32_t h2 = hash(ui + 1u + row1);
  float value = 0.0f, dx = 0.0f, dy = 0.0f;
  simplex_corner2<L>(x0, y0, h0, value, dx, dy);
  simplex_corner2<L>(x1, y1, h1, value, dx, dy);
  simplex_corner2<L>(x2, y2, h2, value, dx, dy);
  return {kSimplexScale2 * value, kSimplexScale2 * dx, kSimplexScale2 * dy};
}

template <class L>
TERRAIN_NOISE_INLINE Sample3 gradient3_kernel(float x, float y, float z, std::uint32_t key) {
  x = clamp_coord(x);
  y = clamp_coord(y);
  z = clamp_coord(z);
  const std::int32_t ix = floor_to_int(x);
  const std::int32_t iy = floor_to_int(y);
  const std::int32_t iz = floor_to_int(z);
  const float fx = x - static_cast<float>(ix);
  const float fy = y - static_cast<float>(iy);
  const float fz = z - static_cast<float>(iz);
  const std::uint32_t ux = u32(ix);
  const std::uint32_t uy = u32(iy);
  const std::uint32_t uz = u32(iz);
  const std::uint32_t plane0 = hash(uz + key);
  const std::uint32_t plane1 = hash(uz + 1u + key);
  const std::uint32_t row00 = hash(uy + plane0);
  const std::uint32_t row10 = hash(uy + 1u + plane0);
  const std::uint32_t row01 = hash(uy + plane1);
  const std::uint32_t row11 = hash(uy + 1u + plane1);
  // Corner cXYZ has gradient gXYZ and plane value nXYZ = gXYZ · (f − corner).
  float g000[3], g100[3], g010[3], g110[3], g001[3], g101[3], g011[3], g111[3];
  gradient_of3<L>(hash(ux + row00), g000[0], g000[1], g000[2]);
  gradient_of3<L>(hash(ux + 1u + row00), g100[0], g100[1], g100[2]);
  gradient_of3<L>(hash(ux + row10), g010[0], g010[1], g010[2]);
  gradient_of3<L>(hash(ux + 1u + row10), g110[0], g110[1], g110[2]);
  gradient_of3<L>(hash(ux + row01), g001[0], g001[1], g001[2]);
  gradient_of3<L>(hash(ux + 1u + row01), g101[0], g101[1], g101[2]);
  gradient_of3<L>(hash(ux + row11), g011[0], g011[1], g011[2]);
  gradient_of3<L>(hash(ux + 1u + row11), g111[0], g111[1], g111[2]);
  const float fx1 = fx - 1.0f;
  const float fy1 = fy - 1.0f;
  const float fz1 = fz - 1.0f;
  const float n000 = g000[0] * fx + g000[1] * fy + g000[2] * fz;
  const float n100 = g100[0] * fx1 + g100[1] * fy + g100[2] * fz;
  const float n010 = g010[0] * fx + g010[1] * fy1 + g010[2] * fz;
  const float n110 = g110[0] * fx1 + g110[1] * fy1 + g110[2] * fz;
  const float n001 = g001[0] * fx + g001[1] * fy + g001[2] * fz1;
  const float n101 = g101[0] * fx1 + g101[1] * fy + g101[2] * fz1;
  const float n011 = g011[0] * fx + g011[1] * fy1 + g011[2] * fz1;
  const float n111 = g111[0] * fx1 + g111[1] * fy1 + g111[2] * fz1;
  const float u = fade(fx);
  const float v = fade(fy);
  const float w = fade(fz);
  const float du = fade_slope(fx);
  const float dv = fade_slope(fy);
  const float dw = fade_slope(fz);
  // Trilinear blend n = k0 + u k1 + v k2 + w k3 + uv k4 + vw k5 + wu k6 + uvw k7; the same
  // combinations of the corner gradients give the part of ∇n that does not come from the fades.
  const auto blend = [](float a000, float a100, float a010, float a110, float a001, float a101,
                        float a011, float a111, float(&k)[8]) {
    k[0] = a000;
    k[1] = a100 - a000;
    k[2] = a010 - a000;
    k[3] = a001 - a000;
    k[4] = (a000 - a100) - (a010 - a110);
    k[5] = (a000 - a010) - (a001 - a011);
    k[6] = (a000 - a100) - (a001 - a101);
    k[7] = ((a100 - a000) + (a010 - a110)) + ((a001 - a101) + (a111 - a011));
  };
  float kn[8], kx[8], ky[8], kz[8];
  blend(n000, n100, n010, n110, n001, n101, n011, n111, kn);
  blend(g000[0], g100[0], g010[0], g110[0], g001[0], g101[0], g011[0], g111[0], kx);
  blend(g000[1], g100[1], g010[1], g110[1], g001[1], g101[1], g011[1], g111[1], ky);
  blend(g000[2], g100[2], g010[2], g110[2], g001[2], g101[2], g011[2], g111[2], kz);
  const float uv = u * v;
  const float vw = v * w;
  const float wu = w * u;
  const float uvw = uv * w;
  const auto mix = [&](const float(&k)[8]) {
    return k[0] + u * k[1] + v * k[2] + w * k[3] + uv * k[4] + vw * k[5] + wu * k[6] + uvw * k[7];
  };
  const float value = mix(kn);
  const float gx = mix(kx) + du * (kn[1] + v * kn[4] + w * kn[6] + vw * kn[7]);
  const float gy = mix(ky) + dv * (kn[2] + u * kn[4] + w * kn[5] + wu * kn[7]);
  const float gz = mix(kz) + dw * (kn[3] + v * kn[5] + u * kn[6] + uv * kn[7]);
  return {kGradientScale3 * value, kGradientScale3 * gx, kGradientScale3 * gy,
          kGradientScale3 * gz};
}

template <class L>
TERRAIN_NOISE_INLINE void simplex_corner3(float x, float y, float z, std::uint32_t h, float& value,
                                          float& dx, float& dy, float& dz) {
  float gx, gy, gz;
  gradient_of3<L>(h, gx, gy, gz);
  const float t = positive_part(0.5f - x * x - y * y - z * z);
  const float t2 = t * t;
  const float t4 = t2 * t2;
  const float gd = gx * x + gy * y + gz * z;
  const float k = -8.0f * t2 * t * gd;
  value += t4 * gd;
  dx += t4 * gx + k * x;
  dy += t4 * gy + k * y;
  dz += t4 * gz + k * z;
}

template <class L>
TERRAIN_NOISE_INLINE Sample3 simplex3_kernel(float x, float y, float z, std::uint32_t key) {
  x = clamp_coord(x);
  y = clamp_coord(y);
  z = clamp_coord(z);
  const float s = (x + y + z) * kSkew3;
  const std::int32_t i = floor_to_int(x + s);
  const std::int32_t j = floor_to_int(y + s);
  const std::int32_t k = floor_to_int(z + s);
  const std::int32_t n = i + j + k;
  const std::uint32_t head = u32(n) * kUnskew3Head;
  const std::int32_t whole = static_cast<std::int32_t>(head) >> 11;  // ⌊n·H/2048⌋
  const float part = static_cast<float>(head & 2047u) * (1.0f / 2048.0f);
  const float tail = static_cast<float>(n) * kUnskew3Tail;
  const float x0 = ((x - static_cast<float>(i - whole)) + part) + tail;
  const float y0 = ((y - static_cast<float>(j - whole)) + part) + tail;
  const float z0 = ((z - static_cast<float>(k - whole)) + part) + tail;
  // Rank of each coordinate among the three (ties broken x > y > z); the simplex steps along
  // the largest coordinate first, then the second largest.
  const auto cxy = static_cast<std::uint32_t>(x0 >= y0);
  const auto cxz = static_cast<std::uint32_t>(x0 >= z0);
  const auto cyz = static_cast<std::uint32_t>(y0 >= z0);
  const std::uint32_t rx = cxy + cxz;
  const std::uint32_t ry = (1u - cxy) + cyz;
  const std::uint32_t rz = (1u - cxz) + (1u - cyz);
  // Ranks are 0..2: rank ≥ 2 is rank >> 1, rank ≥ 1 is (rank + 1) >> 1.
  const std::uint32_t i1 = rx >> 1;
  const std::uint32_t j1 = ry >> 1;
  const std::uint32_t k1 = rz >> 1;
  const std::uint32_t i2 = (rx + 1u) >> 1;
  const std::uint32_t j2 = (ry + 1u) >> 1;
  const std::uint32_t k2 = (rz + 1u) >> 1;
  const float x1 = x0 - unit_if(i1) + kUnskew3;
  const float y1 = y0 - unit_if(j1) + kUnskew3;
  const float z1 = z0 - unit_if(k1) + kUnskew3;
  const float x2 = x0 - unit_if(i2) + 2.0f * kUnskew3;
  const float y2 = y0 - unit_if(j2) + 2.0f * kUnskew3;
  const float z2 = z0 - unit_if(k2) + 2.0f * kUnskew3;
  const float x3 = x0 + (3.0f * kUnskew3 - 1.0f);
  const float y3 = y0 + (3.0f * kUnskew3 - 1.0f);
  const float z3 = z0 + (3.0f * kUnskew3 - 1.0f);
  const std::uint32_t ui = u32(i);
  const std::uint32_t uj = u32(j);
  const std::uint32_t uk = u32(k);
  const std::uint32_t plane0 = hash(uk + key);
  const std::uint32_t plane1 = hash(uk + 1u + key);
  const std::uint32_t h0 = hash(ui + hash(uj + plane0));
  const std::uint32_t planes = plane0 ^ plane1;
  const std::uint32_t h1 = hash(ui + i1 + hash(uj + j1 + (plane0 ^ (planes & (0u - k1)))));
  const std::uint32_t h2 = hash(ui + i2 + hash(uj + j2 + (plane0 ^ (planes & (0u - k2)))));
  const std::uint32_t h3 = hash(ui + 1u + hash(uj + 1u + plane1));
  float value = 0.0f, dx = 0.0f, dy = 0.0f, dz = 0.0f;
  simplex_corner3<L>(x0, y0, z0, h0, value, dx, dy, dz);
  simplex_corner3<L>(x1, y1, z1, h1, value, dx, dy, dz);
  simplex_corner3<L>(x2, y2, z2, h2, value, dx, dy, dz);
  simplex_corner3<L>(x3, y3, z3, h3, value, dx, dy, dz);
  return {kSimplexScale3 * value, kSimplexScale3 * dx, kSimplexScale3 * dy, kSimplexScale3 * dz};
}

// sin φ, cos φ and their derivatives d/dφ, from the periodic polynomials above.
template <class F>
struct Rotation {
  F sin;
  F cos;
  F dsin;
  F dcos;
};

template <class F>
TERRAIN_NOISE_INLINE Rotation<F> rotation_of(F phi) {
  F x = clamp_magnitude(phi * kInvTau, kTurnLimit);
  x = x - to_float(floor_to_int(x + 0.5f));
  const F y = x * x;
  const F q = 0.25f - y;
  const F p =
      ((((kSinP[5] * y + kSinP[4]) * y + kSinP[3]) * y + kSinP[2]) * y + kSinP[1]) * y + kSinP[0];
  const F dp =
      (((5.0f * kSinP[5] * y + 4.0f * kSinP[4]) * y + 3.0f * kSinP[3]) * y + 2.0f * kSinP[2]) * y +
      kSinP[1];
  const F r =
      ((((kCosR[5] * y + kCosR[4]) * y + kCosR[3]) * y + kCosR[2]) * y + kCosR[1]) * y + kCosR[0];
  const F dr =
      (((5.0f * kCosR[5] * y + 4.0f * kCosR[4]) * y + 3.0f * kCosR[3]) * y + 2.0f * kCosR[2]) * y +
      kCosR[1];
  Rotation<F> out;
  out.sin = x * q * p;
  out.cos = q * q * r - 1.0f;
  // d/dx of x q(x²) P(x²) and of q(x²)² R(x²) − 1, then d/dφ = (1/2π) d/dx.
  out.dsin = (q * p + 2.0f * y * (q * dp - p)) * kInvTau;
  out.dcos = 2.0f * x * q * (q * dr - 2.0f * r) * kInvTau;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Fractal plans: the per-octave constants, computed once per call by repeated multiplication.

struct Octave {
  float frequency = 0.0f;  // f_i
  float amplitude = 0.0f;  // w_i·a_i (hybrid: w_i·amplitude, the r^{-iH} factor is in `gain`)
  float slope = 0.0f;      // amplitude · frequency (fBm gradient factor)
  float gain = 1.0f;       // r^{-iH} (hybrid signal scale)
  float phase = 0.0f;      // i·c2 (warped)
  std::uint32_t key = 0;
  float ox = 0.0f;
  float oy = 0.0f;
  float oz = 0.0f;
};

struct Plan {
  Fractal kind = Fractal::fbm;
  Basis basis = Basis::gradient;
  int count = 0;  // octaves with a nonzero weight
  float ridge_offset = 1.0f;
  float ridge_gain = 2.0f;
  float twist = 0.0f;  // c1 / (r·H): rotation per metre of accumulated height sum
  float shift_x = 0.0f;
  float shift_y = 0.0f;
  std::array<Octave, kMaxOctaves> octave{};
};

int max_octaves(const FractalParams& p) {
  return std::clamp(p.octaves, 0, kMaxOctaves);
}

// r^{-H}, computed once in double and rounded, so it is the correctly rounded float on any libm
// with a sub-ulp double pow.
float octave_gain(const FractalParams& p) {
  return static_cast<float>(
      std::pow(static_cast<double>(p.lacunarity), -static_cast<double>(p.hurst)));
}

Plan make_plan(const FractalParams& p, float octaves) {
  Plan plan;
  plan.kind = p.kind;
  plan.basis = p.basis;
  plan.ridge_offset = p.ridge_offset;
  plan.ridge_gain = p.ridge_gain;
  const float rh = p.lacunarity * p.hurst;
  plan.twist = rh != 0.0f ? p.warp_c1 / rh : 0.0f;
  plan.shift_x = p.warp_c3.x;
  plan.shift_y = p.warp_c3.y;
  const float gain = octave_gain(p);
  float frequency = p.frequency;
  float amplitude = p.amplitude;
  float relative = 1.0f;
  const int n = max_octaves(p);
  for (int i = 0; i < n; ++i) {
    const float w = octave_weight(i, octaves);
    if (w <= 0.0f) break;
    Octave& o = plan.octave[static_cast<std::size_t>(i)];
    o.frequency = frequency;
    o.amplitude = (p.kind == Fractal::hybrid ? p.amplitude : amplitude) * w;
    o.slope = o.amplitude * frequency;
    o.gain = relative;
    o.phase = static_cast<float>(i) * p.warp_c2;
    const Lattice lattice = lattice_of(hash(p.seed, static_cast<std::uint32_t>(i)));
    o.key = lattice.key;
    o.ox = lattice.ox;
    o.oy = lattice.oy;
    o.oz = lattice.oz;
    plan.count = i + 1;
    frequency *= p.lacunarity;
    amplitude *= gain;
    relative *= gain;
  }
  return plan;
}

// Plans of recent calls on this thread. Node kernels evaluate many fractals in turn (a scene's
// discs, block after block; the sphere tracer, point after point), and a plan costs a pow and ~5
// hashes per octave (plus two logarithms when it is asked for by sample spacing), far more than
// a small block of points. A plan is a pure function of its key, compared byte for byte (equal
// bytes imply equal fields), so caching changes no result.
struct PlanKey {
  FractalParams params;
  std::uint32_t lod = 0;             // bits of the octave count, or of the sample spacing
  std::uint32_t lod_is_spacing = 0;  // 1: `lod` is a spacing for visible_octaves
};
static_assert(sizeof(PlanKey) == 64, "PlanKey is compared and hashed as padding-free bytes");

class PlanCache {
 public:
  const Plan& find(const FractalParams& p, float lod, bool lod_is_spacing) {
    PlanKey key;
    key.params = p;
    key.lod = bits_of(lod);
    key.lod_is_spacing = lod_is_spacing ? 1u : 0u;
    std::array<std::uint32_t, sizeof(PlanKey) / 4> words;
    std::memcpy(words.data(), &key, sizeof key);
    std::uint32_t h = 0;
    for (const std::uint32_t w : words) h = (h ^ w) * 0x9e3779b1u;
    Entry* set = &entries_[(h >> (32 - kSetBits)) * kWays];
    ++clock_;
    Entry* oldest = set;
    for (std::size_t way = 0; way < kWays; ++way) {
      Entry& e = set[way];
      if (e.used != 0 && std::memcmp(&e.key, &key, sizeof key) == 0) {
        e.used = clock_;
        return e.plan;
      }
      if (e.used < oldest->used) oldest = &e;
    }
    oldest->key = key;
    oldest->used = clock_;
    oldest->plan = make_plan(p, lod_is_spacing ? visible_octaves(p, lod) : lod);
    return oldest->plan;
  }

 private:
  // 64 sets of 4 (least recently used replaced): room for the fractals of a large scene at one
  // level of detail without conflicts thrashing.
  static constexpr int kSetBits = 6;
  static constexpr std::size_t kWays = 4;
  struct Entry {
    PlanKey key;
    std::uint64_t used = 0;  // 0: empty
    Plan plan;
  };
  std::uint64_t clock_ = 0;
  std::array<Entry, (std::size_t{1} << kSetBits) * kWays> entries_{};
};

const Plan& cached_plan(const FractalParams& p, float lod, bool lod_is_spacing = false) {
  // Allocated on first use: threads that never evaluate noise do not pay for it.
  thread_local std::unique_ptr<PlanCache> cache;
  if (!cache) cache = std::make_unique<PlanCache>();
  return cache->find(p, lod, lod_is_spacing);
}

template <Basis B, class L, class F = typename L::F>
TERRAIN_NOISE_INLINE Lanes2<F> basis2(const Octave& o, F x, F y) {
  if constexpr (B == Basis::gradient) {
    return gradient2_kernel<L>(x + o.ox, y + o.oy, o.key);
  } else {
    return simplex2_kernel<L>(x + o.ox, y + o.oy, o.key);
  }
}

template <Basis B, class L>
TERRAIN_NOISE_INLINE Sample3 basis3(const Octave& o, float x, float y, float z) {
  if constexpr (B == Basis::gradient) {
    return gradient3_kernel<L>(x + o.ox, y + o.oy, z + o.oz, o.key);
  } else {
    return simplex3_kernel<L>(x + o.ox, y + o.oy, z + o.oz, o.key);
  }
}

// Per-octave steps, shared by the batch loops and the single-point path. `State` holds the three
// running values each kind carries from octave to octave (ridged/hybrid: the weight W and ∇W;
// warped: the height sum T = Σ_{j<i} H_j and ∇T).
template <class F>
struct State2 {
  F a;
  F ax;
  F ay;
};

template <class F>
TERRAIN_NOISE_INLINE State2<F> initial_state(Fractal kind) {
  const F zero = splat<F>(0.0f);
  return {kind == Fractal::warped ? zero : splat<F>(1.0f), zero, zero};
}

template <Basis B, class L, class F>
TERRAIN_NOISE_INLINE void fbm2_step(const Octave& o, F x, F y, F& v, F& dx, F& dy) {
  const Lanes2<F> n = basis2<B, L>(o, x * o.frequency, y * o.frequency);
  v += o.amplitude * n.value;
  dx += o.slope * n.dx;
  dy += o.slope * n.dy;
}

// All ones where 0 < x < 1 (the clamp to [0, 1] passes derivatives), else zero. Pure integer
// arithmetic on the bits: with compares GCC threads this test into the clamp's and branches.
template <class F>
TERRAIN_NOISE_INLINE BitsOf<F> free_mask(F x) {
  const BitsOf<F> b = bits_of(x);
  // Bit 31 of (b − 1) is clear iff 0 < b ≤ 2^31; bit 31 of (one − 1 − b) is clear iff b < one.
  const BitsOf<F> outside = ((b - 1u) | (bits_of(1.0f) - 1u - b)) >> 31;
  return outside - 1u;
}

// Ridged: s = (offset − |η|)², term = a·s·W, next W = clamp(gain·s, 0, 1).
template <class F>
TERRAIN_NOISE_INLINE void ridged_update(const Octave& o, float offset, float ridge_gain, F n, F nx,
                                        F ny, F& v, F& dx, F& dy, F& w, F& wx, F& wy) {
  // d|η|/dη = sign(η), taken from the sign bit.
  const BitsOf<F> sign = bits_of(n) & 0x80000000u;
  const F m = offset - from_bits(bits_of(n) ^ sign);
  const F s = m * m;
  const F ds = from_bits(bits_of(-2.0f * m) ^ sign);
  const F sx = ds * nx;
  const F sy = ds * ny;
  v += o.amplitude * (s * w);
  dx += o.amplitude * (w * sx + s * wx);
  dy += o.amplitude * (w * sy + s * wy);
  const F raw = ridge_gain * s;
  const BitsOf<F> free = free_mask(raw);
  w = clamp01(raw);
  wx = from_bits(bits_of(ridge_gain * sx) & free);
  wy = from_bits(bits_of(ridge_gain * sy) & free);
}

// Hybrid: s = (η + offset)·r^{-iH}, term = amplitude·W·s, next W = clamp(W·s, 0, 1).
template <class F>
TERRAIN_NOISE_INLINE void hybrid_update(const Octave& o, float offset, F n, F nx, F ny, F& v, F& dx,
                                        F& dy, F& w, F& wx, F& wy) {
  const F s = (n + offset) * o.gain;
  const F sx = o.gain * nx;
  const F sy = o.gain * ny;
  const F px = w * sx + s * wx;
  const F py = w * sy + s * wy;
  const F raw = w * s;
  v += o.amplitude * raw;
  dx += o.amplitude * px;
  dy += o.amplitude * py;
  const BitsOf<F> free = free_mask(raw);
  w = clamp01(raw);
  wx = from_bits(bits_of(px) & free);
  wy = from_bits(bits_of(py) & free);
}

template <Basis B, class L, class F>
TERRAIN_NOISE_INLINE void ridged2_step(const Octave& o, float offset, float ridge_gain, F x, F y,
                                       F& v, F& dx, F& dy, State2<F>& st) {
  const Lanes2<F> n = basis2<B, L>(o, x * o.frequency, y * o.frequency);
  ridged_update(o, offset, ridge_gain, n.value, o.frequency * n.dx, o.frequency * n.dy, v, dx, dy,
                st.a, st.ax, st.ay);
}

template <Basis B, class L, class F>
TERRAIN_NOISE_INLINE void hybrid2_step(const Octave& o, float offset, F x, F y, F& v, F& dx, F& dy,
                                       State2<F>& st) {
  const Lanes2<F> n = basis2<B, L>(o, x * o.frequency, y * o.frequency);
  hybrid_update(o, offset, n.value, o.frequency * n.dx, o.frequency * n.dy, v, dx, dy, st.a, st.ax,
                st.ay);
}

// Warped: φ = twist·T + i·c2, q = f·Rot(φ)p + c3·T, H += w·a·η(q), T += H (after the octave).
template <Basis B, class L, class F>
TERRAIN_NOISE_INLINE void warped2_step(const Octave& o, float twist, float shift_x, float shift_y,
                                       F x, F y, F& v, F& dx, F& dy, State2<F>& st) {
  const F phi = twist * st.a + o.phase;
  const F phix = twist * st.ax;
  const F phiy = twist * st.ay;
  const Rotation<F> r = rotation_of(phi);
  const float f = o.frequency;
  const F qx = f * (r.cos * x - r.sin * y) + shift_x * st.a;
  const F qy = f * (r.sin * x + r.cos * y) + shift_y * st.a;
  // Jacobian ∂q/∂p = f·Rot(φ) + f·Rot'(φ)p ∇φᵀ + c3 ∇Tᵀ.
  const F tx = f * (r.dcos * x - r.dsin * y);
  const F ty = f * (r.dsin * x + r.dcos * y);
  const F fc = f * r.cos;
  const F fs = f * r.sin;
  const F j11 = fc + tx * phix + shift_x * st.ax;
  const F j12 = (tx * phiy - fs) + shift_x * st.ay;
  const F j21 = fs + ty * phix + shift_y * st.ax;
  const F j22 = fc + ty * phiy + shift_y * st.ay;
  const Lanes2<F> n = basis2<B, L>(o, qx, qy);
  v += o.amplitude * n.value;
  dx += o.amplitude * (n.dx * j11 + n.dy * j21);
  dy += o.amplitude * (n.dx * j12 + n.dy * j22);
  st.a += v;
  st.ax += dx;
  st.ay += dy;
}

template <Basis B, class L>
TERRAIN_NOISE_INLINE void fbm3_step(const Octave& o, float x, float y, float z, float& v, float& dx,
                                    float& dy, float& dz) {
  const Sample3 n = basis3<B, L>(o, x * o.frequency, y * o.frequency, z * o.frequency);
  v += o.amplitude * n.value;
  dx += o.slope * n.dx;
  dy += o.slope * n.dy;
  dz += o.slope * n.dz;
}

struct State3 {
  float a = 1.0f;
  float ax = 0.0f;
  float ay = 0.0f;
  float az = 0.0f;
};

// The 3D ridged/hybrid steps reuse the 2D updates for x and y and repeat the z lines, keeping the
// arithmetic identical per component.
template <Basis B, class L>
TERRAIN_NOISE_INLINE void ridged3_step(const Octave& o, float offset, float ridge_gain, float x,
                                       float y, float z, float& v, float& dx, float& dy, float& dz,
                                       State3& st) {
  const Sample3 n = basis3<B, L>(o, x * o.frequency, y * o.frequency, z * o.frequency);
  const float nz = o.frequency * n.dz;
  const std::uint32_t sign = bits_of(n.value) & 0x80000000u;
  const float m = offset - from_bits(bits_of(n.value) ^ sign);
  const float s = m * m;
  const float sz = from_bits(bits_of(-2.0f * m) ^ sign) * nz;
  dz += o.amplitude * (st.a * sz + s * st.az);
  const float next_az = from_bits(bits_of(ridge_gain * sz) & free_mask(ridge_gain * s));
  ridged_update(o, offset, ridge_gain, n.value, o.frequency * n.dx, o.frequency * n.dy, v, dx, dy,
                st.a, st.ax, st.ay);
  st.az = next_az;
}

template <Basis B, class L>
TERRAIN_NOISE_INLINE void hybrid3_step(const Octave& o, float offset, float x, float y, float z,
                                       float& v, float& dx, float& dy, float& dz, State3& st) {
  const Sample3 n = basis3<B, L>(o, x * o.frequency, y * o.frequency, z * o.frequency);
  const float s = (n.value + offset) * o.gain;
  const float sz = o.gain * (o.frequency * n.dz);
  const float pz = st.a * sz + s * st.az;
  dz += o.amplitude * pz;
  const float next_az = from_bits(bits_of(pz) & free_mask(st.a * s));
  hybrid_update(o, offset, n.value, o.frequency * n.dx, o.frequency * n.dy, v, dx, dy, st.a, st.ax,
                st.ay);
  st.az = next_az;
}

// ---------------------------------------------------------------------------------------------
// Single-point evaluation.

template <Basis B>
Sample2 fractal2_point(const Plan& plan, float x, float y) {
  float v = 0.0f, dx = 0.0f, dy = 0.0f;
  State2<float> st = initial_state<float>(plan.kind);
  for (int i = 0; i < plan.count; ++i) {
    const Octave o = plan.octave[static_cast<std::size_t>(i)];
    switch (plan.kind) {
      case Fractal::fbm:
        fbm2_step<B, ScalarLanes>(o, x, y, v, dx, dy);
        break;
      case Fractal::ridged:
        ridged2_step<B, ScalarLanes>(o, plan.ridge_offset, plan.ridge_gain, x, y, v, dx, dy, st);
        break;
      case Fractal::hybrid:
        hybrid2_step<B, ScalarLanes>(o, plan.ridge_offset, x, y, v, dx, dy, st);
        break;
      case Fractal::warped:
        warped2_step<B, ScalarLanes>(o, plan.twist, plan.shift_x, plan.shift_y, x, y, v, dx, dy,
                                     st);
        break;
    }
  }
  return {v, dx, dy};
}

template <Basis B>
Sample3 fractal3_point(const Plan& plan, float x, float y, float z) {
  float v = 0.0f, dx = 0.0f, dy = 0.0f, dz = 0.0f;
  State3 st;
  for (int i = 0; i < plan.count; ++i) {
    const Octave o = plan.octave[static_cast<std::size_t>(i)];
    switch (plan.kind) {
      case Fractal::ridged:
        ridged3_step<B, ScalarLanes>(o, plan.ridge_offset, plan.ridge_gain, x, y, z, v, dx, dy, dz,
                                     st);
        break;
      case Fractal::hybrid:
        hybrid3_step<B, ScalarLanes>(o, plan.ridge_offset, x, y, z, v, dx, dy, dz, st);
        break;
      case Fractal::fbm:
      case Fractal::warped:  // no 3D warp: planets use plain fBm for this kind
        fbm3_step<B, ScalarLanes>(o, x, y, z, v, dx, dy, dz);
        break;
    }
  }
  return {v, dx, dy, dz};
}

// ---------------------------------------------------------------------------------------------
// Batch evaluation: points are processed in fixed-size chunks (the last one copied and padded with
// zeros), and for each octave a branch-free loop runs over the chunk, accumulating into local
// arrays. The constant trip count and the local outputs let GCC vectorise the loops without alias
// checks or epilogues, even at -O2.

constexpr std::size_t kChunk = 128;

template <Basis B>
TERRAIN_NOISE_INLINE void chunk2(const Plan& plan, std::size_t count, const float* x,
                                 const float* y, float* v, float* dx, float* dy, float* sa,
                                 float* sx, float* sy) {
  for (std::size_t k = 0; k < count; ++k) {
    v[k] = 0.0f;
    dx[k] = 0.0f;
    dy[k] = 0.0f;
  }
  if (plan.kind != Fractal::fbm) {
    const State2<float> init = initial_state<float>(plan.kind);
    for (std::size_t k = 0; k < count; ++k) {
      sa[k] = init.a;
      sx[k] = init.ax;
      sy[k] = init.ay;
    }
  }
  const float offset = plan.ridge_offset;
  const float ridge_gain = plan.ridge_gain;
  const float twist = plan.twist;
  const float shift_x = plan.shift_x;
  const float shift_y = plan.shift_y;
  for (int i = 0; i < plan.count; ++i) {
    const Octave o = plan.octave[static_cast<std::size_t>(i)];
    switch (plan.kind) {
      case Fractal::fbm:
        for (std::size_t k = 0; k < count; ++k)
          fbm2_step<B, BitLanes>(o, x[k], y[k], v[k], dx[k], dy[k]);
        break;
      case Fractal::ridged:
        for (std::size_t k = 0; k < count; ++k) {
          State2<float> st{sa[k], sx[k], sy[k]};
          ridged2_step<B, BitLanes>(o, offset, ridge_gain, x[k], y[k], v[k], dx[k], dy[k], st);
          sa[k] = st.a;
          sx[k] = st.ax;
          sy[k] = st.ay;
        }
        break;
      case Fractal::hybrid:
        for (std::size_t k = 0; k < count; ++k) {
          State2<float> st{sa[k], sx[k], sy[k]};
          hybrid2_step<B, BitLanes>(o, offset, x[k], y[k], v[k], dx[k], dy[k], st);
          sa[k] = st.a;
          sx[k] = st.ax;
          sy[k] = st.ay;
        }
        break;
      case Fractal::warped:
        for (std::size_t k = 0; k < count; ++k) {
          State2<float> st{sa[k], sx[k], sy[k]};
          warped2_step<B, BitLanes>(o, twist, shift_x, shift_y, x[k], y[k], v[k], dx[k], dy[k], st);
          sa[k] = st.a;
          sx[k] = st.ax;
          sy[k] = st.ay;
        }
        break;
    }
  }
}

TERRAIN_NOISE_INLINE void fractal2_chunks(const Plan& plan, const float* x, const float* y,
                                          std::size_t n, float* value, float* dx, float* dy) {
  alignas(32) float cx[kChunk], cy[kChunk], cv[kChunk], cdx[kChunk], cdy[kChunk];
  alignas(32) float sa[kChunk], sx[kChunk], sy[kChunk];
  for (std::size_t base = 0; base < n; base += kChunk) {
    const std::size_t m = std::min(kChunk, n - base);
    const float* px = x + base;
    const float* py = y + base;
    // Short calls (node kernels pass blocks of ≤ 64 points, fewer after culling) run only as far
    // as the vector width needs: a partial chunk is padded with zeros to a multiple of 8 lanes.
    const std::size_t count = (m + 7) & ~std::size_t{7};
    if (m < count) {
      std::fill(cx, cx + count, 0.0f);
      std::fill(cy, cy + count, 0.0f);
      std::copy(px, px + m, cx);
      std::copy(py, py + m, cy);
      px = cx;
      py = cy;
    }
    if (plan.basis == Basis::simplex) {
      chunk2<Basis::simplex>(plan, count, px, py, cv, cdx, cdy, sa, sx, sy);
    } else {
      chunk2<Basis::gradient>(plan, count, px, py, cv, cdx, cdy, sa, sx, sy);
    }
    for (std::size_t k = 0; k < m; ++k) {
      value[base + k] = cv[k];
      dx[base + k] = cdx[k];
      dy[base + k] = cdy[k];
    }
  }
}

// Gradient noise on explicit vectors: a vector of points at a time through every octave, in
// registers. The last group is padded with zeros (harmless inputs whose results are dropped).
template <class Vec, Fractal K>
TERRAIN_NOISE_INLINE void fractal2_lanes(const Plan& plan, const float* x, const float* y,
                                         std::size_t n, float* value, float* dx, float* dy) {
  using L = VectorLanes<Vec>;
  constexpr std::size_t kLanes = sizeof(Vec) / sizeof(float);
  for (std::size_t base = 0; base < n; base += kLanes) {
    const std::size_t m = std::min(kLanes, n - base);
    Vec px{}, py{};
    if (m == kLanes) {
      std::memcpy(&px, x + base, sizeof px);
      std::memcpy(&py, y + base, sizeof py);
    } else {
      for (std::size_t k = 0; k < m; ++k) {
        px[k] = x[base + k];
        py[k] = y[base + k];
      }
    }
    Vec v{}, gx{}, gy{};
    State2<Vec> st = initial_state<Vec>(K);
    for (int i = 0; i < plan.count; ++i) {
      const Octave& o = plan.octave[static_cast<std::size_t>(i)];
      if constexpr (K == Fractal::fbm) {
        fbm2_step<Basis::gradient, L>(o, px, py, v, gx, gy);
      } else if constexpr (K == Fractal::ridged) {
        ridged2_step<Basis::gradient, L>(o, plan.ridge_offset, plan.ridge_gain, px, py, v, gx, gy,
                                         st);
      } else if constexpr (K == Fractal::hybrid) {
        hybrid2_step<Basis::gradient, L>(o, plan.ridge_offset, px, py, v, gx, gy, st);
      } else {
        warped2_step<Basis::gradient, L>(o, plan.twist, plan.shift_x, plan.shift_y, px, py, v, gx,
                                         gy, st);
      }
    }
    if (m == kLanes) {
      std::memcpy(value + base, &v, sizeof v);
      std::memcpy(dx + base, &gx, sizeof gx);
      std::memcpy(dy + base, &gy, sizeof gy);
    } else {
      for (std::size_t k = 0; k < m; ++k) {
        value[base + k] = v[k];
        dx[base + k] = gx[k];
        dy[base + k] = gy[k];
      }
    }
  }
}

template <class Vec>
TERRAIN_NOISE_INLINE void fractal2_vectors(const Plan& plan, const float* x, const float* y,
                                           std::size_t n, float* value, float* dx, float* dy) {
  if (plan.basis != Basis::gradient) {
    fractal2_chunks(plan, x, y, n, value, dx, dy);
    return;
  }
  switch (plan.kind) {
    case Fractal::fbm:
      fractal2_lanes<Vec, Fractal::fbm>(plan, x, y, n, value, dx, dy);
      break;
    case Fractal::ridged:
      fractal2_lanes<Vec, Fractal::ridged>(plan, x, y, n, value, dx, dy);
      break;
    case Fractal::hybrid:
      fractal2_lanes<Vec, Fractal::hybrid>(plan, x, y, n, value, dx, dy);
      break;
    case Fractal::warped:
      fractal2_lanes<Vec, Fractal::warped>(plan, x, y, n, value, dx, dy);
      break;
  }
}

// One version per instruction set, picked when the program loads. The baseline runs the loops
// GCC vectorises (fractal2_chunks); with AVX2 and AVX-512, gradient noise runs on explicit 8- and
// 16-lane vectors, which fetch lattice gradients with a permute instead of a dozen bit operations.
#if TERRAIN_MULTIVERSION
[[gnu::target("default")]]
#endif
void fractal2_batch(const Plan& plan, const float* x, const float* y, std::size_t n, float* value,
                    float* dx, float* dy) {
  fractal2_chunks(plan, x, y, n, value, dx, dy);
}

#if TERRAIN_MULTIVERSION

[[gnu::target("avx2")]] void fractal2_batch(const Plan& plan, const float* x, const float* y,
                                            std::size_t n, float* value, float* dx, float* dy) {
  fractal2_vectors<Vec8>(plan, x, y, n, value, dx, dy);
}

[[gnu::target("avx512f")]] void fractal2_batch(const Plan& plan, const float* x, const float* y,
                                               std::size_t n, float* value, float* dx, float* dy) {
  fractal2_vectors<Vec16>(plan, x, y, n, value, dx, dy);
}
#endif

template <Basis B>
TERRAIN_NOISE_INLINE void chunk3(const Plan& plan, std::size_t count, const float* x,
                                 const float* y, const float* z, float* v, float* dx, float* dy,
                                 float* dz, float* sa, float* sx, float* sy, float* sz) {
  for (std::size_t k = 0; k < count; ++k) {
    v[k] = 0.0f;
    dx[k] = 0.0f;
    dy[k] = 0.0f;
    dz[k] = 0.0f;
  }
  if (plan.kind == Fractal::ridged || plan.kind == Fractal::hybrid) {
    for (std::size_t k = 0; k < count; ++k) {
      sa[k] = 1.0f;
      sx[k] = 0.0f;
      sy[k] = 0.0f;
      sz[k] = 0.0f;
    }
  }
  const float offset = plan.ridge_offset;
  const float ridge_gain = plan.ridge_gain;
  for (int i = 0; i < plan.count; ++i) {
    const Octave o = plan.octave[static_cast<std::size_t>(i)];
    switch (plan.kind) {
      case Fractal::ridged:
        for (std::size_t k = 0; k < count; ++k) {
          State3 st{sa[k], sx[k], sy[k], sz[k]};
          ridged3_step<B, BitLanes>(o, offset, ridge_gain, x[k], y[k], z[k], v[k], dx[k], dy[k],
                                    dz[k], st);
          sa[k] = st.a;
          sx[k] = st.ax;
          sy[k] = st.ay;
          sz[k] = st.az;
        }
        break;
      case Fractal::hybrid:
        for (std::size_t k = 0; k < count; ++k) {
          State3 st{sa[k], sx[k], sy[k], sz[k]};
          hybrid3_step<B, BitLanes>(o, offset, x[k], y[k], z[k], v[k], dx[k], dy[k], dz[k], st);
          sa[k] = st.a;
          sx[k] = st.ax;
          sy[k] = st.ay;
          sz[k] = st.az;
        }
        break;
      case Fractal::fbm:
      case Fractal::warped:
        for (std::size_t k = 0; k < count; ++k) {
          fbm3_step<B, BitLanes>(o, x[k], y[k], z[k], v[k], dx[k], dy[k], dz[k]);
        }
        break;
    }
  }
}

TERRAIN_SIMD_CLONES void fractal3_batch(const Plan& plan, const float* x, const float* y,
                                        const float* z, std::size_t n, float* value, float* dx,
                                        float* dy, float* dz) {
  alignas(32) float cx[kChunk], cy[kChunk], cz[kChunk];
  alignas(32) float cv[kChunk], cdx[kChunk], cdy[kChunk], cdz[kChunk];
  alignas(32) float sa[kChunk], sx[kChunk], sy[kChunk], sz[kChunk];
  for (std::size_t base = 0; base < n; base += kChunk) {
    const std::size_t m = std::min(kChunk, n - base);
    const float* px = x + base;
    const float* py = y + base;
    const float* pz = z + base;
    const std::size_t count = (m + 7) & ~std::size_t{7};
    if (m < count) {
      std::fill(cx, cx + count, 0.0f);
      std::fill(cy, cy + count, 0.0f);
      std::fill(cz, cz + count, 0.0f);
      std::copy(px, px + m, cx);
      std::copy(py, py + m, cy);
      std::copy(pz, pz + m, cz);
      px = cx;
      py = cy;
      pz = cz;
    }
    if (plan.basis == Basis::simplex) {
      chunk3<Basis::simplex>(plan, count, px, py, pz, cv, cdx, cdy, cdz, sa, sx, sy, sz);
    } else {
      chunk3<Basis::gradient>(plan, count, px, py, pz, cv, cdx, cdy, cdz, sa, sx, sy, sz);
    }
    for (std::size_t k = 0; k < m; ++k) {
      value[base + k] = cv[k];
      dx[base + k] = cdx[k];
      dy[base + k] = cdy[k];
      dz[base + k] = cdz[k];
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Bounds (double precision; see docs/noise.md for the derivations).

struct Range {
  double lo = 0.0;
  double hi = 0.0;
};

Range product(Range a, Range b) {
  const double p[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
  return {std::min({p[0], p[1], p[2], p[3]}), std::max({p[0], p[1], p[2], p[3]})};
}
Range scaled(Range a, double s) {
  return product(a, {s, s});
}
Range clamped01(Range a) {
  return {std::clamp(a.lo, 0.0, 1.0), std::clamp(a.hi, 0.0, 1.0)};
}
double magnitude(Range a) {
  return std::max(std::abs(a.lo), std::abs(a.hi));
}

// Rounds a bound up to a float, with a relative margin for the float evaluation's rounding.
float round_up(double x) {
  const double padded = x + std::abs(x) * 1e-6;
  const auto f = static_cast<float>(padded);
  return static_cast<double>(f) < padded ? std::nextafter(f, std::numeric_limits<float>::infinity())
                                         : f;
}
float round_down(double x) {
  const double padded = x - std::abs(x) * 1e-6;
  const auto f = static_cast<float>(padded);
  return static_cast<double>(f) > padded
             ? std::nextafter(f, -std::numeric_limits<float>::infinity())
             : f;
}

struct FractalBounds {
  Range value;
  double lipschitz = 0.0;
};

// What is known of one octave's basis term η_i(f_i p) over the region bounded: its range, and a
// bound of |∇η_i| at unit frequency (the gradient in p is f_i times that).
struct OctaveReach {
  Range value{-1.0, 1.0};
  double slope = 0.0;
};

// |x| over x in a.
Range absolute(Range a) {
  if (a.lo <= 0.0 && a.hi >= 0.0) return {0.0, magnitude(a)};
  return {std::min(std::abs(a.lo), std::abs(a.hi)), magnitude(a)};
}
// x² over x in a.
Range squared(Range a) {
  const Range m = absolute(a);
  return {m.lo * m.lo, m.hi * m.hi};
}

// `reach(octave)` says what is known of each octave over the region: the whole basis range and
// its Lipschitz constant for global bounds, or far less over a small region (fractal_bounds_near).
// With `least`, each octave's amplitude at the smallest octave count, the bounds hold for every
// count from that to the plan's: each octave's amplitude (its weight included) is an interval.
template <class Reach>
FractalBounds bounds_of(const Plan& plan, const double* least, double radius, Reach reach) {
  FractalBounds out;
  const Fractal kind = plan.kind;
  const double offset = plan.ridge_offset;
  const double ridge_gain = plan.ridge_gain;
  // ridged/hybrid weight W_i: its range and a bound of |∇W_i|.
  Range weight{1.0, 1.0};
  double weight_slope = 0.0;
  // ridged: the previous octave, whose slope coefficient waits for this octave's s.
  struct RidgedOctave {
    bool pending = false;
    double own = 0.0;        // |a_i|·max|W_i|
    double m = 0.0;          // max |m_i|
    double eta_slope = 0.0;  // bound of |∇η_i(f_i p)|
    bool free = false;       // whether W_{i+1}'s clamp can be inactive
    double gain = 0.0;
    // The coefficient's bound, given a bound of |a_{i+1}| s_{i+1}, times |∇η_i|.
    double settle(double next_term) const {
      double c = 2.0 * m * own;
      if (free) {
        c = std::max(c, 2.0 * std::min(m, 1.0 / std::sqrt(gain)) * (own + gain * next_term));
      }
      return c * eta_slope;
    }
  } ridged;
  ridged.gain = ridge_gain;
  // warped: bounds of |∇H_{i-1}| and |∇T_i|.
  double height_slope = 0.0;
  double sum_slope = 0.0;
  const double shift =
      std::hypot(static_cast<double>(plan.shift_x), static_cast<double>(plan.shift_y));
  const double twist = std::abs(static_cast<double>(plan.twist));
  for (int i = 0; i < plan.count; ++i) {
    const Octave& o = plan.octave[static_cast<std::size_t>(i)];
    const double a = o.amplitude;  // includes the octave weight
    const double f = o.frequency;
    const Range amplitude{least == nullptr ? a : least[i], a};
    const OctaveReach eta = reach(o);
    const double eta_slope = std::abs(f) * eta.slope;  // |∇η(f p)|
    switch (kind) {
      case Fractal::fbm: {
        const Range term = product(eta.value, amplitude);
        out.value.lo += term.lo;
        out.value.hi += term.hi;
        out.lipschitz += std::abs(a) * eta_slope;
        break;
      }
      case Fractal::ridged: {
        // s = m², m = o − |η|, and the next weight W' = clamp(γs). η_i enters the gradient
        // through this term and through W', with one sign: ∂F/∂η_i = −sgn(η_i)·2m·(a_i W_i +
        // [γs < 1] γ a_{i+1} s_{i+1}). Where that clamp is inactive |m| < 1/√γ, so the two
        // parts never peak at one point (ridged_coefficient): octave i's slope coefficient is
        // settled once octave i+1's s is known.
        const Range abs_eta = absolute(eta.value);
        const Range m{offset - abs_eta.hi, offset - abs_eta.lo};
        const Range s = squared(m);
        const Range term = product(product(s, weight), amplitude);
        out.value.lo += term.lo;
        out.value.hi += term.hi;
        if (ridged.pending) out.lipschitz += ridged.settle(std::abs(a) * s.hi);
        ridged.pending = true;
        ridged.own = std::abs(a) * magnitude(weight);
        ridged.m = magnitude(m);
        ridged.eta_slope = eta_slope;
        ridged.free = ridge_gain > 0.0 && ridge_gain * s.lo < 1.0;
        weight = clamped01(scaled(s, ridge_gain));
        break;
      }
      case Fractal::hybrid: {
        const double g = o.gain;
        const Range s = scaled({eta.value.lo + offset, eta.value.hi + offset}, g);
        const double s_slope = g * eta_slope;
        const Range ws = product(weight, s);
        const Range term = product(ws, amplitude);
        out.value.lo += term.lo;
        out.value.hi += term.hi;
        const double product_slope = magnitude(weight) * s_slope + magnitude(s) * weight_slope;
        out.lipschitz += std::abs(a) * product_slope;
        weight = clamped01(ws);
        weight_slope = product_slope;
        break;
      }
      case Fractal::warped: {
        out.value.lo -= std::abs(a);
        out.value.hi += std::abs(a);
        // ‖∂q/∂p‖ ≤ f‖Rot‖ + (f‖Rot'‖|p|·|c1/(rH)| + |c3|)·|∇T_i|.
        const double jacobian = std::abs(f) * kRotationNorm +
                                (std::abs(f) * kRotationNorm * radius * twist + shift) * sum_slope;
        height_slope += std::abs(a) * eta.slope * jacobian;
        sum_slope += height_slope;
        out.lipschitz = height_slope;
        break;
      }
    }
  }
  if (ridged.pending) out.lipschitz += ridged.settle(0.0);
  return out;
}

FractalBounds bounds_of(const FractalParams& p, float octaves, double radius, double lambda) {
  return bounds_of(cached_plan(p, octaves), nullptr, radius, [lambda](const Octave&) {
    return OctaveReach{{-1.0, 1.0}, lambda};
  });
}

// Proven bounds of the Hessian's norm at unit frequency, |∇η(a) − ∇η(b)| ≤ M₂|a − b|
// (docs/noise.md, "Hessian bounds"): gradient 2D 18.182 (the bound function's maximum) and
// simplex 2D 123.81 (three vertices at their worst), plus margin.
constexpr double kHessianGradient2 = 20.0;
constexpr double kHessianSimplex2 = 125.0;

}  // namespace

// -----------------------------------------------------------------------------------------------
// Public API.

Sample2 gradient2(float x, float y, std::uint32_t seed) {
  const Lattice l = lattice_of(seed);
  const Lanes2<float> n = gradient2_kernel<ScalarLanes>(x + l.ox, y + l.oy, l.key);
  return {n.value, n.dx, n.dy};
}

Sample2 simplex2(float x, float y, std::uint32_t seed) {
  const Lattice l = lattice_of(seed);
  const Lanes2<float> n = simplex2_kernel<ScalarLanes>(x + l.ox, y + l.oy, l.key);
  return {n.value, n.dx, n.dy};
}

Sample3 gradient3(float x, float y, float z, std::uint32_t seed) {
  const Lattice l = lattice_of(seed);
  return gradient3_kernel<ScalarLanes>(x + l.ox, y + l.oy, z + l.oz, l.key);
}

Sample3 simplex3(float x, float y, float z, std::uint32_t seed) {
  const Lattice l = lattice_of(seed);
  return simplex3_kernel<ScalarLanes>(x + l.ox, y + l.oy, z + l.oz, l.key);
}

float lipschitz(Basis basis, int dimensions) {
  if (dimensions == 2) return basis == Basis::simplex ? kLipschitzSimplex2 : kLipschitzGradient2;
  if (dimensions == 3) return basis == Basis::simplex ? kLipschitzSimplex3 : kLipschitzGradient3;
  return std::numeric_limits<float>::infinity();
}

float visible_octaves(const FractalParams& p, float spacing) {
  const auto full = static_cast<float>(max_octaves(p));
  if (!(spacing > 0.0f) || !(p.frequency > 0.0f) || !(p.lacunarity > 1.0f)) return full;
  const double n =
      std::log(1.0 / (2.0 * static_cast<double>(spacing) * static_cast<double>(p.frequency))) /
          std::log(static_cast<double>(p.lacunarity)) +
      1.0;
  return static_cast<float>(std::clamp(n, 0.0, static_cast<double>(full)));
}

float octave_weight(int i, float octaves) {
  const auto fi = static_cast<float>(i);
  if (!(octaves > fi)) return 0.0f;  // also NaN
  if (fi + 1.0f <= octaves) return 1.0f;
  const float t = octaves - fi;
  const float u = 1.0f - t * t;
  return 1.0f - u * u * u;
}

void fractal2(const FractalParams& p, const float* x, const float* y, std::size_t n, float octaves,
              float* value, float* dx, float* dy) {
  const Plan& plan = cached_plan(p, octaves);
  fractal2_batch(plan, x, y, n, value, dx, dy);
}

void fractal2_at_spacing(const FractalParams& p, float spacing, const float* x, const float* y,
                         std::size_t n, float* value, float* dx, float* dy) {
  const Plan& plan = cached_plan(p, spacing, true);
  fractal2_batch(plan, x, y, n, value, dx, dy);
}

Sample2 fractal2(const FractalParams& p, Vec2 point, float octaves) {
  const Plan& plan = cached_plan(p, octaves);
  return plan.basis == Basis::simplex ? fractal2_point<Basis::simplex>(plan, point.x, point.y)
                                      : fractal2_point<Basis::gradient>(plan, point.x, point.y);
}

void fractal3(const FractalParams& p, const float* x, const float* y, const float* z, std::size_t n,
              float octaves, float* value, float* dx, float* dy, float* dz) {
  const Plan& plan = cached_plan(p, octaves);
  fractal3_batch(plan, x, y, z, n, value, dx, dy, dz);
}

Sample3 fractal3(const FractalParams& p, float x, float y, float z, float octaves) {
  const Plan& plan = cached_plan(p, octaves);
  return plan.basis == Basis::simplex ? fractal3_point<Basis::simplex>(plan, x, y, z)
                                      : fractal3_point<Basis::gradient>(plan, x, y, z);
}

Interval fractal_range(const FractalParams& p, float octaves) {
  const FractalBounds b = bounds_of(p, octaves, 0.0, 0.0);
  return {round_down(b.value.lo), round_up(b.value.hi)};
}

float fractal_lipschitz(const FractalParams& p, float octaves, float radius) {
  const double r = std::max(0.0, static_cast<double>(radius));
  return round_up(bounds_of(p, octaves, r, lipschitz(p.basis, 2)).lipschitz);
}

RegionBounds fractal_bounds_near(const FractalParams& p, Interval octaves, Vec2 centre,
                                 float radius) {
  const double lambda = lipschitz(p.basis, 2);
  const float most = octaves.hi;
  if (!std::isfinite(centre.x) || !std::isfinite(centre.y) || !(radius >= 0.0f)) {
    return RegionBounds::of_slope(fractal_range(p, most),
                                  fractal_lipschitz(p, most, std::numeric_limits<float>::max()));
  }
  if (p.kind == Fractal::warped) {
    // Range and slope bound hold at any octave count up to `most`; the slope grows with the
    // distance from the origin, at most |c| + r in the region.
    return RegionBounds::of_slope(fractal_range(p, most),
                                  fractal_lipschitz(p, most, length(centre) + radius));
  }
  // Octave i's amplitude lies between the two octave counts' (weights rise with the count). The
  // fewest's are copied out first: the next cache lookup may reuse its entry.
  std::array<double, kMaxOctaves> least{};
  {
    const Plan& fewest = cached_plan(p, std::min(octaves.lo, most));
    for (int i = 0; i < fewest.count; ++i) {
      least[static_cast<std::size_t>(i)] = fewest.octave[static_cast<std::size_t>(i)].amplitude;
    }
  }
  const Plan& plan = cached_plan(p, most);  // no lookup follows while it is in use
  auto least_amplitude = [&](int i) { return least[static_cast<std::size_t>(i)]; };
  const double hessian = hessian_bound(p.basis, 2);
  // The float evaluation's own error is far below this slack (docs/noise.md).
  constexpr double kSlack = 1e-5;
  std::array<OctaveReach, kMaxOctaves> reach{};
  // fBm only: the octaves bounded by Taylor (with a fixed weight) add as vectors at the centre
  // (value, gradient and curvature terms), the others as their ranges and slopes.
  double taylor_x = 0.0, taylor_y = 0.0, remainder = 0.0;
  double taylor_value = 0.0, curvature = 0.0;
  Range rest{0.0, 0.0};
  for (int i = 0; i < plan.count; ++i) {
    const Octave& o = plan.octave[static_cast<std::size_t>(i)];
    OctaveReach& r = reach[static_cast<std::size_t>(i)];
    r = {{-1.0, 1.0}, lambda};
    // The centre in octave o's lattice, computed as the fractal steps compute it, and the
    // region's radius in lattice cells, widened by the float rounding of lattice positions.
    const float x = centre.x * o.frequency;
    const float y = centre.y * o.frequency;
    const double rho = std::abs(static_cast<double>(o.frequency)) * radius +
                       4e-7 * (std::abs(x) + std::abs(y) + 1.0);
    const double amplitude = o.amplitude;
    const double slope_scale = std::abs(amplitude * o.frequency);
    const bool fixed = least_amplitude(i) == amplitude;
    // Near the coordinate clamp the basis has a kink: no Taylor bound there.
    const bool smooth =
        std::abs(x) + rho < 0.5 * kCoordLimit && std::abs(y) + rho < 0.5 * kCoordLimit;
    if (smooth) {
      const Lanes2<float> n = p.basis == Basis::simplex
                                  ? basis2<Basis::simplex, ScalarLanes>(o, x, y)
                                  : basis2<Basis::gradient, ScalarLanes>(o, x, y);
      const double g =
          std::sqrt(static_cast<double>(n.dx) * n.dx + static_cast<double>(n.dy) * n.dy) + kSlack;
      // Taylor: |∇η| ≤ |∇η(c)| + M₂ρ and |η − η(c)| ≤ |∇η(c)|ρ + M₂ρ²/2, never above the global.
      const double spread = std::min(lambda * rho, g * rho + 0.5 * hessian * rho * rho) + kSlack;
      const double value = n.value;
      r = {{std::max(-1.0, value - spread), std::min(1.0, value + spread)},
           std::min(lambda, g + hessian * rho)};
      if (fixed && g + hessian * rho < lambda) {
        taylor_x += amplitude * o.frequency * n.dx;  // signed: these add as vectors
        taylor_y += amplitude * o.frequency * n.dy;
        remainder += slope_scale * (hessian * rho + kSlack);
        taylor_value += amplitude * value;
        curvature += std::abs(amplitude) * (0.5 * hessian * rho * rho + kSlack);
        continue;
      }
    }
    remainder += slope_scale * r.slope;
    const Range term = product(r.value, {least_amplitude(i), amplitude});
    rest = {rest.lo + term.lo, rest.hi + term.hi};
  }
  const FractalBounds local = bounds_of(plan, least.data(), 0.0, [&](const Octave& o) {
    return reach[static_cast<std::size_t>(&o - plan.octave.data())];
  });
  double slope = local.lipschitz;
  Range value = local.value;
  Vec2 gradient{0.0f, 0.0f};
  double spread = slope;
  if (p.kind == Fractal::fbm) {
    const double taylor = std::sqrt(taylor_x * taylor_x + taylor_y * taylor_y);
    if (taylor + remainder < slope) {
      slope = taylor + remainder;
      // The float centre gradient is off the double one by its rounding, added to the spread.
      gradient = {static_cast<float>(taylor_x), static_cast<float>(taylor_y)};
      const double rounded = std::hypot(static_cast<double>(gradient.x) - taylor_x,
                                        static_cast<double>(gradient.y) - taylor_y);
      spread = remainder + rounded;
    }
    // F_T(p) − F_T(c) ≤ |∇F_T(c)| r + Σ a_i M₂ ρ_i²/2 for the Taylor octaves T.
    const double value_reach = taylor * radius + curvature;
    value.lo = std::max(value.lo, taylor_value - value_reach + rest.lo);
    value.hi = std::min(value.hi, taylor_value + value_reach + rest.hi);
  }
  // Never looser than the global bounds: every octave's range and slope lie within the basis'
  // own, and the bounds only grow with them.
  return {{round_down(value.lo), round_up(value.hi)}, round_up(slope), gradient, round_up(spread)};
}

float hessian_bound(Basis basis, int dimensions) {
  if (dimensions == 2) {
    return static_cast<float>(basis == Basis::simplex ? kHessianSimplex2 : kHessianGradient2);
  }
  return std::numeric_limits<float>::infinity();
}

float fractal3_lipschitz(const FractalParams& p, float octaves) {
  FractalParams q = p;
  if (q.kind == Fractal::warped) q.kind = Fractal::fbm;
  return round_up(bounds_of(q, octaves, 0.0, lipschitz(p.basis, 3)).lipschitz);
}

}  // namespace terrain::noise
