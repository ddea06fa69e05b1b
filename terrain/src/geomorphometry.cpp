// The figures of docs/analysis.md over a routed grid: every sum runs in linear index order in
// double precision, so the same grid gives the same bits.
#include "terrain/geomorphometry.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>

namespace terrain {
namespace {

/// Least-squares line y = a + b·x; none with fewer than `min_points` points or no spread in x.
struct Line {
  double intercept = 0.0;
  double slope = 0.0;
  double r_squared = 0.0;
};

std::optional<Line> fit_line(const std::vector<double>& x, const std::vector<double>& y,
                             std::size_t min_points) {
  const std::size_t n = x.size();
  if (n < min_points) return std::nullopt;
  double sx = 0.0, sy = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    sx += x[k];
    sy += y[k];
  }
  const double mx = sx / static_cast<double>(n);
  const double my = sy / static_cast<double>(n);
  double sxx = 0.0, sxy = 0.0, syy = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double dx = x[k] - mx;
    const double dy = y[k] - my;
    sxx += dx * dx;
    sxy += dx * dy;
    syy += dy * dy;
  }
  if (!(sxx > 0.0)) return std::nullopt;
  Line line;
  line.slope = sxy / sxx;
  line.intercept = my - line.slope * mx;
  // r² = 1 − SS_res / SS_tot = (S_xy)² / (S_xx · S_yy); a perfect fit when y does not vary.
  line.r_squared = syy > 0.0 ? (sxy * sxy) / (sxx * syy) : 1.0;
  return line;
}

/// Whether dry land cell (i, j) is a pit: not on the edge (edge cells are outlets), with no D8
/// neighbour strictly lower on the raw surface, a neighbour that is not land counting as lower.
bool is_pit(const ElevationGrid& grid, const Drainage& d, int i, int j) {
  const int w = d.width;
  if (i == 0 || j == 0 || i == w - 1 || j == d.height - 1) return false;
  const std::size_t c =
      static_cast<std::size_t>(j) * static_cast<std::size_t>(w) + static_cast<std::size_t>(i);
  for (int k = 0; k < 8; ++k) {
    const std::size_t nc = static_cast<std::size_t>(j + kD8Dy[k]) * static_cast<std::size_t>(w) +
                           static_cast<std::size_t>(i + kD8Dx[k]);
    if (d.land[nc] == 0 || grid.elevation[nc] < grid.elevation[c]) return false;
  }
  return true;
}

/// S at rank ⌈q·n⌉ of the sorted slopes (nearest rank).
double nearest_rank(const std::vector<double>& sorted, double q) {
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

/// S = (z − z_receiver) / distance on the raw surface of a cell that Flint's fit and the
/// slope–area profile count: one with a receiver, not under standing water (a lake floor's slope
/// is not a river's), and S finite and > 0 (not in a filled depression or on a flat).
std::optional<double> fit_slope(const ElevationGrid& grid, const Drainage& d, std::size_t c) {
  const std::int32_t r = d.receiver[c];
  if (r < 0 || (!grid.wet.empty() && grid.wet[c] == kStandingWater)) return std::nullopt;
  const double slope = (static_cast<double>(grid.elevation[c]) -
                        static_cast<double>(grid.elevation[static_cast<std::size_t>(r)])) /
                       d8_distance(d, static_cast<std::int32_t>(c), r);
  if (!(std::isfinite(slope) && slope > 0.0)) return std::nullopt;
  return slope;
}

/// The slope–area profile (Geomorphometry::slope_area) over every land cell fit_slope counts.
std::vector<SlopeAreaBin> slope_area_profile(const ElevationGrid& grid, const Drainage& d,
                                             const std::vector<std::uint8_t>& channel,
                                             std::span<const std::uint8_t> window) {
  // Bin k holds areas in [10^(k/4), 10^((k+1)/4)): its cells' slopes and channel cells.
  std::map<int, std::pair<std::vector<double>, std::int64_t>> by_bin;
  for (std::size_t c = 0; c < d.cells(); ++c) {
    if (d.land[c] == 0 || window[c] == 0) continue;
    const std::optional<double> slope = fit_slope(grid, d, c);
    if (!slope) continue;
    auto& [slopes, channels] = by_bin[static_cast<int>(std::floor(4.0 * std::log10(d.area[c])))];
    slopes.push_back(*slope);
    channels += channel[c];
  }
  std::vector<SlopeAreaBin> bins;
  for (auto& [k, bin] : by_bin) {
    std::vector<double>& v = bin.first;
    std::sort(v.begin(), v.end());
    bins.push_back({std::pow(10.0, k / 4.0), std::pow(10.0, (k + 1) / 4.0),
                    static_cast<std::int64_t>(v.size()), bin.second, nearest_rank(v, 0.1),
                    nearest_rank(v, 0.5), nearest_rank(v, 0.9)});
  }
  return bins;
}

/// The Strahler streams of one channel network: a stream of order ω starts at each channel cell
/// of order ω that no donor of order ω flows into and runs down its receivers while they stay
/// channel cells of order ω.
struct StreamNetwork {
  std::vector<std::int64_t> streams_per_order;  ///< [ω − 1] = number of streams of order ω
  /// Drop of each complete stream (filled elevation at its start minus at the cell it ends in:
  /// the junction with a higher order or the sea), by order; streams the grid's edge or the
  /// analysis window cuts off are left out, their drop being the window's, not the river's.
  std::vector<std::vector<double>> drops_per_order;
};

StreamNetwork trace_streams(const Drainage& d, const std::vector<std::uint8_t>& channel,
                            std::span<const std::uint8_t> window) {
  const std::size_t n = d.cells();
  const std::vector<int> strahler = strahler_orders(d.receiver, d.order, channel);
  std::vector<std::uint8_t> continued(n, 0);
  int max_order = 0;
  for (std::size_t c = 0; c < n; ++c) {
    if (channel[c] == 0) continue;
    max_order = std::max(max_order, strahler[c]);
    const std::int32_t r = d.receiver[c];
    if (r < 0) continue;
    const auto rc = static_cast<std::size_t>(r);
    if (channel[rc] != 0 && strahler[rc] == strahler[c]) continued[rc] = 1;
  }
  StreamNetwork network;
  network.streams_per_order.assign(static_cast<std::size_t>(max_order), 0);
  network.drops_per_order.resize(static_cast<std::size_t>(max_order));
  for (std::size_t c = 0; c < n; ++c) {
    if (channel[c] == 0 || continued[c] != 0) continue;
    const int order = strahler[c];
    ++network.streams_per_order[static_cast<std::size_t>(order - 1)];
    std::size_t last = c;
    std::int32_t next = d.receiver[last];
    while (next >= 0 && channel[static_cast<std::size_t>(next)] != 0 &&
           strahler[static_cast<std::size_t>(next)] == order) {
      last = static_cast<std::size_t>(next);
      next = d.receiver[last];
    }
    // Ends on the grid's edge, or leaves the window.
    if (next < 0 || window[static_cast<std::size_t>(next)] == 0) continue;
    network.drops_per_order[static_cast<std::size_t>(order - 1)].push_back(
        d.filled[c] - d.filled[static_cast<std::size_t>(next)]);
  }
  return network;
}

/// Horton's R_b = 10^(−slope) of log10 N_ω against ω; none below order 2.
std::optional<double> bifurcation_ratio(const std::vector<std::int64_t>& streams_per_order) {
  if (streams_per_order.size() < 2) return std::nullopt;
  std::vector<double> orders, log_count;
  for (std::size_t k = 0; k < streams_per_order.size(); ++k) {
    orders.push_back(static_cast<double>(k + 1));
    log_count.push_back(std::log10(static_cast<double>(streams_per_order[k])));
  }
  const std::optional<Line> line = fit_line(orders, log_count, 2);
  if (!line) return std::nullopt;
  return std::pow(10.0, -line->slope);
}

/// Fewer complete streams than this on a side leave a candidate untested: a t of so few says
/// nothing.
constexpr std::size_t kDropMinStreams = 5;

/// The first-order streams' drops and the higher orders' together.
struct DropSamples {
  std::vector<double> first;
  std::vector<double> higher;
};

DropSamples drop_samples(const StreamNetwork& network) {
  DropSamples samples;
  for (std::size_t k = 0; k < network.drops_per_order.size(); ++k) {
    std::vector<double>& side = k == 0 ? samples.first : samples.higher;
    side.insert(side.end(), network.drops_per_order[k].begin(), network.drops_per_order[k].end());
  }
  return samples;
}

double mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (const double x : v) sum += x;
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

double squared_deviations(const std::vector<double>& v, double mean) {
  double ss = 0.0;
  for (const double x : v) ss += (x - mean) * (x - mean);
  return ss;
}

/// Student's two-sample t of the first-order streams' mean drop against the higher orders'
/// (pooled variance); none with fewer than kDropMinStreams complete streams on either side.
std::optional<double> drop_t_statistic(const DropSamples& s) {
  if (s.first.size() < kDropMinStreams || s.higher.size() < kDropMinStreams) return std::nullopt;
  const double m1 = mean(s.first);
  const double m2 = mean(s.higher);
  const auto n1 = static_cast<double>(s.first.size());
  const auto n2 = static_cast<double>(s.higher.size());
  const double pooled =
      (squared_deviations(s.first, m1) + squared_deviations(s.higher, m2)) / (n1 + n2 - 2.0);
  const double se = std::sqrt(pooled * (1.0 / n1 + 1.0 / n2));
  if (!(se > 0.0)) return std::nullopt;
  return (m1 - m2) / se;
}

/// Land cells of the window draining at least `channel_area`.
std::vector<std::uint8_t> channel_cells(const Drainage& d, double channel_area,
                                        std::span<const std::uint8_t> window) {
  std::vector<std::uint8_t> channel(d.cells(), 0);
  for (std::size_t c = 0; c < d.cells(); ++c) {
    channel[c] = d.land[c] != 0 && window[c] != 0 && d.area[c] >= channel_area ? 1 : 0;
  }
  return channel;
}

/// The candidate thresholds of the drop analysis: kDropThresholds areas spaced evenly in log
/// from kDropMinCells cells to kDropMaxShare of the grid's area.
constexpr int kDropThresholds = 16;
constexpr double kDropMinCells = 25.0;
constexpr double kDropMaxShare = 0.05;
/// The channel threshold, as a share of the grid's area, where no candidate keeps a constant drop.
constexpr double kFallbackChannelShare = 0.01;
/// |t| below this: the first-order streams' mean drop does not differ from the higher orders'.
constexpr double kDropCriticalT = 2.0;

Status validate(const AnalysisOptions& options) {
  if (!std::isfinite(options.channel_area) || options.channel_area < 0.0) {
    return Error{"must be a finite area in m² (0 to let the drop analysis choose)",
                 "/channel_area"};
  }
  if (!std::isfinite(options.depression_epsilon) || options.depression_epsilon < 0.0) {
    return Error{"must be a finite number of metres, at least 0", "/depression_epsilon"};
  }
  return Ok{};
}

}  // namespace

std::vector<std::uint8_t> edge_fed(const Drainage& d) {
  const int w = d.width, h = d.height;
  std::vector<std::uint8_t> fed(d.cells(), 0);
  const auto on_edge = [w, h](std::size_t c) {
    const auto i = static_cast<int>(c % static_cast<std::size_t>(w));
    const auto j = static_cast<int>(c / static_cast<std::size_t>(w));
    return i == 0 || j == 0 || i == w - 1 || j == h - 1;
  };
  // Where water from beyond enters: each edge land cell's steepest descent in the grid, where
  // that is land inside. Water passed along the edge enters where the last edge cell passes it
  // in, and that cell is an edge cell of its own here; water passed to the sea leaves.
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const std::size_t b =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(w) + static_cast<std::size_t>(i);
      if (!on_edge(b) || d.land[b] == 0) continue;
      const std::int32_t to = steepest_descent(d, i, j);
      if (to < 0) continue;
      const auto entry = static_cast<std::size_t>(to);
      if (!on_edge(entry) && d.land[entry] != 0) fed[entry] = 1;
    }
  }
  // Downstream, upstream first (the reverse of the flood's order), down to the edge: edge cells
  // are outlets, out of the fit, and not counted.
  for (std::size_t k = d.order.size(); k-- > 0;) {
    const auto c = static_cast<std::size_t>(d.order[k]);
    const std::int32_t r = d.receiver[c];
    if (fed[c] == 0 || r < 0) continue;
    const auto down = static_cast<std::size_t>(r);
    if (!on_edge(down) && d.land[down] != 0) fed[down] = 1;
  }
  return fed;
}

std::vector<DropTest> drop_analysis(const Drainage& d) {
  return drop_analysis(d, std::vector<std::uint8_t>(d.cells(), 1));
}

std::vector<DropTest> drop_analysis(const Drainage& d, std::span<const std::uint8_t> window) {
  assert(window.size() == d.cells());
  const double cell_area = d.cell_size * d.cell_size;
  const auto window_cells = std::count(window.begin(), window.end(), std::uint8_t{1});
  const double lo = kDropMinCells * cell_area;
  const double hi = kDropMaxShare * static_cast<double>(window_cells) * cell_area;
  std::vector<DropTest> table;
  for (int k = 0; k < kDropThresholds; ++k) {
    const double f = static_cast<double>(k) / static_cast<double>(kDropThresholds - 1);
    DropTest test;
    test.channel_area = lo * std::pow(hi / lo, f);
    const StreamNetwork network =
        trace_streams(d, channel_cells(d, test.channel_area, window), window);
    test.streams_per_order = network.streams_per_order;
    test.bifurcation_ratio = bifurcation_ratio(network.streams_per_order);
    const DropSamples samples = drop_samples(network);
    test.first_order_streams = static_cast<std::int64_t>(samples.first.size());
    test.first_order_mean_drop = mean(samples.first);
    test.higher_order_streams = static_cast<std::int64_t>(samples.higher.size());
    test.higher_order_mean_drop = mean(samples.higher);
    test.t = drop_t_statistic(samples);
    table.push_back(std::move(test));
  }
  return table;
}

std::optional<double> constant_drop_threshold(std::span<const DropTest> table) {
  // At small thresholds t changes sign as the networks grow and passes by chance where it
  // crosses zero, so the candidate must pass along with every larger testable one.
  std::optional<double> chosen;
  for (auto test = table.rbegin(); test != table.rend(); ++test) {
    if (!test->t) continue;
    if (std::abs(*test->t) >= kDropCriticalT) break;
    chosen = test->channel_area;
  }
  return chosen;
}

Result<Geomorphometry> analyze(const ElevationGrid& grid, const AnalysisOptions& options,
                               AnalysisPicture* picture) {
  if (Status valid = validate(options); !valid) return valid.error();
  Result<Drainage> drainage = route_drainage(grid);
  if (!drainage) return drainage.error();
  Result<Geomorphometry> figures = analyze(grid, *drainage, options);
  if (figures && picture != nullptr) *picture = draw_drainage(grid, *drainage, *figures);
  return figures;
}

Result<Geomorphometry> analyze(const ElevationGrid& grid, const Drainage& d,
                               const AnalysisOptions& options) {
  if (Status valid = validate(options); !valid) return valid.error();
  const std::size_t n = d.cells();
  if (grid.width != d.width || grid.height != d.height || grid.elevation.size() != n) {
    return Error{"the grid is not the one the drainage was routed from", ""};
  }
  const int w = d.width;
  const int h = d.height;
  const std::span<const float> raw = grid.elevation;
  const AnalysisWindow window = options.window.value_or(AnalysisWindow{0, 0, w, h});
  if (!(window.x0 >= 0 && window.y0 >= 0 && window.x0 < window.x1 && window.y0 < window.y1 &&
        window.x1 <= w && window.y1 <= h)) {
    return Error{"must be a non-empty rectangle of the grid's cells", "/window"};
  }
  std::vector<std::uint8_t> in_window(n, 0);
  for (int j = window.y0; j < window.y1; ++j) {
    for (int i = window.x0; i < window.x1; ++i) {
      in_window[static_cast<std::size_t>(j) * static_cast<std::size_t>(w) +
                static_cast<std::size_t>(i)] = 1;
    }
  }
  const auto window_cells = static_cast<std::size_t>(window.x1 - window.x0) *
                            static_cast<std::size_t>(window.y1 - window.y0);

  Geomorphometry g;
  g.width = window.x1 - window.x0;
  g.height = window.y1 - window.y0;
  g.cell_size = d.cell_size;
  g.depression_epsilon = options.depression_epsilon;
  const double cell_area = d.cell_size * d.cell_size;
  if (options.channel_area > 0.0) {
    g.channel_area = options.channel_area;
    g.channel_threshold = ChannelThreshold::given;
  } else {
    g.drop_analysis = drop_analysis(d, in_window);
    if (const std::optional<double> area = constant_drop_threshold(g.drop_analysis)) {
      g.channel_area = *area;
      g.channel_threshold = ChannelThreshold::constant_drop;
    } else {
      g.channel_area = kFallbackChannelShare * static_cast<double>(window_cells) * cell_area;
      g.channel_threshold = ChannelThreshold::share_of_area;
    }
  }

  // Land, elevation range, pits and closed depressions.
  double sum = 0.0;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  for (int j = window.y0; j < window.y1; ++j) {
    for (int i = window.x0; i < window.x1; ++i) {
      const std::size_t c =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(w) + static_cast<std::size_t>(i);
      if (d.land[c] == 0) continue;
      const double z = raw[c];
      ++g.land_cells;
      sum += z;
      lo = std::min(lo, z);
      hi = std::max(hi, z);
      g.max_drainage_area = std::max(g.max_drainage_area, d.area[c]);
      if (!grid.wet.empty() && grid.wet[c] != 0) {
        ++g.wet_cells;
        continue;
      }
      if (d.filled[c] - z > options.depression_epsilon) ++g.depression_cells;
      if (is_pit(grid, d, i, j)) ++g.pits;
    }
  }
  if (g.land_cells > 0) {
    const auto land = static_cast<double>(g.land_cells);
    const auto dry = static_cast<double>(std::max<std::int64_t>(g.land_cells - g.wet_cells, 1));
    g.pit_share = static_cast<double>(g.pits) / dry;
    g.closed_depression_share = static_cast<double>(g.depression_cells) / dry;
    g.min_elevation = lo;
    g.max_elevation = hi;
    g.mean_elevation = sum / land;
    if (hi > lo) g.hypsometric_integral = (g.mean_elevation - lo) / (hi - lo);
  }

  // Channels: their length, and Flint's law on the raw surface.
  // And Flint's law again over the channels no water from beyond the edge reaches.
  const std::vector<std::uint8_t> channel = channel_cells(d, g.channel_area, in_window);
  const std::vector<std::uint8_t> fed = edge_fed(d);
  std::vector<double> log_area, log_slope, inside_log_area, inside_log_slope;
  for (std::size_t c = 0; c < n; ++c) {
    if (channel[c] == 0) continue;
    ++g.channel_cells;
    g.edge_fed_channel_cells += fed[c];
    const std::int32_t r = d.receiver[c];
    if (r < 0) continue;
    g.channel_length += d8_distance(d, static_cast<std::int32_t>(c), r);
    if (const std::optional<double> slope = fit_slope(grid, d, c)) {
      log_area.push_back(std::log10(d.area[c]));
      log_slope.push_back(std::log10(*slope));
      if (fed[c] == 0) {
        inside_log_area.push_back(log_area.back());
        inside_log_slope.push_back(log_slope.back());
      }
    }
  }
  if (g.land_cells > 0) {
    g.drainage_density = g.channel_length / (static_cast<double>(g.land_cells) * cell_area) * 1e3;
  }
  const auto flint_fit = [](const std::vector<double>& x,
                            const std::vector<double>& y) -> std::optional<FlintFit> {
    const std::optional<Line> line = fit_line(x, y, 3);
    if (!line) return std::nullopt;
    return FlintFit{-line->slope, std::pow(10.0, line->intercept), line->r_squared,
                    static_cast<std::int64_t>(x.size())};
  };
  g.flint = flint_fit(log_area, log_slope);
  g.flint_inside = flint_fit(inside_log_area, inside_log_slope);

  g.slope_area = slope_area_profile(grid, d, channel, in_window);

  const StreamNetwork network = trace_streams(d, channel, in_window);
  g.max_strahler_order = static_cast<int>(network.streams_per_order.size());
  g.streams_per_order = network.streams_per_order;
  g.bifurcation_ratio = bifurcation_ratio(network.streams_per_order);
  return g;
}

AnalysisPicture draw_drainage(const ElevationGrid& grid, const Drainage& d,
                              const Geomorphometry& figures) {
  const int w = d.width, h = d.height;
  AnalysisPicture picture{w, h, std::vector<std::uint8_t>(d.cells() * 3)};
  // Light from the north-west, 45° up: a unit vector (−1, 1, √2)/2 against the surface normal
  // (−∂z/∂x, −∂z/∂y, 1) of central differences (one-sided on the grid's edge).
  const auto z = [&](int i, int j) {
    return static_cast<double>(
        grid.elevation[static_cast<std::size_t>(j) * static_cast<std::size_t>(w) +
                       static_cast<std::size_t>(i)]);
  };
  const double log_threshold = std::log10(std::max(figures.channel_area, 1e-300));
  const double log_largest = std::log10(std::max(figures.max_drainage_area, figures.channel_area));
  const double span = std::max(log_largest - log_threshold, 1.0);
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const std::size_t c =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(w) + static_cast<std::size_t>(i);
      // The grid's last row is its northern edge, the picture's first.
      std::uint8_t* rgb =
          &picture.rgb[(static_cast<std::size_t>(h - 1 - j) * static_cast<std::size_t>(w) +
                        static_cast<std::size_t>(i)) *
                       3];
      const auto paint = [&](double r, double g, double b) {
        rgb[0] = static_cast<std::uint8_t>(std::clamp(r, 0.0, 255.0));
        rgb[1] = static_cast<std::uint8_t>(std::clamp(g, 0.0, 255.0));
        rgb[2] = static_cast<std::uint8_t>(std::clamp(b, 0.0, 255.0));
      };
      if (d.land[c] == 0) {
        paint(20, 40, 110);  // sea, water and no data
        continue;
      }
      const std::uint8_t wet = grid.wet.empty() ? 0 : grid.wet[c];
      if (wet == kStandingWater) {
        paint(60, 110, 200);
        continue;
      }
      if (wet == kFlowingWater) {
        paint(0, 200, 255);
        continue;
      }
      if (is_pit(grid, d, i, j)) {
        paint(230, 20, 20);
        continue;
      }
      if (d.area[c] >= figures.channel_area) {  // darker blue as the channel drains more
        const double t = std::clamp((std::log10(d.area[c]) - log_threshold) / span, 0.0, 1.0);
        paint(60.0 * (1.0 - t), 150.0 - 110.0 * t, 255.0 - 55.0 * t);
        continue;
      }
      const int i0 = std::max(i - 1, 0), i1 = std::min(i + 1, w - 1);
      const int j0 = std::max(j - 1, 0), j1 = std::min(j + 1, h - 1);
      const double dx = i1 > i0 ? (z(i1, j) - z(i0, j)) / ((i1 - i0) * d.cell_size) : 0.0;
      const double dy = j1 > j0 ? (z(i, j1) - z(i, j0)) / ((j1 - j0) * d.cell_size) : 0.0;
      const double lit =
          (dx - dy + std::numbers::sqrt2) / (2.0 * std::sqrt(1.0 + dx * dx + dy * dy));
      const double grey = std::isfinite(lit) ? 40.0 + 215.0 * std::clamp(lit, 0.0, 1.0) : 0.0;
      paint(grey, grey, grey);
    }
  }
  return picture;
}

std::string_view threshold_rule_name(ChannelThreshold rule) {
  switch (rule) {
    case ChannelThreshold::given:
      return "given";
    case ChannelThreshold::constant_drop:
      return "constant drop";
    case ChannelThreshold::share_of_area:
      return "1% of the area";
  }
  return "";
}

nlohmann::json to_json(const Geomorphometry& g) {
  auto optional = [](const std::optional<double>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
  };
  auto flint = [](const std::optional<FlintFit>& fit) {
    if (!fit) return nlohmann::json(nullptr);
    return nlohmann::json{{"theta", fit->theta},
                          {"k_s", fit->steepness},
                          {"r_squared", fit->r_squared},
                          {"cells", fit->cells}};
  };
  nlohmann::json slope_area = nlohmann::json::array();
  for (const SlopeAreaBin& bin : g.slope_area) {
    slope_area.push_back({{"area_m2", {bin.area_from, bin.area_to}},
                          {"cells", bin.cells},
                          {"channel_cells", bin.channel_cells},
                          {"slope_p10", bin.slope_p10},
                          {"slope_median", bin.slope_median},
                          {"slope_p90", bin.slope_p90}});
  }
  nlohmann::json drops = nlohmann::json::array();
  for (const DropTest& test : g.drop_analysis) {
    drops.push_back(
        {{"area_threshold_m2", test.channel_area},
         {"streams_per_order", test.streams_per_order},
         {"bifurcation_ratio", optional(test.bifurcation_ratio)},
         {"first_order",
          {{"streams", test.first_order_streams}, {"mean_drop_m", test.first_order_mean_drop}}},
         {"higher_order",
          {{"streams", test.higher_order_streams}, {"mean_drop_m", test.higher_order_mean_drop}}},
         {"t", optional(test.t)}});
  }
  return {
      {"grid", {{"width", g.width}, {"height", g.height}, {"cell_size_m", g.cell_size}}},
      {"land_cells", g.land_cells},
      {"wet_cells", g.wet_cells},
      {"pits", {{"count", g.pits}, {"share", g.pit_share}}},
      {"closed_depressions",
       {{"cells", g.depression_cells},
        {"share", g.closed_depression_share},
        {"epsilon_m", g.depression_epsilon}}},
      {"closed_depression_share", g.closed_depression_share},
      {"channels",
       {{"area_threshold_m2", g.channel_area},
        {"threshold_rule", threshold_rule_name(g.channel_threshold)},
        {"cells", g.channel_cells},
        {"edge_fed_cells", g.edge_fed_channel_cells},
        {"length_m", g.channel_length},
        {"max_drainage_area_m2", g.max_drainage_area},
        {"drop_analysis", drops}}},
      {"drainage_density_per_km", g.drainage_density},
      {"flint", flint(g.flint)},
      {"flint_inside", flint(g.flint_inside)},
      {"slope_area", slope_area},
      {"strahler",
       {{"max_order", g.max_strahler_order},
        {"streams_per_order", g.streams_per_order},
        {"bifurcation_ratio", optional(g.bifurcation_ratio)}}},
      {"hypsometric_integral", optional(g.hypsometric_integral)},
      {"elevation_m",
       {{"min", g.min_elevation}, {"mean", g.mean_elevation}, {"max", g.max_elevation}}},
  };
}

}  // namespace terrain
