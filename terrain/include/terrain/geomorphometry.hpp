// Geomorphometry of an elevation grid (docs/analysis.md): pits, closed depressions, Flint's law
// over channel cells, Strahler orders and Horton's bifurcation ratio, drainage density and the
// hypsometric integral — the figures that tell land shaped by rivers from noise. A pure,
// deterministic function of the grid (drainage.hpp does the routing).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/drainage.hpp"
#include "terrain/result.hpp"

namespace terrain {

/// Cells [x0, x1) × [y0, y1) of a grid.
struct AnalysisWindow {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

struct AnalysisOptions {
  /// Cells draining at least this many m² are channel cells; 0 lets the drop analysis choose
  /// (drop_analysis, constant_drop_threshold), or 1% of the grid's area (width · height ·
  /// cell_size²) where no candidate keeps a constant drop.
  double channel_area = 0.0;
  /// A land cell is in a closed depression when filling raises it by more than this (metres).
  double depression_epsilon = 1e-3;
  /// The cells every figure describes, as if they were the grid, while the drainage (filling,
  /// receivers, areas) is routed over the whole grid: land around a window adds the water it
  /// sends in. Streams leaving the window end there, cut off as by a grid's edge; edge-fed
  /// channels are those the whole grid's edge feeds. None: the whole grid.
  std::optional<AnalysisWindow> window;
};

/// A least-squares fit of log10 S = log10 k_s − θ · log10 A over channel cells with S > 0.
struct FlintFit {
  double theta = 0.0;      ///< concavity θ
  double steepness = 0.0;  ///< k_s, in the units of S at A = 1 m²
  double r_squared = 0.0;  ///< coefficient of determination of the log-log fit
  std::int64_t cells = 0;  ///< channel cells in the fit
};

/// One bin of the slope–area profile: the land cells whose drainage area lies in
/// [area_from, area_to), a quarter of a decade, with their slope S on the raw surface (the same
/// cells and S as Flint's fit, hillslopes included: S > 0, standing water left out).
struct SlopeAreaBin {
  double area_from = 0.0;  ///< m², 10^(k/4)
  double area_to = 0.0;    ///< m², 10^((k+1)/4)
  std::int64_t cells = 0;
  std::int64_t channel_cells = 0;  ///< of them, those draining at least the channel threshold
  /// Nearest-rank percentiles of S (metres per metre): the value at rank ⌈q·cells⌉.
  double slope_p10 = 0.0, slope_median = 0.0, slope_p90 = 0.0;
};

/// One row of the drop analysis (Tarboton, Bras & Rodríguez-Iturbe 1991): the network that a
/// candidate channel threshold extracts, and whether its streams keep Broscoe's constant drop.
struct DropTest {
  double channel_area = 0.0;  ///< m²
  std::vector<std::int64_t> streams_per_order;
  std::optional<double> bifurcation_ratio;
  std::int64_t first_order_streams = 0;   ///< complete ones (not cut by the grid's edge)
  double first_order_mean_drop = 0.0;     ///< metres
  std::int64_t higher_order_streams = 0;  ///< complete ones of order 2 and above
  double higher_order_mean_drop = 0.0;    ///< metres
  std::optional<double> t;  ///< Student's t of the two means; none with under 5 on a side
};

/// How the channel threshold was set.
enum class ChannelThreshold {
  given,          ///< AnalysisOptions::channel_area
  constant_drop,  ///< chosen by the drop analysis
  share_of_area,  ///< 1% of the grid's area: no candidate kept a constant drop
};
/// The rule's name in the JSON (`channels.threshold_rule`).
std::string_view threshold_rule_name(ChannelThreshold rule);

struct Geomorphometry {
  int width = 0;
  int height = 0;
  double cell_size = 0.0;  ///< metres
  std::int64_t land_cells = 0;
  std::int64_t wet_cells = 0;  ///< land cells under a lake or river (ElevationGrid::wet)
  /// Interior dry land cells with no lower D8 neighbour (raw).
  std::int64_t pits = 0;
  double pit_share = 0.0;                ///< pits / dry land cells
  double depression_epsilon = 0.0;       ///< metres, the threshold used
  std::int64_t depression_cells = 0;     ///< dry land cells raised by filling > depression_epsilon
  double closed_depression_share = 0.0;  ///< depression_cells / dry land cells
  double channel_area = 0.0;             ///< threshold used, m²
  ChannelThreshold channel_threshold = ChannelThreshold::given;
  /// The candidates the threshold was chosen from; empty when the options gave it.
  std::vector<DropTest> drop_analysis;
  std::int64_t channel_cells = 0;
  double max_drainage_area = 0.0;  ///< m², the largest over land cells
  std::optional<FlintFit> flint;   ///< none with fewer than 3 cells or no spread in area
  /// Channel cells that water from beyond the grid's edge may reach (edge_fed): their drainage
  /// area counts only the land inside the grid.
  std::int64_t edge_fed_channel_cells = 0;
  /// Flint's fit over the channel cells that are not edge-fed: the channels that begin inside
  /// the grid, with their whole drainage area. None as for `flint`.
  std::optional<FlintFit> flint_inside;
  /// Slope against drainage area in quarter decades, smallest areas first (empty bins left
  /// out): the curve Flint's law fits a line to, with the hillslopes below the channel head.
  std::vector<SlopeAreaBin> slope_area;
  int max_strahler_order = 0;
  std::vector<std::int64_t> streams_per_order;  ///< [ω − 1] = number of streams of order ω
  /// Horton's R_b = 10^(−slope) of the least-squares line of log10 N_ω against ω; none below
  /// order 2.
  std::optional<double> bifurcation_ratio;
  double channel_length = 0.0;                 ///< metres, over channel cells to their receivers
  double drainage_density = 0.0;               ///< channel length / land area, 1/km
  std::optional<double> hypsometric_integral;  ///< (mean − min) / (max − min); none if flat
  double min_elevation = 0.0;                  ///< over land cells (0 when there is no land)
  double max_elevation = 0.0;
  double mean_elevation = 0.0;
};

/// The version of to_json's layout: 2 since the slope–area profile, 3 since the edge-fed
/// channels. Caches of analyses key on it.
inline constexpr int kAnalysisFormat = 3;

/// A picture of an analysed grid, RGB8, width × height, the grid's last row (north) at the
/// top: dry land as a hillshade lit from the north-west; channel cells (draining at least the
/// threshold) in blue, darker as they drain more; pits red; flowing water cyan, standing water
/// blue, sea and no data dark blue.
struct AnalysisPicture {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;
};

/// Routes the grid (route_drainage) and computes every figure; with `picture`, also draws the
/// routing (draw_drainage) when it succeeds. Errors name the field, as route_drainage's, plus
/// /channel_area and /depression_epsilon (finite and ≥ 0) and /window (non-empty, in the grid).
Result<Geomorphometry> analyze(const ElevationGrid& grid, const AnalysisOptions& options = {},
                               AnalysisPicture* picture = nullptr);

/// The picture of `figures`, analysed from `grid` routed as `drainage`.
AnalysisPicture draw_drainage(const ElevationGrid& grid, const Drainage& drainage,
                              const Geomorphometry& figures);

/// The same from a routing already made (`grid` must be the one `drainage` was routed from).
Result<Geomorphometry> analyze(const ElevationGrid& grid, const Drainage& drainage,
                               const AnalysisOptions& options = {});

/// The cells that water from beyond the grid may reach, 1 for each: a grid cut out of wider
/// land drains water from outside through its edge cells (outlets of the routing), and water
/// on an edge cell goes on, as D8 would send it, to its steepest strictly lower neighbour in
/// the grid (unless a neighbour beyond is steeper). Each land cell inside the grid that is
/// that neighbour of an edge land cell, and every cell downstream of it, is edge-fed; edge
/// cells themselves are not.
std::vector<std::uint8_t> edge_fed(const Drainage& drainage);

/// The drop analysis of a routed grid: the networks that 16 candidate thresholds,
/// spaced evenly in log from 25 cells to 5% of the grid's area, extract, each with its
/// Strahler streams and the t-test of Broscoe's constant drop (docs/analysis.md).
std::vector<DropTest> drop_analysis(const Drainage& drainage);
/// The same over the cells of `window` (1 for each; the candidates span its area instead).
std::vector<DropTest> drop_analysis(const Drainage& drainage, std::span<const std::uint8_t> window);

/// The smallest candidate threshold whose streams keep a constant drop (|t| < 2) along with
/// every larger candidate that has a t; none when the largest testable one fails or none has a t.
std::optional<double> constant_drop_threshold(std::span<const DropTest> table);

/// The figures as JSON; field names and definitions are in docs/analysis.md. Figures that are
/// undefined (no fit, order below 2, flat land) are null.
nlohmann::json to_json(const Geomorphometry& g);

}  // namespace terrain
