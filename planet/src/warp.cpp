#include "warp.hpp"

#include <algorithm>

namespace planet::detail {

WarpOctaves warp_octaves(double share, double longest, double edge, double radius,
                         std::uint32_t seed) {
  WarpOctaves plan;
  if (!(share > 0.0)) return plan;
  // Every octave moves points by the same share of its wavelength, so it bends the valleys of
  // its own scale as much as the first bends the longest: a tile sees its valleys wind whatever
  // its zoom. Octaves with amplitudes falling faster than their wavelengths bounded the stretch
  // at the finest levels better but left every valley shorter than the longest octave straight.
  // Their stretches add up, so the octaves are at most kMaxWarpOctaves: with the longest
  // wavelength and share a definition may ask for (100 km, 0.12), six still leave every
  // point's Jacobian a positive determinant (the warp never folds the ground over), and eight
  // did not.
  const double first = std::min(share * longest / radius, 0.05);
  for (double wavelength = longest; wavelength >= 4.0 * edge && plan.count < kMaxWarpOctaves;
       wavelength *= 0.25) {
    ++plan.count;
  }
  for (std::size_t i = 0; i < plan.component.size(); ++i) {
    DetailOctaves& c = plan.component[i];
    c.first = 0;
    c.octaves = plan.count;
    c.amplitude = first;
    c.frequency = radius / longest;
    c.gain = 0.25;
    c.lacunarity = 4.0;
    c.seed = seed + static_cast<std::uint32_t>(i) * 0x85ebca6bU;
  }
  double sum = first;
  for (int k = 0; k < plan.count; ++k, sum *= 0.25) plan.offset += sum;
  return plan;
}

Vec3d warped(const WarpOctaves& plan, const Vec3d& p) {
  std::array<double, 3> scratch{};
  Vec3d out{};
  warped(plan, &p, 1, &out, scratch.data());
  return out;
}

void warped(const WarpOctaves& plan, const Vec3d* p, std::size_t n, Vec3d* out, double* scratch) {
  if (plan.count == 0) {
    if (out != p) std::copy(p, p + n, out);
    return;
  }
  for (std::size_t i = 0; i < 3; ++i) detail_sums(plan.component[i], p, n, scratch + i * n);
  for (std::size_t k = 0; k < n; ++k) {
    Vec3d w{};
    for (std::size_t i = 0; i < 3; ++i) w[i] = 2.0 * scratch[i * n + k] - plan.offset;
    out[k] = normalize(add(p[k], w));
  }
}

}  // namespace planet::detail
