// The planet's gradient noise four at a time: the fractal detail (Planet::detail) for many
// directions, and the relief regions' fields (Rules::region) at one, in AVX2 vectors where the
// CPU has them, else one by one. Every lane computes what the scalar noise (gradient_noise.hpp)
// computes, operation for operation, so the results are the same bits.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "planet/mesh.hpp"

namespace planet::detail {

/// No sum goes past this many octaves (the finest a tile asks for is far coarser), so every
/// sum is bounded even where the gain is 1 (Planet's elevation range counts on it).
inline constexpr int kMaxOctaves = 40;

/// The octaves of one sum: k from `first` while k < kMaxOctaves and k < `octaves` (the last one
/// faded in by its fractional part), octave `first` with `amplitude` and `frequency`, each next one
/// `gain` times as high and `lacunarity` times as fine, octave k's noise seeded with
/// seed + k·0x9e3779b9.
struct DetailOctaves {
  int first = 0;
  double octaves = 0.0;
  double amplitude = 0.0, frequency = 0.0;
  double gain = 0.5, lacunarity = 2.0;
  std::uint32_t seed = 0;

  /// Whether octave k is summed (k ≥ first).
  bool covers(int k) const { return k < kMaxOctaves && k < octaves; }
};

/// Σ_k weight_k · a_k · (1 + clamp(S(p f_k), −1, 1)) / 2 at one direction.
double detail_sum(const DetailOctaves& plan, const Vec3d& p);

/// detail_sum at each of `n` directions, into `out`: the same bits as one by one.
void detail_sums(const DetailOctaves& plan, const Vec3d* p, std::size_t n, double* out);

using Four = std::array<double, 4>;
using FourSeeds = std::array<std::uint32_t, 4>;
/// gradient3 (gradient_noise.hpp) at four points, each with its own seed: the same bits as four
/// calls, in one AVX2 evaluation where the CPU has it (the relief regions' three fields).
Four gradient3_fours(const Four& x, const Four& y, const Four& z, const FourSeeds& seed);

}  // namespace planet::detail
