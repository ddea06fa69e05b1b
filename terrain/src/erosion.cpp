// Stream-power erosion with uplift, diffusion, talus and depression deposits, coarse to fine
// (docs/erosion.md). Written from the equations of Braun & Willett (2013) for the implicit step,
// Barnes, Lehman & Mulla (2014) for the priority-flood, and Perron & Royden (2013) for χ.
#include "terrain/erosion.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <queue>
#include <string>

#include "flood_entry.hpp"

namespace terrain {
namespace {

constexpr double kLn2 = 0.6931471805599453;
constexpr double kSqrt2 = 1.4142135623730951;
constexpr double kPi = 3.141592653589793;
constexpr int kMinLevelSide = 64;
constexpr double kStableDiffusionStep = 0.2;
/// Diffusion sub-steps (a five-point stencil each) counted as one cell-step of the solver
/// (routing, accumulation, incision, talus): about 5 ns against 370 ns per cell in
/// bench/erosion_bench.cpp, so this over-charges them about twofold.
constexpr std::int64_t kDiffusionSubstepsPerCellStep = 32;
constexpr int kMaxLevels = 4;
/// Powers of drainage areas up to this many cells come from a table built once per grid.
constexpr std::uint32_t kPowerTableCells = 4096;

double portable_log(double x) {
  int e = 0;
  double f = std::frexp(x, &e);  // x = f·2^e, f in [0.5, 1)
  if (f < 0.7071067811865476) {
    f *= 2.0;
    --e;
  }
  // ln f = 2 atanh(s), s = (f − 1)/(f + 1), |s| ≤ 0.172: twenty odd terms are far past double.
  const double s = (f - 1.0) / (f + 1.0);
  const double s2 = s * s;
  double term = s;
  double sum = 0.0;
  for (int k = 1; k < 40; k += 2) {
    sum += term / k;
    term *= s2;
  }
  return 2.0 * sum + e * kLn2;
}

double portable_exp(double y) {
  const double k = std::nearbyint(y / kLn2);
  const double r = y - k * kLn2;  // |r| ≤ 0.35
  double term = 1.0;
  double sum = 1.0;
  for (int i = 1; i <= 22; ++i) {
    term *= r / i;
    sum += term;
  }
  return std::ldexp(sum, static_cast<int>(k));
}

/// tan of an angle in (0, π/2) from the sine and cosine series.
double portable_tan(double angle) {
  double sine = 0.0, cosine = 0.0;
  double term_s = angle, term_c = 1.0;
  const double a2 = angle * angle;
  for (int k = 0; k < 30; ++k) {
    sine += term_s;
    cosine += term_c;
    term_s *= -a2 / ((2 * k + 2) * (2 * k + 3));
    term_c *= -a2 / ((2 * k + 1) * (2 * k + 2));
  }
  return sine / cosine;
}

/// Bilinear resampling between two grids over the same extent (corner samples coincide).
std::vector<double> resample(std::span<const double> src, int sw, int sh, int dw, int dh) {
  if (sw == dw && sh == dh) return {src.begin(), src.end()};
  std::vector<double> out(static_cast<std::size_t>(dw) * static_cast<std::size_t>(dh));
  const double sx = static_cast<double>(sw - 1) / (dw - 1);
  const double sy = static_cast<double>(sh - 1) / (dh - 1);
  for (int j = 0; j < dh; ++j) {
    const double y = j * sy;
    const int j0 = std::min(static_cast<int>(y), sh - 2);
    const double fy = y - j0;
    for (int i = 0; i < dw; ++i) {
      const double x = i * sx;
      const int i0 = std::min(static_cast<int>(x), sw - 2);
      const double fx = x - i0;
      const std::size_t a = static_cast<std::size_t>(j0) * static_cast<std::size_t>(sw) +
                            static_cast<std::size_t>(i0);
      const std::size_t b = a + static_cast<std::size_t>(sw);
      const double top = (1.0 - fx) * src[a] + fx * src[a + 1];
      const double bottom = (1.0 - fx) * src[b] + fx * src[b + 1];
      out[static_cast<std::size_t>(j) * static_cast<std::size_t>(dw) +
          static_cast<std::size_t>(i)] = (1.0 - fy) * top + fy * bottom;
    }
  }
  return out;
}

/// Rho8's weight of the drop to a diagonal neighbour (Fairfield & Leymarie 1991): 1 / (2 − r),
/// r uniform in [0, 1), drawn per cell from a hash of its position and the grid's width, so the
/// same on every run. Plain D8 weighs every diagonal 1/√2, and on a planar slope every cell then
/// drains the same way: parallel channels along the eight grid directions that never meet. With
/// Rho8 the expected flow direction is the slope's true aspect, and flow paths wander and join.
double rho8_diagonal_weight(int i, int j, int width) {
  std::uint64_t h = (std::uint64_t{static_cast<std::uint32_t>(j)} << 32) |
                    std::uint64_t{static_cast<std::uint32_t>(i)};
  h ^= std::uint64_t{static_cast<std::uint32_t>(width)} * 0x9E3779B97F4A7C15ull;
  h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;  // splitmix64's finaliser
  h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
  h ^= h >> 31;
  const double r = static_cast<double>(h >> 11) * 0x1.0p-53;
  return 1.0 / (2.0 - r);
}

/// Explicit diffusion sub-steps of `coefficient` (κΔt/Δx²), each within the scheme's stability
/// limit of 0.25.
int diffusion_substeps(double coefficient) {
  return coefficient > 0.0 ? static_cast<int>(std::ceil(coefficient / kStableDiffusionStep)) : 0;
}

/// One grid of the coarse-to-fine solve: heights in metres, lengths relative to the side L.
class Solver {
 public:
  Solver(int width, int height, double cell_metres, double cell_relative)
      : w_(width),
        h_(height),
        n_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height)),
        cell_metres_(cell_metres),
        cell_relative_(cell_relative),
        receiver_(n_, -1),
        order_(n_, 0),
        count_(n_, 1),
        donor_start_(n_ + 1, 0),
        donors_(n_, 0) {}

  std::vector<double> z;
  std::vector<float> uplift;         ///< the uplift pattern u in [0, 1]
  std::vector<std::uint8_t> outlet;  ///< fixed cells: the edge and the sea

  /// Outlets: the grid's edge, and cells of `authored` at or below the sea level.
  void mark_outlets(const std::vector<double>& authored, std::optional<double> sea_level) {
    outlet.assign(n_, 0);
    for (int j = 0; j < h_; ++j) {
      for (int i = 0; i < w_; ++i) {
        const std::size_t c = at(i, j);
        const bool edge = i == 0 || j == 0 || i == w_ - 1 || j == h_ - 1;
        outlet[c] = edge || (sea_level && authored[c] <= *sea_level);
      }
    }
  }

  /// Steepest-descent receivers, Rho8's weights on the diagonals; false when some cell (not an
  /// outlet) has no lower neighbour.
  bool route() {
    bool drains = true;
    for (int j = 0; j < h_; ++j) {
      for (int i = 0; i < w_; ++i) {
        const std::size_t c = at(i, j);
        receiver_[c] = -1;
        if (outlet[c] != 0) continue;
        double steepest = 0.0;
        const double diagonal_weight = rho8_diagonal_weight(i, j, w_);
        for (int k = 0; k < 8; ++k) {
          const std::size_t nc = at(i + kD8Dx[k], j + kD8Dy[k]);  // interior: never off-grid
          const double drop = z[c] - z[nc];
          if (!(drop > 0.0)) continue;
          const double slope = (kD8Dx[k] != 0 && kD8Dy[k] != 0) ? drop * diagonal_weight : drop;
          if (receiver_[c] < 0 || slope > steepest) {
            steepest = slope;
            receiver_[c] = static_cast<std::int32_t>(nc);
          }
        }
        drains = drains && receiver_[c] >= 0;
      }
    }
    return drains;
  }

  /// Priority-flood + ε from the outlets: every other cell ends at least `epsilon` above the
  /// cell the flood reached it from, so every cell drains. Raised cells are the deposits that
  /// fill closed depressions to their spill level. Pit cells go through a FIFO, merged with the
  /// heap by value (both streams are non-decreasing), which spares most heap operations.
  void fill(double epsilon) {
    std::vector<std::uint8_t> closed(n_, 0);
    std::priority_queue<FloodEntry, std::vector<FloodEntry>, std::greater<>> open;
    std::vector<std::int32_t> pit;
    std::size_t pit_head = 0;
    std::uint64_t sequence = 0;
    for (std::size_t c = 0; c < n_; ++c) {
      if (outlet[c] == 0) continue;
      closed[c] = 1;
      open.push({z[c], sequence++, static_cast<std::int32_t>(c)});
    }
    while (!open.empty() || pit_head < pit.size()) {
      std::int32_t c = 0;
      if (pit_head < pit.size() &&
          (open.empty() || z[static_cast<std::size_t>(pit[pit_head])] <= open.top().value)) {
        c = pit[pit_head++];
      } else {
        c = open.top().cell;
        open.pop();
      }
      const int ci = c % w_;
      const int cj = c / w_;
      const double raised = z[static_cast<std::size_t>(c)] + epsilon;
      for (int k = 0; k < 8; ++k) {
        const int ni = ci + kD8Dx[k];
        const int nj = cj + kD8Dy[k];
        if (ni < 0 || nj < 0 || ni >= w_ || nj >= h_) continue;
        const std::size_t nc = at(ni, nj);
        if (closed[nc] != 0) continue;
        closed[nc] = 1;
        if (z[nc] <= raised) {
          z[nc] = raised;
          pit.push_back(static_cast<std::int32_t>(nc));
        } else {
          open.push({z[nc], sequence++, static_cast<std::int32_t>(nc)});
        }
      }
    }
  }

  /// Routes, filling first where some cell does not drain.
  void route_filled(double epsilon) {
    if (route()) return;
    fill(epsilon);
    [[maybe_unused]] const bool drains = route();
    assert(drains && "a filled surface drains");
  }

  /// Receivers before donors (breadth first from the outlets, donors in index order), then the
  /// drainage area of every cell in cells.
  void accumulate() {
    std::fill(donor_start_.begin(), donor_start_.end(), 0);
    for (std::size_t c = 0; c < n_; ++c) {
      if (receiver_[c] >= 0) ++donor_start_[static_cast<std::size_t>(receiver_[c]) + 1];
    }
    for (std::size_t c = 0; c < n_; ++c) donor_start_[c + 1] += donor_start_[c];
    std::vector<std::int32_t> next(donor_start_.begin(), donor_start_.end() - 1);
    for (std::size_t c = 0; c < n_; ++c) {
      if (receiver_[c] >= 0) {
        donors_[static_cast<std::size_t>(next[static_cast<std::size_t>(receiver_[c])]++)] =
            static_cast<std::int32_t>(c);
      }
    }
    std::size_t tail = 0;
    for (std::size_t c = 0; c < n_; ++c) {
      if (outlet[c] != 0) order_[tail++] = static_cast<std::int32_t>(c);
    }
    for (std::size_t head = 0; head < tail; ++head) {
      const auto c = static_cast<std::size_t>(order_[head]);
      for (std::int32_t d = donor_start_[c]; d < donor_start_[c + 1]; ++d) {
        order_[tail++] = donors_[static_cast<std::size_t>(d)];
      }
    }
    assert(tail == n_ && "every cell drains to an outlet");
    std::fill(count_.begin(), count_.end(), 1u);
    for (std::size_t k = n_; k-- > 0;) {
      const auto c = static_cast<std::size_t>(order_[k]);
      if (receiver_[c] >= 0) count_[static_cast<std::size_t>(receiver_[c])] += count_[c];
    }
  }

  /// a^m for every drainage area of `cells` cells, a relative to L².
  void prepare_powers(double concavity) {
    concavity_ = concavity;
    cell_area_power_ = portable_pow(cell_relative_ * cell_relative_, concavity);
    powers_.resize(kPowerTableCells + 1);
    powers_[0] = 0.0;
    for (std::uint32_t k = 1; k <= kPowerTableCells; ++k) {
      powers_[k] = portable_pow(static_cast<double>(k), concavity) * cell_area_power_;
    }
  }

  double area_power(std::uint32_t cells) const {
    if (cells <= kPowerTableCells) return powers_[cells];
    return portable_pow(static_cast<double>(cells), concavity_) * cell_area_power_;
  }

  double distance(std::size_t from, std::size_t to) const {
    const bool diagonal =
        (from % static_cast<std::size_t>(w_)) != (to % static_cast<std::size_t>(w_)) &&
        (from / static_cast<std::size_t>(w_)) != (to / static_cast<std::size_t>(w_));
    return diagonal ? cell_relative_ * kSqrt2 : cell_relative_;
  }

  /// max over cells of χ_u = Σ u δ / a^m along the path to the outlet: the steady state's relief
  /// per unit of λ (h = λ χ_u when U = K λ u).
  double max_chi() const {
    std::vector<double> chi(n_, 0.0);
    double top = 0.0;
    for (std::size_t k = 0; k < n_; ++k) {
      const auto c = static_cast<std::size_t>(order_[k]);
      if (receiver_[c] < 0) continue;
      const auto r = static_cast<std::size_t>(receiver_[c]);
      chi[c] = chi[r] + uplift[c] * distance(c, r) / area_power(count_[c]);
      top = std::max(top, chi[c]);
    }
    return top;
  }

  /// One implicit stream-power step (n = 1), receivers first: h_i ← (h_i + K λ u_i + F h_r) /
  /// (1 + F), F = K a_i^m / δ_i; each cell kept at least ε above its receiver.
  void incise(double strength, double lambda, double epsilon) {
    for (std::size_t k = 0; k < n_; ++k) {
      const auto c = static_cast<std::size_t>(order_[k]);
      if (receiver_[c] < 0) continue;
      const auto r = static_cast<std::size_t>(receiver_[c]);
      const double f = strength * area_power(count_[c]) / distance(c, r);
      const double next = (z[c] + strength * lambda * uplift[c] + f * z[r]) / (1.0 + f);
      z[c] = std::max(next, z[r] + epsilon);
    }
  }

  /// Explicit linear diffusion over the four neighbours (Jacobi), outlets fixed, in as many
  /// sub-steps as keep it stable. Two buffers swapped per sub-step: the cells no sub-step writes
  /// (edge, outlets) are the same in both.
  void diffuse(double coefficient) {
    const int substeps = diffusion_substeps(coefficient);
    if (substeps == 0) return;
    const double each = coefficient / substeps;
    std::vector<double> next = z;
    for (int s = 0; s < substeps; ++s) {
      for (int j = 1; j + 1 < h_; ++j) {
        for (int i = 1; i + 1 < w_; ++i) {
          const std::size_t c = at(i, j);
          if (outlet[c] != 0) continue;
          const double laplacian =
              z[at(i - 1, j)] + z[at(i + 1, j)] + z[at(i, j - 1)] + z[at(i, j + 1)] - 4.0 * z[c];
          next[c] = z[c] + each * laplacian;
        }
      }
      z.swap(next);
    }
  }

  /// Lowers every cell (raster order) to at most `slope` above its lowest neighbour-plus-run:
  /// cells only go down, and stay above their lowest neighbour, so no pit appears.
  void talus(double slope) {
    const double straight = slope * cell_metres_;
    const double diagonal = straight * kSqrt2;
    for (int j = 1; j + 1 < h_; ++j) {
      for (int i = 1; i + 1 < w_; ++i) {
        const std::size_t c = at(i, j);
        if (outlet[c] != 0) continue;
        double cap = z[c];
        for (int k = 0; k < 8; ++k) {
          const double run = (kD8Dx[k] != 0 && kD8Dy[k] != 0) ? diagonal : straight;
          cap = std::min(cap, z[at(i + kD8Dx[k], j + kD8Dy[k])] + run);
        }
        z[c] = cap;
      }
    }
  }

  const std::vector<std::int32_t>& receivers() const { return receiver_; }
  const std::vector<std::int32_t>& order() const { return order_; }

 private:
  std::size_t at(int i, int j) const {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(i);
  }

  int w_, h_;
  std::size_t n_;
  double cell_metres_, cell_relative_;
  double concavity_ = 0.5, cell_area_power_ = 1.0;
  std::vector<std::int32_t> receiver_;
  std::vector<std::int32_t> order_;
  std::vector<std::uint32_t> count_;
  std::vector<std::int32_t> donor_start_;
  std::vector<std::int32_t> donors_;
  std::vector<double> powers_;
};

Status check_range(double value, double lo, double hi, const char* pointer, const char* what) {
  if (std::isfinite(value) && value >= lo && value <= hi) return Ok{};
  return Error{
      "must be " + std::string(what) + " from " + std::to_string(lo) + " to " + std::to_string(hi),
      pointer};
}

}  // namespace

double portable_pow(double x, double y) {
  return portable_exp(y * portable_log(x));
}

std::vector<ErosionLevel> erosion_levels(int width, int height, int iterations) {
  std::vector<ErosionLevel> levels{{width, height, 0}};
  while (static_cast<int>(levels.size()) < kMaxLevels) {
    const ErosionLevel& last = levels.back();
    const int w = (last.width + 1) / 2, h = (last.height + 1) / 2;
    if (w < kMinLevelSide || h < kMinLevelSide) break;
    levels.push_back({w, h, 0});
  }
  // The coarsest grid runs every iteration; each finer one a quarter of the one before, at least
  // two: the network forms where it is cheap, and fine grids only sharpen it.
  int steps = std::max(iterations, 1);
  for (auto it = levels.rbegin(); it != levels.rend(); ++it) {
    it->steps = steps;
    steps = std::max(2, steps / 4);
  }
  return levels;
}

namespace {
double level_diffusion(double diffusion, int width, int height, const ErosionLevel& level) {
  // κ stays the same in metres: a grid `scale` times coarser diffuses 1/scale² as much per step.
  const double scale = static_cast<double>(std::max(width, height) - 1) /
                       static_cast<double>(std::max(level.width, level.height) - 1);
  return diffusion / (scale * scale);
}
}  // namespace

std::int64_t erosion_work(int width, int height, int iterations, double diffusion) {
  std::int64_t work = 0;
  for (const ErosionLevel& level : erosion_levels(width, height, iterations)) {
    const std::int64_t cell_steps = std::int64_t{level.width} * level.height * level.steps;
    const int substeps = diffusion_substeps(level_diffusion(diffusion, width, height, level));
    work += cell_steps + (cell_steps * substeps + kDiffusionSubstepsPerCellStep - 1) /
                             kDiffusionSubstepsPerCellStep;
  }
  return work;
}

Status validate_erosion(const ElevationGrid& grid, const ErosionParams& p) {
  if (grid.width < kMinErosionSide || grid.width > kMaxErosionSide) {
    return Error{"must be from " + std::to_string(kMinErosionSide) + " to " +
                     std::to_string(kMaxErosionSide) + " cells",
                 "/width"};
  }
  if (grid.height < kMinErosionSide || grid.height > kMaxErosionSide) {
    return Error{"must be from " + std::to_string(kMinErosionSide) + " to " +
                     std::to_string(kMaxErosionSide) + " cells",
                 "/height"};
  }
  if (!std::isfinite(grid.cell_size) || !(grid.cell_size > 0.0)) {
    return Error{"must be a finite number of metres greater than 0", "/cell_size"};
  }
  const auto cells = static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height);
  if (grid.elevation.size() != cells) {
    return Error{"must hold width × height = " + std::to_string(cells) + " values", "/elevation"};
  }
  for (float v : grid.elevation) {
    if (!std::isfinite(v)) return Error{"must be finite everywhere", "/elevation"};
  }
  if (p.iterations < 1 || p.iterations > kMaxErosionIterations) {
    return Error{"must be from 1 to " + std::to_string(kMaxErosionIterations), "/iterations"};
  }
  for (const Status& s :
       {check_range(p.strength, 0.0, kMaxErosionStrength, "/strength", "a number"),
        check_range(p.concavity, kMinConcavity, kMaxConcavity, "/concavity", "a number"),
        check_range(p.uplift, 0.0, 1.0, "/uplift", "a number"),
        check_range(p.diffusion, 0.0, kMaxDiffusion, "/diffusion", "a number"),
        check_range(p.talus_angle, kMinTalusAngle, kMaxTalusAngle, "/talus_angle",
                    "an angle in degrees")}) {
    if (!s) return s;
  }
  if (p.sea_level && !std::isfinite(*p.sea_level)) {
    return Error{"must be a finite elevation", "/sea_level"};
  }
  return Ok{};
}

Result<std::vector<float>> erode(const ElevationGrid& grid, const ErosionParams& p) {
  if (Status valid = validate_erosion(grid, p); !valid) return valid.error();
  const int width = grid.width, height = grid.height;
  const std::vector<double> input(grid.elevation.begin(), grid.elevation.end());

  // Base and relief: the sea level (or the lowest cell) to the highest cell.
  double top = input.front(), base = input.front();
  for (double v : input) {
    top = std::max(top, v);
    base = std::min(base, v);
  }
  if (p.sea_level) base = *p.sea_level;
  const double relief = std::max(top - base, 0.0);
  // ε: a drop every cell keeps to its receiver, four float32 ulps of the largest magnitude at
  // least, so the result drains in float32 too.
  const double magnitude = std::max({std::fabs(top), std::fabs(base), 1.0});
  const double epsilon =
      std::max(1e-3, 4.0 * (std::nextafter(static_cast<float>(magnitude), INFINITY) -
                            static_cast<float>(magnitude)));
  const double talus_slope = portable_tan(p.talus_angle * kPi / 180.0);
  const double side = grid.cell_size * (std::max(width, height) - 1);

  const std::vector<ErosionLevel> levels = erosion_levels(width, height, p.iterations);
  std::vector<double> z;
  std::vector<double> coarser_authored;  // the input as the coarser grid held it
  int zw = 0, zh = 0;
  double lambda = 0.0;
  for (std::size_t li = levels.size(); li-- > 0;) {
    const ErosionLevel& level = levels[li];
    const double cell_metres =
        grid.cell_size * (std::max(width, height) - 1) / (std::max(level.width, level.height) - 1);
    Solver solver(level.width, level.height, cell_metres, cell_metres / side);
    const std::vector<double> authored = resample(input, width, height, level.width, level.height);
    const std::size_t n = authored.size();
    solver.mark_outlets(authored, p.sea_level);
    solver.uplift.assign(n, 0.0f);
    for (std::size_t c = 0; c < n; ++c) {
      const double share = relief > 0.0 ? std::clamp((authored[c] - base) / relief, 0.0, 1.0) : 0.0;
      solver.uplift[c] = static_cast<float>((1.0 - p.uplift) + p.uplift * share);
    }
    if (z.empty()) {
      solver.z = authored;
    } else {
      // The coarser result, plus the input's detail that the coarser grid could not hold: what
      // the coarse steps carved stays carved, and what they never saw is there to shape.
      solver.z = resample(z, zw, zh, level.width, level.height);
      const std::vector<double> coarse_input =
          resample(coarser_authored, zw, zh, level.width, level.height);
      for (std::size_t c = 0; c < n; ++c) solver.z[c] += authored[c] - coarse_input[c];
    }
    // Outlets keep the authored heights at every level.
    for (std::size_t c = 0; c < n; ++c) {
      if (solver.outlet[c] != 0) solver.z[c] = authored[c];
    }
    solver.prepare_powers(p.concavity);
    const double diffusion = level_diffusion(p.diffusion, width, height, level);
    for (int step = 0; step < level.steps; ++step) {
      solver.diffuse(diffusion);
      solver.route_filled(epsilon);
      solver.accumulate();
      if (z.empty() && step == 0) {
        // U = K λ u with λ from the first network: the steady state spans the relief.
        const double chi = solver.max_chi();
        lambda = chi > 0.0 ? relief / chi : 0.0;
      }
      solver.incise(p.strength, lambda, epsilon);
      solver.talus(talus_slope);
    }
    z = std::move(solver.z);
    coarser_authored = authored;
    zw = level.width;
    zh = level.height;
  }

  // The authored relief exactly, then the talus slope again, then drainage in float32.
  Solver last(width, height, grid.cell_size, grid.cell_size / side);
  last.mark_outlets(input, p.sea_level);
  double high = base;
  for (std::size_t c = 0; c < input.size(); ++c) {
    if (last.outlet[c] == 0) high = std::max(high, z[c]);
  }
  last.z = std::move(z);
  if (high > base) {
    // Stretched about the outlet each cell drains to, so every path keeps descending: stretching
    // about one base would lower cells next to a high edge below it, and filling would flatten
    // them.
    last.route_filled(epsilon);
    last.accumulate();
    std::vector<double> outlet_height(last.z.size(), 0.0);
    for (const std::int32_t cell : last.order()) {
      const auto c = static_cast<std::size_t>(cell);
      const std::int32_t r = last.receivers()[c];
      outlet_height[c] = r < 0 ? last.z[c] : outlet_height[static_cast<std::size_t>(r)];
    }
    // The largest stretch that keeps every cell at or below the authored top: the cell that
    // sets it lands on the top. (Not always the highest cell: one draining to a lower outlet
    // stands further above it.)
    double stretch = INFINITY;
    for (std::size_t c = 0; c < last.z.size(); ++c) {
      const double above = last.z[c] - outlet_height[c];
      if (last.outlet[c] == 0 && above > 0.0) {
        stretch = std::min(stretch, (top - outlet_height[c]) / above);
      }
    }
    if (!std::isfinite(stretch)) stretch = 1.0;
    for (std::size_t c = 0; c < last.z.size(); ++c) {
      if (last.outlet[c] == 0) {
        last.z[c] = outlet_height[c] + (last.z[c] - outlet_height[c]) * stretch;
      }
    }
  }

  last.talus(talus_slope);
  last.route_filled(epsilon);
  last.accumulate();
  std::vector<float> out(last.z.size());
  for (const std::int32_t cell : last.order()) {
    const auto c = static_cast<std::size_t>(cell);
    out[c] = static_cast<float>(last.z[c]);
    const std::int32_t r = last.receivers()[c];
    if (r >= 0 && !(out[c] > out[static_cast<std::size_t>(r)])) {
      out[c] = std::nextafter(out[static_cast<std::size_t>(r)], INFINITY);
    }
  }
  return out;
}

}  // namespace terrain
