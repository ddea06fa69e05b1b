#include "detail_batch.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#include "gradient_noise.hpp"
#include "terrain/simd.hpp"

#if TERRAIN_MULTIVERSION
#include <immintrin.h>
#endif

namespace planet::detail {

double detail_sum(const DetailOctaves& plan, const Vec3d& p) {
  double sum = 0.0, amplitude = plan.amplitude, frequency = plan.frequency;
  for (int k = plan.first; plan.covers(k); ++k) {
    const double weight = std::min(1.0, plan.octaves - k);  // the last octave fades in
    const double s = gradient3(p[0] * frequency, p[1] * frequency, p[2] * frequency,
                               plan.seed + static_cast<std::uint32_t>(k) * 0x9e3779b9U);
    sum += weight * amplitude * 0.5 * (1.0 + std::clamp(s, -1.0, 1.0));
    amplitude *= plan.gain;
    frequency *= plan.lacunarity;
  }
  return sum;
}

namespace {

void sums_one_by_one(const DetailOctaves& plan, const Vec3d* p, std::size_t n, double* out) {
  for (std::size_t i = 0; i < n; ++i) out[i] = detail_sum(plan, p[i]);
}

#if TERRAIN_MULTIVERSION

using V4d = double __attribute__((vector_size(32)));
using V4u64 = std::uint64_t __attribute__((vector_size(32)));
using V4i64 = std::int64_t __attribute__((vector_size(32)));
using V4u32 = std::uint32_t __attribute__((vector_size(16)));

[[gnu::target("avx2"), gnu::always_inline]] inline V4u64 bits(V4d v) {
  return reinterpret_cast<V4u64>(v);
}
[[gnu::target("avx2"), gnu::always_inline]] inline V4d doubles(V4u64 v) {
  return reinterpret_cast<V4d>(v);
}

/// fade(t) of gradient_noise.hpp, lane by lane.
[[gnu::target("avx2"), gnu::always_inline]] inline V4d fade4(V4d t) {
  return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

/// corner() of gradient_noise.hpp for four lanes: the cell coordinates' low 32 bits, the seed
/// (one for every lane, or one per lane) and the offsets from the corner.
template <typename Seed>
[[gnu::target("avx2"), gnu::always_inline]] inline V4d corner4(V4u32 ix, V4u32 iy, V4u32 iz,
                                                               Seed seed, V4d x, V4d y, V4d z) {
  const V4u32 h = terrain::noise::detail::lowbias32<V4u32>(ix * 0x8da6b343U ^ iy * 0xd8163841U ^
                                                           iz * 0xcb1ab31fU ^ seed);
  // h % 12 exactly: q = ⌊h · 0xAAAAAAAB / 2^35⌋ = ⌊h / 12⌋ for every 32-bit h.
  const auto wide = reinterpret_cast<__m256i>(__builtin_convertvector(h, V4u64));
  const auto q = reinterpret_cast<V4u64>(
      _mm256_srli_epi64(_mm256_mul_epu32(wide, _mm256_set1_epi64x(0xAAAAAAABLL)), 35));
  const V4u64 g = reinterpret_cast<V4u64>(wide) - q * 12U;
  const auto first_is_y = reinterpret_cast<V4u64>(g >= 8U);
  const auto second_is_z = reinterpret_cast<V4u64>(g >= 4U);
  const V4u64 first = (bits(x) & ~first_is_y) | (bits(y) & first_is_y);
  const V4u64 second = (bits(y) & ~second_is_z) | (bits(z) & second_is_z);
  return doubles(first ^ ((g & 1U) << 63)) + doubles(second ^ ((g & 2U) << 62));
}

/// The low 32 bits of the integer an integral double holds, for |v| < 2^51: added to 1.5·2^52
/// it is exact and sits in the mantissa's low bits, in two's complement.
[[gnu::target("avx2"), gnu::always_inline]] inline V4u32 low_bits(V4d integral) {
  const V4u64 b = bits(integral + 0x1.8p52);
  return __builtin_convertvector(b, V4u32);
}

/// std::floor, lane by lane.
[[gnu::target("avx2"), gnu::always_inline]] inline V4d floor4(V4d v) {
  return reinterpret_cast<V4d>(
      _mm256_round_pd(reinterpret_cast<__m256d>(v), _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC));
}

/// gradient3 of gradient_noise.hpp for four lanes.
template <typename Seed>
[[gnu::target("avx2"), gnu::always_inline]] inline V4d gradient4(V4d x, V4d y, V4d z, Seed seed) {
  const V4d fx = floor4(x), fy = floor4(y), fz = floor4(z);
  const V4u32 ix = low_bits(fx), iy = low_bits(fy), iz = low_bits(fz);
  const V4d rx = x - fx, ry = y - fy, rz = z - fz;
  const V4d u = fade4(rx), v = fade4(ry), w = fade4(rz);
  const V4d rx1 = rx - 1.0, ry1 = ry - 1.0, rz1 = rz - 1.0;
  const V4u32 jx = ix + 1U, jy = iy + 1U, jz = iz + 1U;
  const V4d c000 = corner4(ix, iy, iz, seed, rx, ry, rz);
  const V4d c100 = corner4(jx, iy, iz, seed, rx1, ry, rz);
  const V4d c010 = corner4(ix, jy, iz, seed, rx, ry1, rz);
  const V4d c110 = corner4(jx, jy, iz, seed, rx1, ry1, rz);
  const V4d c001 = corner4(ix, iy, jz, seed, rx, ry, rz1);
  const V4d c101 = corner4(jx, iy, jz, seed, rx1, ry, rz1);
  const V4d c011 = corner4(ix, jy, jz, seed, rx, ry1, rz1);
  const V4d c111 = corner4(jx, jy, jz, seed, rx1, ry1, rz1);
  const V4d x00 = c000 + u * (c100 - c000), x10 = c010 + u * (c110 - c010);
  const V4d x01 = c001 + u * (c101 - c001), x11 = c011 + u * (c111 - c011);
  const V4d y0 = x00 + v * (x10 - x00), y1 = x01 + v * (x11 - x01);
  return y0 + w * (y1 - y0);
}

[[gnu::target("avx2")]] void sums_by_four(const DetailOctaves& plan, const Vec3d* p, std::size_t n,
                                          double* out) {
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    const V4d px = {p[i][0], p[i + 1][0], p[i + 2][0], p[i + 3][0]};
    const V4d py = {p[i][1], p[i + 1][1], p[i + 2][1], p[i + 3][1]};
    const V4d pz = {p[i][2], p[i + 1][2], p[i + 2][2], p[i + 3][2]};
    V4d sum = {0.0, 0.0, 0.0, 0.0};
    double amplitude = plan.amplitude, frequency = plan.frequency;
    for (int k = plan.first; plan.covers(k); ++k) {
      const double weight = std::min(1.0, plan.octaves - k);
      V4d s = gradient4(px * frequency, py * frequency, pz * frequency,
                        plan.seed + static_cast<std::uint32_t>(k) * 0x9e3779b9U);
      // std::clamp(s, −1, 1): −1 below, 1 above, else s itself (NaN included).
      s = s < -1.0 ? V4d{} - 1.0 : (1.0 < s ? V4d{} + 1.0 : s);
      sum += weight * amplitude * 0.5 * (1.0 + s);
      amplitude *= plan.gain;
      frequency *= plan.lacunarity;
    }
    for (int lane = 0; lane < 4; ++lane) out[i + lane] = sum[lane];
  }
  sums_one_by_one(plan, p + i, n - i, out + i);
}

[[gnu::target("avx2")]] Four gradients_by_four(const Four& x, const Four& y, const Four& z,
                                               const FourSeeds& seed) {
  const V4d s = gradient4(V4d{x[0], x[1], x[2], x[3]}, V4d{y[0], y[1], y[2], y[3]},
                          V4d{z[0], z[1], z[2], z[3]}, V4u32{seed[0], seed[1], seed[2], seed[3]});
  return {s[0], s[1], s[2], s[3]};
}

#endif

Four gradients_one_by_one(const Four& x, const Four& y, const Four& z, const FourSeeds& seed) {
  Four out{};
  for (std::size_t i = 0; i < 4; ++i) out[i] = gradient3(x[i], y[i], z[i], seed[i]);
  return out;
}

// One version per instruction set, picked when the program loads (as terrain's noise is): the
// baseline sums one direction at a time, AVX2 four. The versions and their callers must share a
// translation unit: a caller that sees only a plain declaration calls the baseline.
#if TERRAIN_MULTIVERSION
[[gnu::target("default")]]
#endif
void sums(const DetailOctaves& plan, const Vec3d* p, std::size_t n, double* out) {
  sums_one_by_one(plan, p, n, out);
}

#if TERRAIN_MULTIVERSION
[[gnu::target("avx2")]] void sums(const DetailOctaves& plan, const Vec3d* p, std::size_t n,
                                  double* out) {
  // The lanes take a cell coordinate's low 32 bits through a double (low_bits), exact below
  // 2^51: far beyond any octave a tile asks for (a metre on an Earth-sized sphere is 2^23),
  // but checked.
  double finest = plan.frequency;
  for (int k = plan.first + 1; plan.covers(k); ++k) finest *= plan.lacunarity;
  if (finest < 0x1p50) {
    sums_by_four(plan, p, n, out);
  } else {
    sums_one_by_one(plan, p, n, out);
  }
}
#endif

#if TERRAIN_MULTIVERSION
[[gnu::target("default")]]
#endif
Four gradients(const Four& x, const Four& y, const Four& z, const FourSeeds& seed) {
  return gradients_one_by_one(x, y, z, seed);
}

#if TERRAIN_MULTIVERSION
[[gnu::target("avx2")]] Four gradients(const Four& x, const Four& y, const Four& z,
                                       const FourSeeds& seed) {
  // low_bits is exact below 2^51 (sums() above).
  for (const Four* axis : {&x, &y, &z}) {
    for (const double v : *axis) {
      if (!(std::abs(v) < 0x1p50)) return gradients_one_by_one(x, y, z, seed);
    }
  }
  return gradients_by_four(x, y, z, seed);
}
#endif

}  // namespace

void detail_sums(const DetailOctaves& plan, const Vec3d* p, std::size_t n, double* out) {
  sums(plan, p, n, out);
}

Four gradient3_fours(const Four& x, const Four& y, const Four& z, const FourSeeds& seed) {
  return gradients(x, y, z, seed);
}

}  // namespace planet::detail
