// Rivers and lakes of an elevation grid (docs/erosion.md, "Drainage"): depressions found by
// priority-flood become lakes at their spill level (or, when shallow, sediment), flow is routed
// D8 and accumulated, cells draining at least a threshold area become channels whose width and
// depth follow hydraulic geometry (w ∝ Q^0.5, d ∝ Q^0.4 with Q ∝ drainage area), and the
// channels are carved into the surface with beds that descend downstream. A pure function of its
// inputs, like erode(): fixed visit orders, integer tie-breaks, powers from + − × ÷ only.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "terrain/drainage.hpp"
#include "terrain/result.hpp"

namespace terrain {

/// What makes a channel and how large it is. A channel draining area A has width
/// `width` · (A / channel_area)^0.5 and depth `depth` · (A / channel_area)^0.4 (Leopold &
/// Maddock's exponents, runoff uniform so discharge ∝ area); its water stands at 0.8 of its depth.
struct RiverParams {
  double channel_area = 1e5;  ///< m²: the drainage area where channels begin
  double width = 10.0;        ///< m: a channel's width where it begins
  double depth = 1.0;         ///< m: its depth there
  double bank_slope = 0.5;    ///< rise per run of the banks beside the bed
  /// m: depressions at least this deep become lakes; shallower ones are filled as sediment.
  double lake_depth = 1.0;
  std::optional<double> sea_level = {};  ///< cells at or below are sea: outlets, and water
};

/// Accepted ranges (inclusive), checked by validate_rivers and by the drainage node's parser.
inline constexpr double kMinChannelArea = 1.0, kMaxChannelArea = 1e13;
inline constexpr double kMaxChannelWidth = 1e4, kMaxChannelDepth = 1e3;
inline constexpr double kMinBankSlope = 0.05, kMaxBankSlope = 20.0;
inline constexpr double kMaxLakeDepth = 1e4;
/// A bed widens its channel's surroundings at most this many cells from the channel's centre
/// line: the carve's work stays at most (2·8 + 1)² per cell.
inline constexpr int kMaxCarveRadius = 8;
/// The share of a channel's depth its water fills.
inline constexpr double kWaterShareOfDepth = 0.8;
/// Below the ground by this much, the water surface of a dry cell: the water layer's shoreline
/// is where the interpolated surface meets the interpolated ground.
inline constexpr float kDryDepth = 1.0f;
/// How far (in cells, along rows, columns and diagonals) the water layer's weight reaches beyond
/// wet cells: every bicubic stencil that touches water reads weights of 1 only.
inline constexpr int kWaterReachCells = 3;

/// The carved grid and its water, row-major like the input.
struct RiverNetwork {
  std::vector<float> terrain;  ///< carved heights; lake floors and sea as they were
  /// The water surface: lakes at their spill level, channels at 0.8 of their depth, the sea at
  /// its level; kDryDepth below `terrain` where there is no water.
  std::vector<float> water;
  /// The water layer's weight: 1 within kWaterReachCells of a cell whose water stands above its
  /// ground (lakes, channels and their floors, the sea), 0 further away. Dry land away from water
  /// thus has no water surface at all, rather than one kDryDepth below it, which pictures and
  /// colour tiles would take for a shore.
  std::vector<float> water_weight;
  std::vector<std::uint8_t> channel;  ///< 1 for a channel's centre-line cells
  std::vector<std::uint8_t> lake;     ///< 1 for lake cells
  /// Downstream channel cell of each channel cell, or −1 where the channel ends (the grid's
  /// edge, the sea, a lake).
  std::vector<std::int32_t> downstream;
  std::vector<int> strahler;  ///< Strahler order of channel cells, 0 elsewhere
  int lakes = 0;              ///< lakes kept (depressions at least lake_depth deep)
};

/// Refuses parameters outside their ranges (naming /channel_area, /width, /depth, /bank_slope,
/// /lake_depth, /sea_level) and grids route_drainage refuses.
Status validate_rivers(const ElevationGrid& grid, const RiverParams& params);

/// The grid's rivers and lakes. Every channel bed and channel water surface lies strictly below
/// the one upstream (in float32); every land cell that is not a lake, sea or on the grid's edge
/// has a strictly lower neighbour, so the carved surface has no pits outside its lakes.
/// `grid.water` is ignored.
Result<RiverNetwork> carve_rivers(const ElevationGrid& grid, const RiverParams& params);

}  // namespace terrain
