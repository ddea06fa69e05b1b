// Double-precision 3D gradient noise (Perlin's improved noise with hashed gradients), so that
// positions in metres on an Earth-sized sphere keep sub-centimetre resolution at every octave:
// terrain's float noise would quantise a coordinate of 6.4e6 m to half a metre. Lattice corners
// are hashed with terrain::noise::hash, the project's one integer hash.
#pragma once

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
  // Perlin's twelve edge gradients (|g| = √2), chosen by the hash.
  switch (h % 12U) {
    case 0:
      return x + y;
    case 1:
      return -x + y;
    case 2:
      return x - y;
    case 3:
      return -x - y;
    case 4:
      return x + z;
    case 5:
      return -x + z;
    case 6:
      return x - z;
    case 7:
      return -x - z;
    case 8:
      return y + z;
    case 9:
      return -y + z;
    case 10:
      return y - z;
    default:
      return -y - z;
  }
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
