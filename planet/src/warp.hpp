// Domain warping (Schneider et al. 2006; planet.md "Winding valleys"): a point is evaluated
// where a smooth vector noise field moves it. The mesh's drains and valleys are straight chords
// along a handful of directions; seen through the warp they wind, at every scale from the
// longest octave down to a few edges of the level sampled. A pure function of the direction and
// the level, so a lone sample and a tile's grid move every point alike.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "detail_batch.hpp"
#include "planet/mesh.hpp"

namespace planet::detail {

/// Octaves no warp sums (warp_octaves says why).
inline constexpr int kMaxWarpOctaves = 6;

/// One level's warp: each of the three components a sum of `count` octaves of the planet's
/// gradient noise (the fractal detail's sums, so that many directions go four at a time),
/// octave k a quarter as long and as high as octave k − 1; component i is
/// 2·sum_i − `offset`, centred on 0.
struct WarpOctaves {
  int count = 0;
  std::array<DetailOctaves, 3> component{};
  double offset = 0.0;  ///< Σ_k amplitude_k
};

/// The octaves for edges `edge` metres long: wavelengths `longest`, a quarter of that, … while
/// at least four edges (none past kMaxWarpOctaves). Each moves a point by up to `share` of its
/// wavelength in each component, the first at most 0.05 of the radius (so that p + w stays far
/// from the sphere's centre).
WarpOctaves warp_octaves(double share, double longest, double edge, double radius,
                         std::uint32_t seed);

/// The unit direction p is evaluated at: p + (w₀, w₁, w₂), normalised.
Vec3d warped(const WarpOctaves& plan, const Vec3d& p);

/// warped() of each of `n` directions into `out` (which may be `p`): the same bits, the noise
/// several directions at a time where the CPU has vectors for it. `scratch` holds 3n values.
void warped(const WarpOctaves& plan, const Vec3d* p, std::size_t n, Vec3d* out, double* scratch);

}  // namespace planet::detail
