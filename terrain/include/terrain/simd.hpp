// Helpers for the loops over a block of points that GCC vectorises (noise, node kernels, blend
// accumulation, the planet's detail noise and drainage floors): clones for AVX-512, AVX2 and the
// baseline chosen at run time, and branch-free selects on float bit patterns. Under GCC's default
// -ftrapping-math a float `c ? a : b` whose operands need arithmetic stays behind branches and
// the loop scalar, which the selects on bits avoided; since 2026-12-06 the project builds with
// -fno-trapping-math (cmake/ProjectOptions.cmake), under which plain selects vectorise too. A
// select returns one of its operands bit for bit and the project builds with -ffp-contract=off,
// so every clone computes the same numbers.
#pragma once

#include <bit>
#include <cstdint>

#if defined(__SANITIZE_THREAD__) || defined(__clang__)
// One baseline version only: ThreadSanitizer instruments the ifunc resolvers that pick a version,
// and the loader runs them before the sanitizer's runtime exists (a crash at start); clang (the
// fuzz preset) multiversions differently from GCC, and fuzzing needs no speed.
#define TERRAIN_SIMD_CLONES
#define TERRAIN_MULTIVERSION 0
#else
/// Compiles a function for AVX-512, AVX2 and the baseline; the loader picks one per machine.
#define TERRAIN_SIMD_CLONES [[gnu::target_clones("avx512f", "avx2", "default")]]
#define TERRAIN_MULTIVERSION 1
#endif
#define TERRAIN_SIMD_INLINE [[gnu::always_inline]] inline

namespace terrain::simd {

TERRAIN_SIMD_INLINE constexpr std::uint32_t bits_of(float x) {
  return std::bit_cast<std::uint32_t>(x);
}
TERRAIN_SIMD_INLINE constexpr float from_bits(std::uint32_t b) {
  return std::bit_cast<float>(b);
}
/// All ones where `condition` holds, else zero.
TERRAIN_SIMD_INLINE constexpr std::uint32_t mask_of(bool condition) {
  return 0u - static_cast<std::uint32_t>(condition);
}
/// mask ? a : b for a mask from mask_of.
TERRAIN_SIMD_INLINE float select(std::uint32_t mask, float a, float b) {
  return from_bits((bits_of(a) & mask) | (bits_of(b) & ~mask));
}

}  // namespace terrain::simd
