// Double-precision 3D gradient noise (Perlin's improved noise with hashed gradients), so that
// positions in metres on an Earth-sized sphere keep sub-centimetre resolution at every octave:
// terrain's float noise would quantise a coordinate of 6.4e6 m to half a metre. Lattice corners
// are hashed with terrain::noise::hash, the project's one integer hash.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>

#include "terrain/noise.hpp"

namespace planet::detail {

inline double fade(double t) {
  return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

inline double corner(std::int64_t ix, std::int64_t iy, std::int64_t iz, std::uint32_t seed,
                     double x, double y, double z) {
  // One hash per corner: the three wrapped cell coordinates folded with distinct odd constants.
  const std::uint32_t h = terrain::noise::hash(static_cast<std::uint32_t>(ix) * 0x8da6b343U ^
                                               static_cast<std::uint32_t>(iy) * 0xd8163841U ^
                                               static_cast<std::uint32_t>(iz) * 0xcb1ab31fU ^ seed);
  // Perlin's twelve edge gradients (|g| = √2), chosen by the hash: ±x ± y (0–3), ±x ± z (4–7),
  // ±y ± z (8–11), bit 0 negating the first term and bit 1 the second. Written without branches
  // (a switch on the hash mispredicts at most corners: a zoom-18 planet tile took 18.3 ms with it
  // and 13.5 ms without): the terms are picked and their signs flipped on the bits, and
  // a + (−b) is a − b exactly, so the values are those of the switch.
  const std::uint32_t g = h % 12U;
  const std::uint64_t first_is_y = 0ULL - static_cast<std::uint64_t>(g >= 8U);
  const std::uint64_t second_is_z = 0ULL - static_cast<std::uint64_t>(g >= 4U);
  const auto bits = [](double v) { return std::bit_cast<std::uint64_t>(v); };
  const std::uint64_t first = (bits(x) & ~first_is_y) | (bits(y) & first_is_y);
  const std::uint64_t second = (bits(y) & ~second_is_z) | (bits(z) & second_is_z);
  const std::uint64_t sign = 0x8000000000000000ULL;
  return std::bit_cast<double>(first ^ (static_cast<std::uint64_t>(g & 1U) << 63 & sign)) +
         std::bit_cast<double>(second ^ (static_cast<std::uint64_t>(g & 2U) << 62 & sign));
}

/// Gradient noise at (x, y, z) in lattice units; about [−1, 1].
inline double gradient3(double x, double y, double z, std::uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy),
             iz = static_cast<std::int64_t>(fz);
  const double rx = x - fx, ry = y - fy, rz = z - fz;
  const double u = fade(rx), v = fade(ry), w = fade(rz);
  const double c000 = corner(ix, iy, iz, seed, rx, ry, rz);
  const double c100 = corner(ix + 1, iy, iz, seed, rx - 1, ry, rz);
  const double c010 = corner(ix, iy + 1, iz, seed, rx, ry - 1, rz);
  const double c110 = corner(ix + 1, iy + 1, iz, seed, rx - 1, ry - 1, rz);
  const double c001 = corner(ix, iy, iz + 1, seed, rx, ry, rz - 1);
  const double c101 = corner(ix + 1, iy, iz + 1, seed, rx - 1, ry, rz - 1);
  const double c011 = corner(ix, iy + 1, iz + 1, seed, rx, ry - 1, rz - 1);
  const double c111 = corner(ix + 1, iy + 1, iz + 1, seed, rx - 1, ry - 1, rz - 1);
  const double x00 = c000 + u * (c100 - c000), x10 = c010 + u * (c110 - c010);
  const double x01 = c001 + u * (c101 - c001), x11 = c011 + u * (c111 - c011);
  const double y0 = x00 + v * (x10 - x00), y1 = x01 + v * (x11 - x01);
  return y0 + w * (y1 - y0);
}

}  // namespace planet::detail
