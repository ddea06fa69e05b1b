// Deterministic noise: integer-hashed gradient and simplex noise in 2D and 3D with analytic
// derivatives, and the fractal sums built from them (fBm, ridged, hybrid multifractal, Schneider's
// rescale-and-add with per-octave domain warping). Every function returns the same bits on every
// platform and compiler (IEEE float, no FMA contraction, no libm calls in the hot path), which the
// golden-value tests pin. See docs/noise.md for the hash and the exact formulas.
#pragma once

#include <cstddef>
#include <cstdint>

#include "terrain/math.hpp"

namespace terrain::noise {

namespace detail {
/// lowbias32 on a 32-bit word, or on each lane of a vector of words (the batch kernels).
template <class U>
constexpr U lowbias32(U x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}
}  // namespace detail

/// Integer hash of one 32-bit word ("lowbias32": xorshift-multiply, full avalanche).
constexpr std::uint32_t hash(std::uint32_t x) {
  return detail::lowbias32(x);
}
/// Hash of a structured key: each word is folded in turn, so (a, b) and (b, a) differ.
constexpr std::uint32_t hash(std::uint32_t a, std::uint32_t b) {
  return hash(a ^ hash(b + 0x9e3779b9U));
}
constexpr std::uint32_t hash(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  return hash(hash(a, b), c);
}
constexpr std::uint32_t hash(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
  return hash(hash(a, b, c), d);
}

/// Value and gradient of a 2D scalar field.
struct Sample2 {
  float value = 0.0f;
  float dx = 0.0f;
  float dy = 0.0f;
};
/// Value and gradient of a 3D scalar field.
struct Sample3 {
  float value = 0.0f;
  float dx = 0.0f;
  float dy = 0.0f;
  float dz = 0.0f;
};

enum class Basis : std::uint32_t { gradient = 0, simplex = 1 };

// Single-octave noise with unit frequency. Values lie in [-1, 1]; the Lipschitz bounds below are
// proven bounds of |gradient| (checked by tests on dense samples).
Sample2 gradient2(float x, float y, std::uint32_t seed);
Sample2 simplex2(float x, float y, std::uint32_t seed);
Sample3 gradient3(float x, float y, float z, std::uint32_t seed);
Sample3 simplex3(float x, float y, float z, std::uint32_t seed);

/// Proven bound of |∇| for the single-octave basis functions at unit frequency.
float lipschitz(Basis basis, int dimensions);

enum class Fractal : std::uint32_t {
  fbm = 0,     ///< Σ a_i η(s_i p)
  ridged = 1,  ///< Musgrave's ridged multifractal, weighted by the previous octave
  hybrid = 2,  ///< Musgrave's hybrid multifractal
  warped = 3,  ///< Schneider's rescale-and-add with height-dependent domain warping
};

/// Parameters of a fractal sum. Octave i has frequency `frequency · lacunarity^i` and amplitude
/// `amplitude · lacunarity^(-i·hurst)` (Schneider eq. 1; gain = lacunarity^-H).
struct FractalParams {
  Fractal kind = Fractal::fbm;
  Basis basis = Basis::gradient;
  std::uint32_t seed = 0;
  int octaves = 8;            ///< maximum octave count (1..24)
  float frequency = 1.0f;     ///< of octave 0, cycles per metre
  float amplitude = 1.0f;     ///< of octave 0, metres
  float lacunarity = 2.0f;    ///< r > 1
  float hurst = 1.0f;         ///< H > 0
  float ridge_offset = 1.0f;  ///< ridged/hybrid offset
  float ridge_gain = 2.0f;    ///< ridged weighting gain
  // Domain warping (kind == warped): per-octave rotation angle and translation driven by the
  // height accumulated so far (see docs/noise.md for why angles replace the paper's vector update).
  float warp_c1 = 0.0f;      ///< rotation per unit roughness (radians)
  float warp_c2 = 0.0f;      ///< constant rotation per octave (radians)
  Vec2 warp_c3{0.0f, 0.0f};  ///< translation per unit of accumulated height, in lattice cells of
                             ///< the octave sampled
};

/// Schneider's LoD octave count: how many octaves are visible at sample spacing `spacing` metres
/// (Nyquist: the finest octave's wavelength is at least two samples). Fractional; clamped to
/// [0, octaves]. spacing <= 0 means full detail.
float visible_octaves(const FractalParams& p, float spacing);

/// Weight of octave i when `octaves` (fractional) are visible: 1 for i < floor, a C1 ramp for the
/// partial octave, 0 beyond. Continuous in `octaves`, so LoD changes never jump.
float octave_weight(int i, float octaves);

/// Evaluates the fractal at n points (x[k], y[k]) (metres, relative to the feature's origin) with
/// `octaves` visible octaves, writing value and gradient. Vectorised; n may be any size.
void fractal2(const FractalParams& p, const float* x, const float* y, std::size_t n, float octaves,
              float* value, float* dx, float* dy);
Sample2 fractal2(const FractalParams& p, Vec2 point, float octaves);
/// fractal2 with visible_octaves(p, spacing) octaves, bit for bit; the octave count and the
/// per-octave constants are cached per (p, spacing), so kernels that evaluate block after block at
/// one level of detail compute neither again.
void fractal2_at_spacing(const FractalParams& p, float spacing, const float* x, const float* y,
                         std::size_t n, float* value, float* dx, float* dy);

/// The same over 3D positions (for planets): value and gradient.
void fractal3(const FractalParams& p, const float* x, const float* y, const float* z, std::size_t n,
              float octaves, float* value, float* dx, float* dy, float* dz);

/// fractal3 at one point; bit-identical to the batch call.
Sample3 fractal3(const FractalParams& p, float x, float y, float z, float octaves);

/// Bounds of the fractal's value over all points, and a proven Lipschitz bound of its value over a
/// region whose points lie within `radius` metres of the origin (only `warped` depends on it).
/// fractal_range also bounds fractal3; fractal_lipschitz is for fractal2.
Interval fractal_range(const FractalParams& p, float octaves);
float fractal_lipschitz(const FractalParams& p, float octaves, float radius);
/// Bounds of fractal2 over the points within `radius` metres of `centre` (the fractal's own
/// coordinates), at every octave count in `octaves` (a tracer reuses one bound over a band of
/// levels of detail): each octave's range and slope come from its value and gradient at the
/// centre, widened by the basis' Hessian bound, so an octave whose wavelength is long beside the
/// region contributes the slope it has there rather than its worst case. Never looser than the
/// global bounds; the warped kind gets those (its slope depends on the whole path of the sum),
/// for |p| ≤ |centre| + radius.
struct RegionBounds {
  Interval value;
  float lipschitz = 0.0f;
  /// |∇F(p) − gradient_at_centre| ≤ gradient_spread everywhere in the region: the gradient
  /// itself, not just its length, where the octaves allow it (fBm over a small region); else a
  /// zero vector and the slope bound.
  Vec2 gradient_at_centre{0.0f, 0.0f};
  float gradient_spread = 0.0f;
  /// Bounds that know the slope alone.
  static RegionBounds of_slope(Interval value, float lipschitz) {
    return {value, lipschitz, {0.0f, 0.0f}, lipschitz};
  }
};
RegionBounds fractal_bounds_near(const FractalParams& p, Interval octaves, Vec2 centre,
                                 float radius);
inline RegionBounds fractal_bounds_near(const FractalParams& p, float octaves, Vec2 centre,
                                        float radius) {
  return fractal_bounds_near(p, Interval::point(octaves), centre, radius);
}

/// Proven bound of the Hessian's norm of a single-octave basis at unit frequency:
/// |∇η(a) − ∇η(b)| ≤ hessian_bound · |a − b| (2D only; infinity otherwise).
float hessian_bound(Basis basis, int dimensions);

/// Proven Lipschitz bound of fractal3 (3D basis bounds; `warped` is evaluated as fBm in 3D).
float fractal3_lipschitz(const FractalParams& p, float octaves);

}  // namespace terrain::noise
