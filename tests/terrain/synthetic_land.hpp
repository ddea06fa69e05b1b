// Deterministic synthetic land for the erosion and drainage tests and benchmarks: value noise
// from an integer hash, summed over octaves.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace terrain::testing {

/// Deterministic value noise: a hash per lattice point, smoothstep between.
inline double lattice(int i, int j, int seed) {
  std::uint32_t x = static_cast<std::uint32_t>(i) * 73856093u ^
                    static_cast<std::uint32_t>(j) * 19349663u ^
                    static_cast<std::uint32_t>(seed) * 83492791u;
  x ^= x >> 13;
  x *= 0x5bd1e995u;
  x ^= x >> 15;
  return static_cast<double>(x & 0xffffffu) / 16777215.0;
}

inline double value_noise(double x, double y, int seed) {
  const double fi = std::floor(x), fj = std::floor(y);
  const int i = static_cast<int>(fi), j = static_cast<int>(fj);
  double fx = x - fi, fy = y - fj;
  fx = fx * fx * (3 - 2 * fx);
  fy = fy * fy * (3 - 2 * fy);
  const double a = lattice(i, j, seed), b = lattice(i + 1, j, seed);
  const double c = lattice(i, j + 1, seed), d = lattice(i + 1, j + 1, seed);
  return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy;
}

/// Rough land: eight octaves of value noise over a 4 km square, 100 m plus `scale` times a sum
/// that spans about 1.3 (the default: about 1.4 km of relief).
inline std::vector<float> rough_land(int side, double scale = 1050.0) {
  std::vector<float> z(static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  const double cell = 4000.0 / (side - 1);
  for (int j = 0; j < side; ++j) {
    for (int i = 0; i < side; ++i) {
      double e = 0.0, amplitude = 1.0, frequency = 1.0 / 1500.0;
      for (int o = 0; o < 8; ++o) {
        e += amplitude * value_noise(i * cell * frequency, j * cell * frequency, o);
        amplitude *= 0.5;
        frequency *= 2.0;
      }
      z[static_cast<std::size_t>(j) * static_cast<std::size_t>(side) +
        static_cast<std::size_t>(i)] = static_cast<float>(100.0 + scale * e);
    }
  }
  return z;
}

}  // namespace terrain::testing
