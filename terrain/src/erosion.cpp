// Stream-power erosion with uplift, diffusion, talus and depression deposits, coarse to fine
// (docs/erosion.md). Written from the equations of Braun & Willett (2013) for the implicit step,
// Barnes, Lehman & Mulla (2014) for the priority-flood, and Perron & Royden (2013) for χ.
#include "terrain/erosion.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <deque>
#include <queue>
#include <string>

#include "free_storage.hpp"

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

/// The bilinear sample at (x, y) of a grid (cell units, within it).
double bilinear(std::span<const float> src, int sw, int sh, double x, double y) {
  const int i0 = std::min(static_cast<int>(x), sw - 2);
  const int j0 = std::min(static_cast<int>(y), sh - 2);
  const double fx = x - i0, fy = y - j0;
  const std::size_t a =
      static_cast<std::size_t>(j0) * static_cast<std::size_t>(sw) + static_cast<std::size_t>(i0);
  const std::size_t b = a + static_cast<std::size_t>(sw);
  const double top = (1.0 - fx) * src[a] + fx * src[a + 1];
  const double bottom = (1.0 - fx) * src[b] + fx * src[b + 1];
  return (1.0 - fy) * top + fy * bottom;
}

/// Maps cell (i, j) of a dw × dh grid onto an sw × sh grid over the same extent (corner samples
/// coincide) and samples it there.
class Resampler {
 public:
  Resampler(std::span<const float> src, int sw, int sh, int dw, int dh)
      : src_(src),
        sw_(sw),
        sh_(sh),
        sx_(static_cast<double>(sw - 1) / (dw - 1)),
        sy_(static_cast<double>(sh - 1) / (dh - 1)) {}
  double operator()(int i, int j) const { return bilinear(src_, sw_, sh_, i * sx_, j * sy_); }

 private:
  std::span<const float> src_;
  int sw_, sh_;
  double sx_, sy_;
};

std::vector<float> resample(std::span<const float> src, int sw, int sh, int dw, int dh) {
  const Resampler at(src, sw, sh, dw, dh);
  std::vector<float> out(static_cast<std::size_t>(dw) * static_cast<std::size_t>(dh));
  for (int j = 0; j < dh; ++j) {
    for (int i = 0; i < dw; ++i) {
      out[static_cast<std::size_t>(j) * static_cast<std::size_t>(dw) +
          static_cast<std::size_t>(i)] = static_cast<float>(at(i, j));
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

/// The uplift pattern u in [0, 1] of an authored height: uniform, or rising with the height.
struct UpliftPattern {
  double uniform = 1.0;    ///< 1 − the uplift parameter
  double with_height = 0;  ///< the uplift parameter
  double base = 0, relief = 0;
  double operator()(float authored) const {
    const double share = relief > 0.0 ? std::clamp((authored - base) / relief, 0.0, 1.0) : 0.0;
    return uniform + with_height * share;
  }
  /// u in 1/65535 steps: two bytes a cell instead of the authored height's four, so the finest
  /// level can overwrite its input. (One byte, steps of 1/255, changed the example scenes'
  /// networks enough to move river-lake's Flint fit from r² 0.54 to 0.49; two bytes leave every
  /// scene's figures as they were.)
  static std::uint16_t encode(double u) {
    return static_cast<std::uint16_t>(std::nearbyint(std::clamp(u, 0.0, 1.0) * 65535.0));
  }
  static double decode(std::uint16_t code) { return code / 65535.0; }
};

/// A priority-flood queue entry: the lowest height first, then the lowest cell index, a total
/// order, so no result depends on the heap's implementation. Eight bytes: the queue of a 2048²
/// flood can hold a large share of the grid.
struct FloodCell {
  float value = 0.0f;
  std::int32_t cell = 0;
  bool operator>(const FloodCell& other) const {
    if (value != other.value) return value > other.value;
    return cell > other.cell;
  }
};

/// One grid of the coarse-to-fine solve: heights in metres (float), lengths relative to the
/// side L. Fifteen bytes per cell at most (heights, the stack order, drainage areas, a 16-bit
/// uplift and a byte of flow direction and flags), so a 2048² solve fits in 64 MiB with its
/// input (the finest level works in the input's storage): the arithmetic is in
/// double, the stored heights in float, and each cell keeps a drop of ε ≥ four float ulps to its
/// receiver.
class Solver {
 public:
  /// The grid over `authored` (this level's input heights): outlets are its edge and, with a
  /// sea level, the cells at or below it.
  Solver(std::span<const float> authored, const UpliftPattern& uplift, int width, int height,
         double cell_metres, double cell_relative, std::optional<double> sea_level)
      : w_(width),
        h_(height),
        n_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height)),
        cell_metres_(cell_metres),
        cell_relative_(cell_relative),
        cell_(n_, kNoReceiver),
        uplift_(n_) {
    for (std::size_t c = 0; c < n_; ++c) uplift_[c] = UpliftPattern::encode(uplift(authored[c]));
    for (int k = 0; k < 8; ++k) {
      offset_[k] = static_cast<std::ptrdiff_t>(kD8Dy[k]) * width + kD8Dx[k];
      const bool diagonal = kD8Dx[k] != 0 && kD8Dy[k] != 0;
      distance_[k] = diagonal ? cell_relative * kSqrt2 : cell_relative;
    }
    for (int j = 0; j < h_; ++j) {
      for (int i = 0; i < w_; ++i) {
        const std::size_t c = at(i, j);
        const bool edge = i == 0 || j == 0 || i == w_ - 1 || j == h_ - 1;
        if (edge || (sea_level && authored[c] <= *sea_level)) cell_[c] = kOutlet;
      }
    }
  }

  std::vector<float> z;

  bool is_outlet(std::size_t c) const { return (cell_[c] & kDirectionMask) == kOutlet; }

  /// Steepest-descent receivers, Rho8's weights on the diagonals; false when some cell (not an
  /// outlet) has no lower neighbour.
  bool route() {
    bool drains = true;
    for (int j = 0; j < h_; ++j) {
      for (int i = 0; i < w_; ++i) {
        const std::size_t c = at(i, j);
        if (is_outlet(c)) continue;
        std::uint8_t receiver = kNoReceiver;
        double steepest = 0.0;
        const double diagonal_weight = rho8_diagonal_weight(i, j, w_);
        for (int k = 0; k < 8; ++k) {
          const double drop = static_cast<double>(z[c]) - z[neighbour(c, k)];  // interior cell
          if (!(drop > 0.0)) continue;
          const double slope = (kD8Dx[k] != 0 && kD8Dy[k] != 0) ? drop * diagonal_weight : drop;
          if (receiver == kNoReceiver || slope > steepest) {
            steepest = slope;
            receiver = static_cast<std::uint8_t>(k);
          }
        }
        cell_[c] = receiver;
        drains = drains && receiver != kNoReceiver;
      }
    }
    return drains;
  }

  /// Priority-flood + ε from the outlets: every other cell ends at least `epsilon` above the
  /// cell the flood reached it from, so every cell drains. Raised cells are the deposits that
  /// fill closed depressions to their spill level. Pit cells go through a FIFO, merged with the
  /// heap by value (both streams are non-decreasing), which spares most heap operations.
  void fill(double epsilon) {
    clear_scratch();
    std::priority_queue<FloodCell, std::vector<FloodCell>, std::greater<>> open;
    std::deque<std::int32_t> pit;  // a deque: it frees what it has passed
    for (std::size_t c = 0; c < n_; ++c) {
      if (!is_outlet(c)) continue;
      cell_[c] |= kClosed;
      open.push({z[c], static_cast<std::int32_t>(c)});
    }
    while (!open.empty() || !pit.empty()) {
      std::int32_t c = 0;
      if (!pit.empty() &&
          (open.empty() || z[static_cast<std::size_t>(pit.front())] <= open.top().value)) {
        c = pit.front();
        pit.pop_front();
      } else {
        c = open.top().cell;
        open.pop();
      }
      const int ci = c % w_;
      const int cj = c / w_;
      const auto raised = static_cast<float>(z[static_cast<std::size_t>(c)] + epsilon);
      for (int k = 0; k < 8; ++k) {
        const int ni = ci + kD8Dx[k];
        const int nj = cj + kD8Dy[k];
        if (ni < 0 || nj < 0 || ni >= w_ || nj >= h_) continue;
        const std::size_t nc = at(ni, nj);
        if ((cell_[nc] & kClosed) != 0) continue;
        cell_[nc] |= kClosed;
        if (z[nc] <= raised) {
          z[nc] = raised;
          pit.push_back(static_cast<std::int32_t>(nc));
        } else {
          open.push({z[nc], static_cast<std::int32_t>(nc)});
        }
      }
    }
  }

  /// Routes, filling first where some cell does not drain, then orders the cells.
  void route_filled(double epsilon) {
    if (!route()) {
      fill(epsilon);
      [[maybe_unused]] const bool drains = route();
      assert(drains && "a filled surface drains");
    }
    order_cells();
  }

  /// The drainage area of every cell, in cells (route_filled first).
  void accumulate() {
    area_.assign(n_, 1u);
    for (const std::int32_t cell : order_) {
      const auto c = static_cast<std::size_t>(cell);
      if (const int k = direction(c); k < 8) area_[neighbour(c, k)] += area_[c];
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

  /// max over cells of χ_u = Σ u δ / a^m along the path to the outlet: the steady state's relief
  /// per unit of λ (h = λ χ_u when U = K λ u).
  double max_chi() const {
    std::vector<double> chi(n_, 0.0);
    double top = 0.0;
    for (std::size_t k = n_; k-- > 0;) {
      const auto c = static_cast<std::size_t>(order_[k]);
      const int d = direction(c);
      if (d >= 8) continue;
      chi[c] = chi[neighbour(c, d)] +
               UpliftPattern::decode(uplift_[c]) * distance_[d] / area_power(area_[c]);
      top = std::max(top, chi[c]);
    }
    return top;
  }

  /// One implicit stream-power step (n = 1), receivers first: h_i ← (h_i + K λ u_i + F h_r) /
  /// (1 + F), F = K a_i^m / δ_i; each cell kept at least ε above its receiver.
  void incise(double strength, double lambda, double epsilon) {
    for (std::size_t k = n_; k-- > 0;) {
      const auto c = static_cast<std::size_t>(order_[k]);
      const int d = direction(c);
      if (d >= 8) continue;
      const double receiver = z[neighbour(c, d)];
      const double f = strength * area_power(area_[c]) / distance_[d];
      const double next =
          (z[c] + strength * lambda * UpliftPattern::decode(uplift_[c]) + f * receiver) / (1.0 + f);
      z[c] = static_cast<float>(std::max(next, receiver + epsilon));
    }
  }

  /// Explicit linear diffusion over the four neighbours (Jacobi), outlets fixed, in as many
  /// sub-steps as keep it stable. In place: each row's old values are kept for the next row, and
  /// the row below is still old when a row is written.
  void diffuse(double coefficient) {
    const int substeps = diffusion_substeps(coefficient);
    if (substeps == 0) return;
    const double each = coefficient / substeps;
    const auto row = static_cast<std::size_t>(w_);
    std::vector<float> above(row), current(row);
    for (int s = 0; s < substeps; ++s) {
      std::copy_n(z.begin(), row, above.begin());
      for (int j = 1; j + 1 < h_; ++j) {
        const std::size_t start = at(0, j);
        std::copy_n(z.begin() + static_cast<std::ptrdiff_t>(start), row, current.begin());
        for (int i = 1; i + 1 < w_; ++i) {
          const std::size_t c = start + static_cast<std::size_t>(i);
          if (is_outlet(c)) continue;
          const auto x = static_cast<std::size_t>(i);
          const double laplacian = static_cast<double>(current[x - 1]) + current[x + 1] + above[x] +
                                   z[c + row] - 4.0 * current[x];
          z[c] = static_cast<float>(current[x] + each * laplacian);
        }
        above.swap(current);
      }
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
        if (is_outlet(c)) continue;
        double cap = z[c];
        for (int k = 0; k < 8; ++k) {
          const double run = (kD8Dx[k] != 0 && kD8Dy[k] != 0) ? diagonal : straight;
          cap = std::min(cap, z[neighbour(c, k)] + run);
        }
        z[c] = static_cast<float>(cap);
      }
    }
  }

  /// Frees the drainage areas (the last stage does not need them, and needs the room).
  void release_areas() { free_storage(area_); }

  /// Cells with donors after their receivers' donors: upstream first (route_filled first).
  std::span<const std::int32_t> order() const { return order_; }
  /// The receiver of cell c, or −1 for an outlet.
  std::int64_t receiver(std::size_t c) const {
    const int k = direction(c);
    return k < 8 ? static_cast<std::int64_t>(neighbour(c, k)) : -1;
  }

 private:
  static constexpr std::uint8_t kDirectionMask = 0x0f;  ///< D8 index 0–7, or one of these:
  static constexpr std::uint8_t kNoReceiver = 8;
  static constexpr std::uint8_t kOutlet = 15;
  static constexpr std::uint8_t kClosed = 0x10;    ///< scratch (fill): reached by the flood
  static constexpr std::uint8_t kOneDonor = 0x10;  ///< scratch (order): donors not yet placed

  std::size_t at(int i, int j) const {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(i);
  }
  int direction(std::size_t c) const { return cell_[c] & kDirectionMask; }
  std::size_t neighbour(std::size_t c, int k) const {
    return static_cast<std::size_t>(static_cast<std::ptrdiff_t>(c) + offset_[k]);
  }
  void clear_scratch() {
    for (std::uint8_t& cell : cell_) cell &= kDirectionMask;
  }

  /// Kahn's topological order of the flow graph, cells without donors first (in index order):
  /// every cell comes after all its donors. Any such order gives the same areas and heights, as
  /// each cell's update reads only its receiver; the donor counts live in the flags' high
  /// nibble (at most eight).
  void order_cells() {
    clear_scratch();
    for (std::size_t c = 0; c < n_; ++c) {
      if (const int k = direction(c); k < 8) cell_[neighbour(c, k)] += kOneDonor;
    }
    order_.resize(n_);
    std::size_t tail = 0;
    for (std::size_t c = 0; c < n_; ++c) {
      if (cell_[c] < kOneDonor) order_[tail++] = static_cast<std::int32_t>(c);
    }
    for (std::size_t head = 0; head < tail; ++head) {
      const auto c = static_cast<std::size_t>(order_[head]);
      const int k = direction(c);
      if (k >= 8) continue;
      const std::size_t r = neighbour(c, k);
      cell_[r] -= kOneDonor;
      if (cell_[r] < kOneDonor) order_[tail++] = static_cast<std::int32_t>(r);
    }
    assert(tail == n_ && "the flow graph is a forest");
  }

  double area_power(std::uint32_t cells) const {
    if (cells <= kPowerTableCells) return powers_[cells];
    return portable_pow(static_cast<double>(cells), concavity_) * cell_area_power_;
  }

  int w_, h_;
  std::size_t n_;
  double cell_metres_, cell_relative_;
  std::vector<std::uint8_t> cell_;     ///< low nibble: direction; high nibble: scratch
  std::vector<std::uint16_t> uplift_;  ///< UpliftPattern::encode of each cell's uplift
  std::vector<std::int32_t> order_;
  std::vector<std::uint32_t> area_;
  std::ptrdiff_t offset_[8] = {};
  double distance_[8] = {};
  double concavity_ = 0.5, cell_area_power_ = 1.0;
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
  return erode(std::vector<float>(grid.elevation.begin(), grid.elevation.end()), grid.width,
               grid.height, grid.cell_size, p);
}

Result<std::vector<float>> erode(std::vector<float>&& heights, int width, int height,
                                 double cell_size, const ErosionParams& p) {
  const ElevationGrid grid{width, height, cell_size, heights, std::nullopt, {}};
  if (Status valid = validate_erosion(grid, p); !valid) return valid.error();
  // The input, and then the finest level's heights: the solve overwrites it once each cell's
  // uplift and outlet flag are taken from it.
  std::vector<float> field = std::move(heights);
  const std::span<const float> input = field;

  // Base and relief: the sea level (or the lowest cell) to the highest cell.
  double top = input.front(), base = input.front();
  for (const float v : input) {
    top = std::max(top, static_cast<double>(v));
    base = std::min(base, static_cast<double>(v));
  }
  if (p.sea_level) base = *p.sea_level;
  const double relief = std::max(top - base, 0.0);
  const UpliftPattern uplift{1.0 - p.uplift, p.uplift, base, relief};
  // ε: a drop every cell keeps to its receiver, four float32 ulps of the largest magnitude at
  // least, so heights stored in float32 keep draining.
  const double magnitude = std::max({std::fabs(top), std::fabs(base), 1.0});
  const double epsilon =
      std::max(1e-3, 4.0 * (std::nextafter(static_cast<float>(magnitude), INFINITY) -
                            static_cast<float>(magnitude)));
  const double talus_slope = portable_tan(p.talus_angle * kPi / 180.0);
  const double side = grid.cell_size * (std::max(width, height) - 1);

  // Coarse to fine. Each level's input is the authored grid resampled (the finest level works in
  // the input itself); the coarser level's result and input are freed before the finer level's
  // flow graph is built, so the finest level's fifteen bytes per cell, input included, are the
  // peak.
  const std::vector<ErosionLevel> levels = erosion_levels(width, height, p.iterations);
  std::vector<float> z;                 // the coarser level's result
  std::vector<float> coarser_authored;  // the coarser level's input
  std::vector<float> authored_storage;  // this level's input, but at the finest level
  int zw = 0, zh = 0;
  double lambda = 0.0;
  std::optional<Solver> solver;
  for (std::size_t li = levels.size(); li-- > 0;) {
    const ErosionLevel& level = levels[li];
    const double cell_metres =
        grid.cell_size * (std::max(width, height) - 1) / (std::max(level.width, level.height) - 1);
    if (li > 0) authored_storage = resample(input, width, height, level.width, level.height);
    const std::span<const float> authored =
        li > 0 ? std::span<const float>(authored_storage) : input;
    solver.emplace(authored, uplift, level.width, level.height, cell_metres, cell_metres / side,
                   p.sea_level);
    // The level's heights start as its input: the finest level's are the input's own storage,
    // which the solver has read all it needs from.
    std::vector<float> start =
        li > 0 ? std::vector<float>(authored.begin(), authored.end()) : std::move(field);
    if (!z.empty()) {
      // The coarser result, plus the input's detail that the coarser grid could not hold: what
      // the coarse steps carved stays carved, and what they never saw is there to shape.
      // Outlets keep the authored heights at every level.
      const Resampler coarse_result(z, zw, zh, level.width, level.height);
      const Resampler coarse_input(coarser_authored, zw, zh, level.width, level.height);
      for (int j = 0; j < level.height; ++j) {
        for (int i = 0; i < level.width; ++i) {
          const std::size_t c =
              static_cast<std::size_t>(j) * static_cast<std::size_t>(level.width) +
              static_cast<std::size_t>(i);
          if (solver->is_outlet(c)) continue;
          start[c] = static_cast<float>(coarse_result(i, j) + (start[c] - coarse_input(i, j)));
        }
      }
      free_storage(z);
      free_storage(coarser_authored);
    }
    solver->z = std::move(start);
    solver->prepare_powers(p.concavity);
    const double diffusion = level_diffusion(p.diffusion, width, height, level);
    for (int step = 0; step < level.steps; ++step) {
      solver->diffuse(diffusion);
      solver->route_filled(epsilon);
      solver->accumulate();
      if (li + 1 == levels.size() && step == 0) {
        // U = K λ u with λ from the first network: the steady state spans the relief.
        const double chi = solver->max_chi();
        lambda = chi > 0.0 ? relief / chi : 0.0;
      }
      solver->incise(p.strength, lambda, epsilon);
      solver->talus(talus_slope);
    }
    if (li > 0) {
      z = std::move(solver->z);
      coarser_authored = std::move(authored_storage);
      solver.reset();
      zw = level.width;
      zh = level.height;
    }
  }

  // The finest level's solver goes on: the authored relief exactly, then the talus slope again,
  // then drainage in float32.
  Solver& last = *solver;
  last.release_areas();
  double high = base;
  for (std::size_t c = 0; c < last.z.size(); ++c) {
    if (!last.is_outlet(c)) high = std::max(high, static_cast<double>(last.z[c]));
  }
  if (high > base) {
    // Stretched about the outlet each cell drains to, so every path keeps descending: stretching
    // about one base would lower cells next to a high edge below it, and filling would flatten
    // them.
    last.route_filled(epsilon);
    std::vector<float> outlet_height(last.z.size());
    const std::span<const std::int32_t> order = last.order();
    for (std::size_t k = order.size(); k-- > 0;) {
      const auto c = static_cast<std::size_t>(order[k]);
      const std::int64_t r = last.receiver(c);
      outlet_height[c] = r < 0 ? last.z[c] : outlet_height[static_cast<std::size_t>(r)];
    }
    // The largest stretch that keeps every cell at or below the authored top: the cell that
    // sets it lands on the top. (Not always the highest cell: one draining to a lower outlet
    // stands further above it.)
    double stretch = INFINITY;
    for (std::size_t c = 0; c < last.z.size(); ++c) {
      const double above = static_cast<double>(last.z[c]) - outlet_height[c];
      if (!last.is_outlet(c) && above > 0.0) {
        stretch = std::min(stretch, (top - outlet_height[c]) / above);
      }
    }
    if (!std::isfinite(stretch)) stretch = 1.0;
    for (std::size_t c = 0; c < last.z.size(); ++c) {
      if (!last.is_outlet(c)) {
        last.z[c] = static_cast<float>(
            outlet_height[c] + (static_cast<double>(last.z[c]) - outlet_height[c]) * stretch);
      }
    }
  }

  last.talus(talus_slope);
  last.route_filled(epsilon);
  std::vector<float>& out = last.z;
  const std::span<const std::int32_t> order = last.order();
  for (std::size_t k = order.size(); k-- > 0;) {
    const auto c = static_cast<std::size_t>(order[k]);
    const std::int64_t r = last.receiver(c);
    if (r >= 0 && !(out[c] > out[static_cast<std::size_t>(r)])) {
      out[c] = std::nextafter(out[static_cast<std::size_t>(r)], INFINITY);
    }
  }
  return std::move(out);
}

}  // namespace terrain
