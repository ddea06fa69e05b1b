// Drainage of an elevation grid (docs/analysis.md): depression filling by priority-flood with an
// epsilon gradient (Barnes, Lehman & Mulla 2014), D8 flow directions on the filled surface,
// drainage area by accumulation in topological order, and Strahler stream orders. Everything is
// a pure, single-threaded function of the grid: fixed visit orders, ties broken by the lower
// linear index, no unordered containers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "terrain/result.hpp"

namespace terrain {

/// A row-major elevation grid: cell (i, j) is elevation[j * width + i]; cells are square,
/// `cell_size` metres on a side. Which way is north does not matter to any figure.
struct ElevationGrid {
  int width = 0;
  int height = 0;
  double cell_size = 1.0;            ///< metres, finite and > 0
  std::span<const float> elevation;  ///< width * height metres; NaN = no data
  /// Cells at or below this elevation are sea: not land, outlets.
  std::optional<float> sea_level = {};
  /// Empty, or width * height flags: nonzero marks a cell as water (not land, an outlet).
  std::span<const std::uint8_t> water = {};
  /// Empty, or width * height flags: nonzero marks land under water — kFlowingWater (a river)
  /// or kStandingWater (a lake). Flow crosses it like any land; the analysis counts no pits or
  /// closed depressions there (a lake's floor is a depression by nature), and leaves standing
  /// water out of Flint's law (a lake floor's slope is not a river's).
  std::span<const std::uint8_t> wet = {};
};
inline constexpr std::uint8_t kFlowingWater = 1, kStandingWater = 2;

/// The eight D8 neighbours' offsets in increasing linear index: the row below, the same row,
/// the row above (the order every tie-break follows).
inline constexpr int kD8Dx[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
inline constexpr int kD8Dy[8] = {-1, -1, -1, 0, 0, 1, 1, 1};

/// The largest grid analysed: each side at most 8192 cells, at most 16 Mi cells in all.
inline constexpr int kMaxGridSide = 8192;
inline constexpr std::int64_t kMaxGridCells = std::int64_t{1} << 24;

/// Where water goes. Land cells are those with a finite elevation above the sea level and not
/// marked as water; every other cell, and every land cell on the grid's edge, is an outlet.
struct Drainage {
  int width = 0;
  int height = 0;
  double cell_size = 1.0;
  std::vector<std::uint8_t> land;  ///< 1 for land cells
  /// The depression-filled surface (priority-flood + epsilon, in double precision): each land
  /// cell not an outlet lies strictly above the cell the flood reached it from, by the smallest
  /// step a double allows, so that every such cell has a strictly lower D8 neighbour. Outlets
  /// keep their raw elevation (−∞ for no-data cells).
  std::vector<double> filled;
  /// D8 receiver of each cell (steepest descent on `filled`, ties to the lower linear index),
  /// or −1 for outlets.
  std::vector<std::int32_t> receiver;
  /// Every cell once, in the order the flood reached them: a receiver always comes before its
  /// donors, so the reverse is an upstream-first topological order.
  std::vector<std::int32_t> order;
  /// Drainage area of each land cell in m²: its own cell plus every cell draining through it
  /// (0 for cells that are not land).
  std::vector<double> area;

  std::size_t cells() const { return land.size(); }
};

/// Validates the grid (sides 1..kMaxGridSide, at most kMaxGridCells, cell size finite and > 0,
/// elevation, water and wet spans of the right length, a finite sea level) and routes it.
/// Errors name the field: /width, /height, /cell_size, /elevation, /water, /wet, /sea_level.
Result<Drainage> route_drainage(const ElevationGrid& grid);

/// Strahler order of every cell of a channel network (0 for cells outside it): a channel cell
/// with no channel donor has order 1; otherwise the highest order among its channel donors,
/// plus one when two or more donors share that highest order. `receiver` and `order` are as in
/// Drainage (any receiver-first order of all cells); `channel` flags the network's cells.
std::vector<int> strahler_orders(std::span<const std::int32_t> receiver,
                                 std::span<const std::int32_t> order,
                                 std::span<const std::uint8_t> channel);

/// The neighbour of cell (i, j) in the grid down which D8 sends water: the steepest strict
/// descent on `filled` (drop over one cell straight, √2 diagonally; ties to the first in kD8
/// order, the lower linear index), or −1 where none is lower. Every land cell inside the grid
/// has this as its receiver; an edge cell, an outlet, would pass water from beyond the grid to it.
std::int32_t steepest_descent(const Drainage& drainage, int i, int j);

/// Distance from cell `from` to its D8 neighbour `to`: one cell size straight, √2 diagonally.
double d8_distance(const Drainage& drainage, std::int32_t from, std::int32_t to);

}  // namespace terrain
