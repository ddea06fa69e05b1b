// The figures of docs/analysis.md over a routed grid: every sum runs in linear index order in
// double precision, so the same grid gives the same bits.
#include "terrain/geomorphometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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

Status validate(const AnalysisOptions& options) {
  if (!std::isfinite(options.channel_area) || options.channel_area < 0.0) {
    return Error{"must be a finite area in m² (0 for 1% of the grid's area)", "/channel_area"};
  }
  if (!std::isfinite(options.depression_epsilon) || options.depression_epsilon < 0.0) {
    return Error{"must be a finite number of metres, at least 0", "/depression_epsilon"};
  }
  return Ok{};
}

}  // namespace

Result<Geomorphometry> analyze(const ElevationGrid& grid, const AnalysisOptions& options) {
  if (Status valid = validate(options); !valid) return valid.error();
  Result<Drainage> drainage = route_drainage(grid);
  if (!drainage) return drainage.error();
  return analyze(grid, *drainage, options);
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

  Geomorphometry g;
  g.width = w;
  g.height = h;
  g.cell_size = d.cell_size;
  g.depression_epsilon = options.depression_epsilon;
  const double cell_area = d.cell_size * d.cell_size;
  g.channel_area = options.channel_area > 0.0
                       ? options.channel_area
                       : 0.01 * static_cast<double>(w) * static_cast<double>(h) * cell_area;

  // Land, elevation range, pits and closed depressions.
  double sum = 0.0;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
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
      if (i == 0 || j == 0 || i == w - 1 || j == h - 1) continue;  // edge cells are outlets
      bool lower = false;
      for (int k = 0; k < 8 && !lower; ++k) {
        const std::size_t nc =
            static_cast<std::size_t>(j + kD8Dy[k]) * static_cast<std::size_t>(w) +
            static_cast<std::size_t>(i + kD8Dx[k]);
        lower = d.land[nc] == 0 || raw[nc] < raw[c];
      }
      if (!lower) ++g.pits;
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
  std::vector<std::uint8_t> channel(n, 0);
  std::vector<double> log_area, log_slope;
  for (std::size_t c = 0; c < n; ++c) {
    if (d.land[c] == 0 || d.area[c] < g.channel_area) continue;
    channel[c] = 1;
    ++g.channel_cells;
    const std::int32_t r = d.receiver[c];
    if (r < 0) continue;
    const double distance = d8_distance(d, static_cast<std::int32_t>(c), r);
    g.channel_length += distance;
    const double slope =
        (static_cast<double>(raw[c]) - static_cast<double>(raw[static_cast<std::size_t>(r)])) /
        distance;
    // Under standing water the slope is a lake floor's, not a river's.
    const bool standing = !grid.wet.empty() && grid.wet[c] == kStandingWater;
    if (std::isfinite(slope) && slope > 0.0 && !standing) {
      log_area.push_back(std::log10(d.area[c]));
      log_slope.push_back(std::log10(slope));
    }
  }
  if (g.land_cells > 0) {
    g.drainage_density = g.channel_length / (static_cast<double>(g.land_cells) * cell_area) * 1e3;
  }
  if (const std::optional<Line> line = fit_line(log_area, log_slope, 3)) {
    g.flint = FlintFit{-line->slope, std::pow(10.0, line->intercept), line->r_squared,
                       static_cast<std::int64_t>(log_area.size())};
  }

  // Strahler orders; a stream of order ω starts at each channel cell of order ω that no donor
  // of order ω flows into.
  const std::vector<int> strahler = strahler_orders(d.receiver, d.order, channel);
  std::vector<std::uint8_t> continued(n, 0);
  for (std::size_t c = 0; c < n; ++c) {
    const std::int32_t r = d.receiver[c];
    if (channel[c] == 0 || r < 0) continue;
    const auto rc = static_cast<std::size_t>(r);
    if (channel[rc] != 0 && strahler[rc] == strahler[c]) continued[rc] = 1;
  }
  for (std::size_t c = 0; c < n; ++c) {
    if (channel[c] == 0) continue;
    g.max_strahler_order = std::max(g.max_strahler_order, strahler[c]);
  }
  g.streams_per_order.assign(static_cast<std::size_t>(g.max_strahler_order), 0);
  for (std::size_t c = 0; c < n; ++c) {
    if (channel[c] != 0 && continued[c] == 0) {
      ++g.streams_per_order[static_cast<std::size_t>(strahler[c] - 1)];
    }
  }
  if (g.max_strahler_order >= 2) {
    std::vector<double> orders, log_count;
    for (std::size_t k = 0; k < g.streams_per_order.size(); ++k) {
      orders.push_back(static_cast<double>(k + 1));
      log_count.push_back(std::log10(static_cast<double>(g.streams_per_order[k])));
    }
    if (const std::optional<Line> line = fit_line(orders, log_count, 2)) {
      g.bifurcation_ratio = std::pow(10.0, -line->slope);
    }
  }
  return g;
}

nlohmann::json to_json(const Geomorphometry& g) {
  auto optional = [](const std::optional<double>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
  };
  nlohmann::json flint = nullptr;
  if (g.flint) {
    flint = {{"theta", g.flint->theta},
             {"k_s", g.flint->steepness},
             {"r_squared", g.flint->r_squared},
             {"cells", g.flint->cells}};
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
        {"cells", g.channel_cells},
        {"length_m", g.channel_length},
        {"max_drainage_area_m2", g.max_drainage_area}}},
      {"drainage_density_per_km", g.drainage_density},
      {"flint", flint},
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
