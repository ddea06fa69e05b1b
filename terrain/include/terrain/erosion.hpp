// Fluvial erosion of a height grid under the stream-power law with uplift (docs/erosion.md):
// Braun & Willett's (2013) implicit O(n) step for n = 1, hillslope diffusion, a talus slope, and
// depressions filled as deposits (priority-flood + ε), solved coarse to fine. A pure function of
// its inputs: fixed traversal orders, integer tie-breaks, and powers from +, −, ×, ÷ only, so the
// result has the same bits on every machine, thread count and vector path.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "terrain/drainage.hpp"
#include "terrain/result.hpp"

namespace terrain {

/// What shapes the grid. The stream-power law dh/dt = U − K A^m S is written in lengths relative
/// to the grid's side L (A/L², S, distances/L), so K does not depend on the grid's size or
/// resolution; the uplift U is scaled so that the steady state spans the input's relief, and the
/// result is rescaled to it exactly: the input's mountains stay where, and as high as, authored.
struct ErosionParams {
  int iterations = 24;        ///< implicit steps on the coarsest grid (finer grids run fewer)
  double strength = 2.0;      ///< K: stream-power erodibility per step, relative units
  double concavity = 0.45;    ///< m/n with n = 1: Flint's law θ at steady state
  double uplift = 0.6;        ///< 0: uniform uplift; 1: proportional to the input's height
  double diffusion = 0.05;    ///< hillslope diffusion per step, κΔt/Δx² on the finest grid
  double talus_angle = 60.0;  ///< degrees: no slope steeper is kept
  std::optional<double> sea_level = {};  ///< cells at or below are sea: fixed outlets
};

/// Accepted ranges (inclusive), checked by validate_erosion and by the erosion node's parser.
inline constexpr int kMinErosionSide = 16;
inline constexpr int kMaxErosionSide = 2048;
inline constexpr int kMaxErosionIterations = 400;
inline constexpr double kMaxErosionStrength = 1000.0;
inline constexpr double kMinConcavity = 0.1, kMaxConcavity = 1.0;
inline constexpr double kMaxDiffusion = 16.0;  ///< run in explicit sub-steps of at most 0.2
inline constexpr double kMinTalusAngle = 1.0, kMaxTalusAngle = 89.0;

/// The grids one solve walks, finest first: each coarser one halves the side (rounding up) while
/// it stays at least 64 cells, four at most, all covering the same extent.
struct ErosionLevel {
  int width = 0;
  int height = 0;
  int steps = 0;  ///< implicit steps run on this grid
};
std::vector<ErosionLevel> erosion_levels(int width, int height, int iterations);

/// Cell-steps the solve runs (Σ width·height·steps over its levels, 32 diffusion sub-steps
/// counted as one): what limits compare.
std::int64_t erosion_work(int width, int height, int iterations, double diffusion);

/// Refuses parameters outside their ranges and grids outside kMinErosionSide..kMaxErosionSide,
/// naming the field (/iterations, /strength, /concavity, /uplift, /diffusion, /talus_angle,
/// /sea_level, /width, /height, /cell_size, /elevation).
Status validate_erosion(const ElevationGrid& grid, const ErosionParams& params);

/// The eroded grid, row-major like the input (width × height floats). Every cell that is not an
/// outlet (the grid's edge, sea) drains: it lies strictly above its steepest-descent neighbour, in
/// float32, so the result has no pits. `grid.water` is ignored.
Result<std::vector<float>> erode(const ElevationGrid& grid, const ErosionParams& params);

/// The same for a grid the caller hands over (`heights`: width × height, row-major): the solve
/// works in its storage, so a 2048² solve holds fifteen bytes a cell in all, its input and
/// output included, where the copying form holds four more. Errors name /width, /height,
/// /cell_size, /elevation as above.
Result<std::vector<float>> erode(std::vector<float>&& heights, int width, int height,
                                 double cell_size, const ErosionParams& params);

/// x^y for x > 0 from + − × ÷ only (a log and an exp series in double), about 1e-15 relative:
/// libm's pow may differ between its CPU-specific variants by an ulp.
double portable_pow(double x, double y);

}  // namespace terrain
