// Drainage and geomorphometry (docs/analysis.md) on surfaces with known answers: planes, a bowl,
// cones, a valley built to follow Flint's law, hand-made stream networks, and the CLI.
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "terrain/drainage.hpp"
#include "terrain/geomorphometry.hpp"
#include "terrain/image_io.hpp"

namespace terrain {
namespace {

namespace fs = std::filesystem;

/// A width × height grid of f(i, j).
std::vector<float> make_grid(int width, int height, const std::function<double(int, int)>& f) {
  std::vector<float> z(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (int j = 0; j < height; ++j) {
    for (int i = 0; i < width; ++i) {
      z[static_cast<std::size_t>(j) * static_cast<std::size_t>(width) +
        static_cast<std::size_t>(i)] = static_cast<float>(f(i, j));
    }
  }
  return z;
}

Geomorphometry analyze_or_die(const ElevationGrid& grid, const AnalysisOptions& options = {}) {
  Result<Geomorphometry> g = analyze(grid, options);
  EXPECT_TRUE(g.ok()) << (g.ok() ? "" : g.error().pointer + ": " + g.error().message);
  return g.ok() ? std::move(g).value() : Geomorphometry{};
}

Drainage route_or_die(const ElevationGrid& grid) {
  Result<Drainage> d = route_drainage(grid);
  EXPECT_TRUE(d.ok()) << (d.ok() ? "" : d.error().pointer + ": " + d.error().message);
  return d.ok() ? std::move(d).value() : Drainage{};
}

/// Where water from cell c leaves the grid: the last cell of its receiver chain.
std::int32_t outlet_of(const Drainage& d, std::int32_t c) {
  for (std::size_t steps = 0; steps <= d.cells(); ++steps) {
    const std::int32_t r = d.receiver[static_cast<std::size_t>(c)];
    if (r < 0) return c;
    c = r;
  }
  return -2;  // a cycle
}

TEST(Geomorphometry, AnInclinedPlaneHasNoPitsAndEveryCellReachesTheEdge) {
  const int w = 60, h = 40;
  const std::vector<float> z = make_grid(w, h, [](int i, int j) { return 3.0 * i + 1.0 * j; });
  const ElevationGrid grid{w, h, 10.0, z};
  const Geomorphometry g = analyze_or_die(grid);
  EXPECT_EQ(g.land_cells, w * h);
  EXPECT_EQ(g.pits, 0);
  EXPECT_EQ(g.depression_cells, 0);
  EXPECT_EQ(g.closed_depression_share, 0.0);
  ASSERT_TRUE(g.hypsometric_integral.has_value());
  EXPECT_NEAR(*g.hypsometric_integral, 0.5, 1e-6);

  // Mass balance: what the edge cells collect is the whole grid's area.
  const Drainage d = route_or_die(grid);
  double collected = 0.0;
  for (std::size_t c = 0; c < d.cells(); ++c) {
    if (d.receiver[c] < 0) collected += d.area[c];
    EXPECT_GE(outlet_of(d, static_cast<std::int32_t>(c)), 0) << "cell " << c;
  }
  EXPECT_DOUBLE_EQ(collected, w * h * 100.0);
}

TEST(Geomorphometry, ABowlIsOneClosedDepressionFilledToItsSpillLevel) {
  const int n = 41, centre = 20;
  const std::vector<float> z = make_grid(
      n, n, [](int i, int j) { return (i - centre) * (i - centre) + (j - centre) * (j - centre); });
  const ElevationGrid grid{n, n, 5.0, z};
  const Geomorphometry g = analyze_or_die(grid);
  EXPECT_EQ(g.pits, 1);  // the centre
  // The lowest edge cell is the middle of a side, 20² above the centre: the bowl fills to it.
  const double spill = centre * centre;
  const Drainage d = route_or_die(grid);
  std::int64_t expected = 0;
  for (std::size_t c = 0; c < z.size(); ++c) {
    if (spill - z[c] > 1e-3) ++expected;
    EXPECT_NEAR(d.filled[c], std::max<double>(z[c], spill), 1e-6) << "cell " << c;
  }
  EXPECT_GT(expected, 1000);
  EXPECT_EQ(g.depression_cells, expected);
  EXPECT_DOUBLE_EQ(g.closed_depression_share, static_cast<double>(expected) / (n * n));
  // Filled, the bowl still drains: every cell reaches the edge.
  for (std::size_t c = 0; c < d.cells(); ++c) {
    EXPECT_GE(outlet_of(d, static_cast<std::int32_t>(c)), 0) << "cell " << c;
  }
}

TEST(Geomorphometry, AConeHasNoPitsAndNoDepressions) {
  const int n = 51, centre = 25;
  const std::vector<float> z = make_grid(
      n, n, [](int i, int j) { return 1000.0 - 20.0 * std::hypot(i - centre, j - centre); });
  const Geomorphometry g = analyze_or_die({n, n, 20.0, z});
  EXPECT_EQ(g.pits, 0);
  EXPECT_EQ(g.depression_cells, 0);
}

TEST(Geomorphometry, AnInvertedConeDrainsThroughItsOneOutlet) {
  // The centre has no data: the one outlet every interior cell drains to.
  const int n = 41, centre = 20;
  std::vector<float> z = make_grid(
      n, n, [](int i, int j) { return 100.0 + 10.0 * std::hypot(i - centre, j - centre); });
  const auto outlet = static_cast<std::int32_t>(centre * n + centre);
  z[static_cast<std::size_t>(outlet)] = std::numeric_limits<float>::quiet_NaN();
  const ElevationGrid grid{n, n, 10.0, z};
  const Geomorphometry g = analyze_or_die(grid);
  EXPECT_EQ(g.land_cells, n * n - 1);
  EXPECT_EQ(g.pits, 0);
  EXPECT_EQ(g.depression_cells, 0);
  const Drainage d = route_or_die(grid);
  for (int j = 1; j + 1 < n; ++j) {
    for (int i = 1; i + 1 < n; ++i) {
      EXPECT_EQ(outlet_of(d, j * n + i), outlet) << "cell " << i << ", " << j;
    }
  }
}

TEST(Geomorphometry, SeaAndNoDataAreNotLandAndActAsOutlets) {
  // A ramp rising from the sea at x < 10, with a hole of no data in the land.
  const int w = 30, h = 20;
  std::vector<float> z = make_grid(w, h, [](int i, int) { return 2.0 * (i - 10) + 1.0; });
  z[static_cast<std::size_t>(10 * w + 20)] = std::numeric_limits<float>::quiet_NaN();
  const ElevationGrid grid{w, h, 1.0, z, 0.0f};
  const Geomorphometry g = analyze_or_die(grid);
  EXPECT_EQ(g.land_cells, (w - 10) * h - 1);
  EXPECT_EQ(g.pits, 0);
  EXPECT_DOUBLE_EQ(g.min_elevation, 1.0);
  const Drainage d = route_or_die(grid);
  for (std::size_t c = 0; c < d.cells(); ++c) {
    EXPECT_EQ(d.area[c] > 0.0, d.land[c] != 0);
  }
  // A water mask takes cells out of the land the same way.
  std::vector<std::uint8_t> water(z.size(), 0);
  water[static_cast<std::size_t>(5 * w + 25)] = 1;
  const Geomorphometry masked = analyze_or_die({w, h, 1.0, z, 0.0f, water});
  EXPECT_EQ(masked.land_cells, g.land_cells - 1);
}

// A straight valley up the middle column of a grid, hillslopes rising at slope 1 on either side
// draining straight into it, so valley cell j (rows 1..H−2; rows 0 and H−1 are the edge) drains
// A_j = (W − 2)(H − 1 − j) cells. Its bed descends by S_j = k_s · A_j^−θ per cell length: a
// stream-power surface in equilibrium (S = (U/K)^(1/n) A^(−m/n)).
struct StreamPowerValley {
  static constexpr int w = 41, h = 301, valley = 20;
  static constexpr double cell = 30.0, theta = 0.45, k_s = 20.0;
  static double area(int j) { return (w - 2) * (h - 1 - std::min(j, h - 2)) * cell * cell; }
  std::vector<float> z = [] {
    std::vector<double> bed(h, 0.0);
    for (int j = 1; j < h; ++j) bed[j] = bed[j - 1] + cell * k_s * std::pow(area(j), -theta);
    return make_grid(w, h, [&](int i, int j) { return bed[j] + cell * std::abs(i - valley); });
  }();
  ElevationGrid grid() const { return {w, h, cell, z}; }
};

TEST(Geomorphometry, ASyntheticStreamPowerSurfaceFollowsFlintsLaw) {
  const StreamPowerValley surface;
  const auto [w, h, valley] = std::tuple{surface.w, surface.h, surface.valley};
  const auto [cell, theta, k_s] = std::tuple{surface.cell, surface.theta, surface.k_s};
  const auto area = StreamPowerValley::area;
  const ElevationGrid grid = surface.grid();

  const Drainage d = route_or_die(grid);
  for (int j = 1; j + 1 < h; ++j) {
    EXPECT_DOUBLE_EQ(d.area[static_cast<std::size_t>(j * w + valley)], area(j)) << "row " << j;
  }
  AnalysisOptions options;
  options.channel_area = area(h - 4);  // valley cells of rows 1..H−4: hillslopes drain far less
  const Geomorphometry g = analyze_or_die(grid, options);
  EXPECT_EQ(g.pits, 0);
  EXPECT_EQ(g.channel_cells, h - 3);  // rows 0..H−4; row 0 is an outlet, out of the fit
  ASSERT_TRUE(g.flint.has_value());
  EXPECT_EQ(g.flint->cells, h - 4);
  EXPECT_NEAR(g.flint->theta, theta, 2e-3);
  EXPECT_NEAR(g.flint->steepness, k_s, 0.02 * k_s);
  EXPECT_GT(g.flint->r_squared, 0.9999);
  // One unbranched stream.
  EXPECT_EQ(g.max_strahler_order, 1);
  EXPECT_EQ(g.streams_per_order, std::vector<std::int64_t>{1});
  EXPECT_FALSE(g.bifurcation_ratio.has_value());
  EXPECT_NEAR(g.channel_length, (h - 4) * cell, 1e-9);
  EXPECT_NEAR(g.drainage_density, (h - 4) * cell / (w * h * cell * cell) * 1e3, 1e-12);
}

// The slope–area profile of the same valley: the bins its channel cells fill follow
// S = k_s·A^−θ (each bin's median within the spread of the curve over the bin), slopes fall
// bin by bin, and every cell with a receiver is in exactly one bin.
TEST(Geomorphometry, TheSlopeAreaProfileOfAStreamPowerValleyFallsAsFlintsLawSays) {
  const StreamPowerValley surface;
  const auto [w, h, theta, k_s] = std::tuple{surface.w, surface.h, surface.theta, surface.k_s};
  AnalysisOptions options;
  options.channel_area = StreamPowerValley::area(h - 4);
  const Geomorphometry g = analyze_or_die(surface.grid(), options);

  ASSERT_FALSE(g.slope_area.empty());
  std::int64_t cells = 0, channel_cells = 0;
  for (std::size_t b = 0; b < g.slope_area.size(); ++b) {
    const SlopeAreaBin& bin = g.slope_area[b];
    cells += bin.cells;
    channel_cells += bin.channel_cells;
    EXPECT_NEAR(bin.area_to / bin.area_from, std::pow(10.0, 0.25), 1e-9);
    if (b > 0) {
      EXPECT_GT(bin.area_from, g.slope_area[b - 1].area_from);
    }
    EXPECT_LE(bin.slope_p10, bin.slope_median);
    EXPECT_LE(bin.slope_median, bin.slope_p90);
  }
  EXPECT_EQ(cells, (w - 2) * (h - 2));  // every cell but the outlets on the grid's edge
  EXPECT_EQ(channel_cells, g.flint->cells);
  // The bins of valley cells alone (areas beyond the hillslopes', which drain at most a row).
  int valley_bins = 0;
  double previous = std::numeric_limits<double>::infinity();
  for (const SlopeAreaBin& bin : g.slope_area) {
    if (bin.area_from < options.channel_area) continue;
    ++valley_bins;
    EXPECT_EQ(bin.channel_cells, bin.cells);
    EXPECT_LE(bin.slope_median, k_s * std::pow(bin.area_from, -theta) * 1.01);
    EXPECT_GE(bin.slope_median, k_s * std::pow(bin.area_to, -theta) * 0.99);
    EXPECT_LT(bin.slope_median, previous);
    previous = bin.slope_median;
  }
  EXPECT_GE(valley_bins, 5);
}

// On a plane every cell has the same slope, whatever it drains: a flat profile (what the
// planets' land between rivers measured at zoom 11, docs/analysis.md).
TEST(Geomorphometry, AnInclinedPlaneHasTheSameSlopeInEveryBin) {
  const int w = 60, h = 40;
  const std::vector<float> z = make_grid(w, h, [](int, int j) { return 2.0 * j; });
  const Geomorphometry g = analyze_or_die({w, h, 10.0, z});
  ASSERT_GE(g.slope_area.size(), 3u);
  for (const SlopeAreaBin& bin : g.slope_area) {
    EXPECT_DOUBLE_EQ(bin.slope_p10, 0.2);
    EXPECT_DOUBLE_EQ(bin.slope_p90, 0.2);
  }
}

// Water from beyond the grid enters where an edge cell's steepest descent in the grid is a cell
// inside: here only the middle of the north edge, which passes it down the valley column. The
// edge cells beside it fall more steeply along the edge, and the rest of the edge is lower than
// the land inside, so nothing else is edge-fed.
TEST(Geomorphometry, WaterFromBeyondEntersWhereAnEdgeCellFallsInward) {
  const int w = 5, h = 6;
  const std::vector<float> z = make_grid(w, h, [](int i, int j) -> double {
    if (j == h - 1) return i == 2 ? 100.0 : (i == 1 || i == 3) ? 95.0 : 0.0;
    if (i == 0 || j == 0 || i == w - 1) return 0.0;
    return i == 2 ? 10.0 + j : 50.0;
  });
  const std::vector<std::uint8_t> fed = edge_fed(route_or_die({w, h, 10.0, z}));
  std::vector<std::uint8_t> expected(z.size(), 0);
  for (int j = 1; j <= 4; ++j) expected[static_cast<std::size_t>(j * w + 2)] = 1;
  EXPECT_EQ(fed, expected);
}

// A valley whose head the grid's edge cuts off: every channel cell inside is edge-fed, so
// Flint's fit over the channels that begin inside has no cell.
TEST(Geomorphometry, AValleyTheEdgeCutsOffIsEdgeFedAllTheWayDown) {
  const StreamPowerValley surface;
  AnalysisOptions options;
  options.channel_area = StreamPowerValley::area(surface.h - 4);
  const Geomorphometry g = analyze_or_die(surface.grid(), options);
  ASSERT_TRUE(g.flint.has_value());
  // Rows 1..H−4 of the valley; row 0 is an edge cell, an outlet, never edge-fed.
  EXPECT_EQ(g.edge_fed_channel_cells, surface.h - 4);
  EXPECT_FALSE(g.flint_inside.has_value());
}

// A basin rising to the grid's edge takes in whatever the land beyond sends it; a cone falling
// to the edge takes in nothing, so its fit without edge-fed channels is its fit.
TEST(Geomorphometry, ABasinRisingToTheEdgeIsEdgeFedAndAConeIsNot) {
  const int n = 41, centre = 20;
  std::vector<float> basin = make_grid(
      n, n, [](int i, int j) { return 100.0 + 10.0 * std::hypot(i - centre, j - centre); });
  basin[static_cast<std::size_t>(centre * n + centre)] = std::numeric_limits<float>::quiet_NaN();
  const Drainage d = route_or_die({n, n, 10.0, basin});
  const std::vector<std::uint8_t> fed = edge_fed(d);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const bool inside = i > 0 && j > 0 && i < n - 1 && j < n - 1;
      const auto c = static_cast<std::size_t>(j * n + i);
      // Inside: every land cell drains to the centre past cells the edge feeds.
      EXPECT_EQ(fed[c], inside && d.land[c] != 0 ? 1 : 0) << "cell " << i << ", " << j;
    }
  }

  const std::vector<float> cone = make_grid(
      n, n, [](int i, int j) { return 1000.0 - 20.0 * std::hypot(i - centre, j - centre); });
  AnalysisOptions options;
  options.channel_area = 3 * 20.0 * 20.0;
  const Geomorphometry g = analyze_or_die({n, n, 20.0, cone}, options);
  EXPECT_EQ(g.edge_fed_channel_cells, 0);
  ASSERT_TRUE(g.flint.has_value());
  ASSERT_TRUE(g.flint_inside.has_value());
  EXPECT_EQ(g.flint_inside->cells, g.flint->cells);
  EXPECT_EQ(g.flint_inside->theta, g.flint->theta);
  EXPECT_EQ(g.flint_inside->r_squared, g.flint->r_squared);
}

// The picture: a plane falling west with a one-cell pit, a river cell, a lake cell and a sea
// column on its west edge; channels are the cells draining at least five cells' area.
TEST(Geomorphometry, TheDrainagePictureShowsPitsChannelsWaterAndSeaNorthUp) {
  constexpr int w = 20, h = 12;
  std::vector<float> z = make_grid(w, h, [](int i, int j) { return 0.1 * i + 0.001 * j; });
  const auto at = [](int i, int j) { return static_cast<std::size_t>(j * w + i); };
  z[at(12, 6)] -= 5.0f;  // the pit
  std::vector<std::uint8_t> sea(z.size(), 0), wet(z.size(), 0);
  for (int j = 0; j < h; ++j) sea[at(0, j)] = 1;
  wet[at(15, 2)] = kFlowingWater;
  wet[at(15, 9)] = kStandingWater;
  const ElevationGrid grid{w, h, 1.0, z, std::nullopt, sea, wet};
  AnalysisOptions options;
  options.channel_area = 5.0;
  AnalysisPicture picture;
  const Result<Geomorphometry> g = analyze(grid, options, &picture);
  ASSERT_TRUE(g.ok());
  EXPECT_EQ(g->pits, 1);
  ASSERT_EQ(picture.width, w);
  ASSERT_EQ(picture.height, h);
  ASSERT_EQ(picture.rgb.size(), static_cast<std::size_t>(w * h * 3));
  // Grid row j is picture row h − 1 − j.
  const auto pixel = [&](int i, int j) {
    const std::size_t k =
        (static_cast<std::size_t>(h - 1 - j) * w + static_cast<std::size_t>(i)) * 3;
    return std::array<int, 3>{picture.rgb[k], picture.rgb[k + 1], picture.rgb[k + 2]};
  };
  EXPECT_EQ(pixel(12, 6), (std::array<int, 3>{230, 20, 20}));
  EXPECT_EQ(pixel(0, 0), (std::array<int, 3>{20, 40, 110}));
  EXPECT_EQ(pixel(15, 2), (std::array<int, 3>{0, 200, 255}));
  EXPECT_EQ(pixel(15, 9), (std::array<int, 3>{60, 110, 200}));
  // West of column 16 every interior row has drained five cells: channels, blue.
  const std::array<int, 3> channel = pixel(3, 4), hillslope = pixel(18, 4);
  EXPECT_GT(channel[2], channel[0]);
  EXPECT_GT(channel[2], channel[1]);
  EXPECT_EQ(hillslope[0], hillslope[1]);
  EXPECT_EQ(hillslope[1], hillslope[2]);
  // The same picture as drawing the figures of a routing made apart.
  EXPECT_EQ(draw_drainage(grid, route_or_die(grid), *g).rgb, picture.rgb);
}

// The same valley: its one stream leaves by the grid's edge, which cuts its drop, so no
// candidate of the drop analysis has a complete stream and the threshold falls back to 1%.
TEST(Geomorphometry, AStreamTheGridsEdgeCutsOffHasNoDrop) {
  const int w = 41, h = 301, valley = 20;
  const double cell = 30.0;
  const std::vector<float> z =
      make_grid(w, h, [&](int i, int j) { return 3.0 * j + cell * std::abs(i - valley); });
  const Geomorphometry g = analyze_or_die({w, h, cell, z});
  ASSERT_EQ(g.drop_analysis.size(), 16u);
  for (const DropTest& test : g.drop_analysis) {
    EXPECT_EQ(test.streams_per_order, std::vector<std::int64_t>{1}) << test.channel_area;
    EXPECT_EQ(test.first_order_streams, 0);
    EXPECT_FALSE(test.t.has_value());
  }
  EXPECT_EQ(g.channel_threshold, ChannelThreshold::share_of_area);
  EXPECT_DOUBLE_EQ(g.channel_area, 0.01 * w * h * cell * cell);
}

// The valley again, ending in a sea three rows deep: its stream is complete, and drops from
// the highest valley cell draining a candidate's area to the sea cell it flows into.
TEST(Geomorphometry, AStreamEndingInTheSeaDropsFromItsHeadToTheSea) {
  const int w = 41, h = 301, valley = 20;
  const double cell = 30.0, sea_floor = -5.0;
  // A bed falling a tenth of the hillslopes' fall per cell: they drain straight across into it.
  auto bed = [&](int j) { return 3.0 * (j - 2); };
  const std::vector<float> z = make_grid(w, h, [&](int i, int j) {
    return j <= 2 ? sea_floor : bed(j) + cell * std::abs(i - valley);
  });
  const Geomorphometry g = analyze_or_die({w, h, cell, z, 0.0f});
  ASSERT_EQ(g.drop_analysis.size(), 16u);
  // Candidates from 25 cells to 5% of the grid's area, evenly spaced in log.
  const double cell_area = cell * cell;
  EXPECT_DOUBLE_EQ(g.drop_analysis.front().channel_area, 25 * cell_area);
  EXPECT_NEAR(g.drop_analysis.back().channel_area, 0.05 * w * h * cell_area, 1e-6);
  const double step = g.drop_analysis[1].channel_area / g.drop_analysis[0].channel_area;
  for (std::size_t k = 1; k < g.drop_analysis.size(); ++k) {
    EXPECT_NEAR(g.drop_analysis[k].channel_area / g.drop_analysis[k - 1].channel_area, step, 1e-9);
  }
  for (const DropTest& test : g.drop_analysis) {
    // Valley cell j drains its own row and every row above it but the edge's: (W − 2)(H − 1 − j)
    // cells; the hillslopes drain at most 20 cells each.
    int head = h - 2;
    while ((w - 2) * (h - 1 - head) * cell_area < test.channel_area) --head;
    ASSERT_GE(head, 3);
    EXPECT_EQ(test.streams_per_order, std::vector<std::int64_t>{1}) << test.channel_area;
    EXPECT_EQ(test.first_order_streams, 1);
    EXPECT_NEAR(test.first_order_mean_drop, bed(head) - sea_floor, 1e-9) << test.channel_area;
    EXPECT_EQ(test.higher_order_streams, 0);
    EXPECT_FALSE(test.t.has_value());  // one stream is no sample
  }
}

// A window analyses its cells as a grid of their own, but with the drainage routed over the
// whole grid: the stream-power valley's rows in the middle third keep the areas of every row
// above them, and Flint's fit over them finds the valley's θ. Cut out as a grid of its own, the
// same rows drain only themselves, and the fit is off.
TEST(Geomorphometry, AWindowKeepsTheAreaDrainedFromBeyondIt) {
  const StreamPowerValley surface;
  const auto [w, h, theta] = std::tuple{surface.w, surface.h, surface.theta};
  const int top = 2 * h / 3, bottom = h / 3;
  AnalysisOptions options;
  options.channel_area = StreamPowerValley::area(top);  // the valley's cells in the window
  options.window = AnalysisWindow{0, bottom, w, top};
  const Geomorphometry g = analyze_or_die(surface.grid(), options);
  EXPECT_EQ(g.width, w);
  EXPECT_EQ(g.height, top - bottom);
  EXPECT_EQ(g.land_cells, std::int64_t{w} * (top - bottom));
  EXPECT_EQ(g.channel_cells, top - bottom);
  ASSERT_TRUE(g.flint.has_value());
  EXPECT_EQ(g.flint->cells, top - bottom);
  EXPECT_NEAR(g.flint->theta, theta, 2e-3);
  EXPECT_GT(g.flint->r_squared, 0.9999);

  const std::vector<float> rows(surface.z.begin() + std::ptrdiff_t{bottom} * w,
                                surface.z.begin() + std::ptrdiff_t{top} * w);
  AnalysisOptions cut;
  cut.channel_area = 5 * (w - 2) * surface.cell * surface.cell;
  const Geomorphometry alone = analyze_or_die({w, top - bottom, surface.cell, rows}, cut);
  ASSERT_TRUE(alone.flint.has_value());
  EXPECT_GT(std::abs(alone.flint->theta - theta), 0.1) << alone.flint->theta;
}

// A stream that leaves the window is cut off there, as the grid's edge cuts one: the valley
// that ends in the sea has a complete stream, but not in a window that leaves the sea out.
TEST(Geomorphometry, AStreamLeavingTheWindowHasNoDrop) {
  const int w = 41, h = 301, valley = 20;
  const double cell = 30.0;
  const std::vector<float> z = make_grid(w, h, [&](int i, int j) {
    return j <= 2 ? -5.0 : 3.0 * (j - 2) + cell * std::abs(i - valley);
  });
  AnalysisOptions options;
  options.window = AnalysisWindow{0, 10, w, h};
  const Geomorphometry g = analyze_or_die({w, h, cell, z, 0.0f}, options);
  ASSERT_EQ(g.drop_analysis.size(), 16u);
  // Candidates from 25 cells to 5% of the window's area.
  EXPECT_NEAR(g.drop_analysis.back().channel_area, 0.05 * w * (h - 10) * cell * cell, 1e-6);
  for (const DropTest& test : g.drop_analysis) {
    EXPECT_EQ(test.streams_per_order, std::vector<std::int64_t>{1}) << test.channel_area;
    EXPECT_EQ(test.first_order_streams, 0) << test.channel_area;
  }
  EXPECT_EQ(g.channel_threshold, ChannelThreshold::share_of_area);
}

/// A drop analysis table whose candidates have these t statistics (none: untested).
std::vector<DropTest> drop_table(const std::vector<std::optional<double>>& t) {
  std::vector<DropTest> table(t.size());
  for (std::size_t k = 0; k < t.size(); ++k) {
    table[k].channel_area = 100.0 * static_cast<double>(k + 1);
    table[k].t = t[k];
  }
  return table;
}

TEST(Geomorphometry, TheDropAnalysisChoosesTheSmallestThresholdFromWhichTheDropStaysConstant) {
  using T = std::optional<double>;
  // 1.6 passes only where t crosses zero between two failures.
  EXPECT_EQ(constant_drop_threshold(drop_table({3.3, 1.6, -3.1, -0.3, T{}, 0.1, 1.9, T{}})), 400.0);
  EXPECT_EQ(constant_drop_threshold(drop_table({-1.0, 0.5})), 100.0);
  // The largest testable candidate fails, or none can be tested: no choice.
  EXPECT_EQ(constant_drop_threshold(drop_table({-0.3, 0.2, -2.5, T{}})), std::nullopt);
  EXPECT_EQ(constant_drop_threshold(drop_table({T{}, T{}})), std::nullopt);
  EXPECT_EQ(constant_drop_threshold({}), std::nullopt);
}

TEST(Geomorphometry, AConfluenceOfTwoFirstOrderStreamsHasOrderTwo) {
  // 0 ─┐
  //    2 ── 3 ── outlet      (a Y)
  // 1 ─┘
  const std::vector<std::int32_t> receiver{2, 2, 3, -1};
  const std::vector<std::int32_t> order{3, 2, 0, 1};  // receivers first
  const std::vector<std::uint8_t> channel{1, 1, 1, 1};
  EXPECT_EQ(strahler_orders(receiver, order, channel), (std::vector<int>{1, 1, 2, 2}));
}

TEST(Geomorphometry, AFirstOrderTributaryDoesNotRaiseASecondOrderStream) {
  // The Y above, then a first-order stream 4 joins at 3; cell 5 is not a channel.
  const std::vector<std::int32_t> receiver{2, 2, 3, -1, 3, 4};
  const std::vector<std::int32_t> order{3, 2, 4, 5, 0, 1};
  const std::vector<std::uint8_t> channel{1, 1, 1, 1, 1, 0};
  EXPECT_EQ(strahler_orders(receiver, order, channel), (std::vector<int>{1, 1, 2, 2, 1, 0}));
}

TEST(Geomorphometry, TwoSecondOrderStreamsMakeOrderThree) {
  // Two Ys (0, 1 → 2 and 3, 4 → 5) meeting at 6.
  const std::vector<std::int32_t> receiver{2, 2, 6, 5, 5, 6, -1};
  const std::vector<std::int32_t> order{6, 5, 2, 4, 3, 1, 0};
  const std::vector<std::uint8_t> channel(7, 1);
  EXPECT_EQ(strahler_orders(receiver, order, channel), (std::vector<int>{1, 1, 2, 1, 1, 2, 3}));
}

/// Rough, deterministic terrain: integer-hashed noise on a tilted plane, full of pits.
std::vector<float> rough_surface(int w, int h) {
  return make_grid(w, h, [](int i, int j) {
    std::uint32_t x =
        static_cast<std::uint32_t>(i) * 73856093u ^ static_cast<std::uint32_t>(j) * 19349663u;
    x ^= x >> 13;
    x *= 0x5bd1e995u;
    x ^= x >> 15;
    return 0.5 * i + 0.2 * j + 8.0 * (x & 0xffffu) / 65535.0;
  });
}

TEST(Geomorphometry, TheSameGridGivesTheSameBits) {
  const int w = 97, h = 83;
  const std::vector<float> z = rough_surface(w, h);
  const ElevationGrid grid{w, h, 12.5, z};
  const Drainage a = route_or_die(grid);
  const Drainage b = route_or_die(grid);
  ASSERT_EQ(a.cells(), b.cells());
  EXPECT_EQ(std::memcmp(a.filled.data(), b.filled.data(), a.cells() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(a.area.data(), b.area.data(), a.cells() * sizeof(double)), 0);
  EXPECT_EQ(a.receiver, b.receiver);
  EXPECT_EQ(a.order, b.order);
  const Geomorphometry g = analyze_or_die(grid);
  EXPECT_EQ(to_json(g).dump(), to_json(analyze_or_die(grid)).dump());
  // And the figures are sane: rough noise has pits and depressions, every cell still drains.
  EXPECT_GT(g.pits, 0);
  EXPECT_GT(g.closed_depression_share, 0.0);
  EXPECT_LT(g.closed_depression_share, 1.0);
  for (std::size_t c = 0; c < a.cells(); ++c) {
    EXPECT_GE(outlet_of(a, static_cast<std::int32_t>(c)), 0);
  }
}

// A window of the whole grid is no window.
TEST(Geomorphometry, AWindowOfTheWholeGridChangesNothing) {
  const int w = 64, h = 48;
  const std::vector<float> z = rough_surface(w, h);  // the grid holds a view of it
  const ElevationGrid grid{w, h, 25.0, z};
  AnalysisOptions whole;
  whole.window = AnalysisWindow{0, 0, w, h};
  EXPECT_EQ(to_json(analyze_or_die(grid, whole)), to_json(analyze_or_die(grid)));
}

TEST(Geomorphometry, MalformedInputIsRefusedNamingTheField) {
  const std::vector<float> z(16, 1.0f);
  const std::vector<std::uint8_t> short_water(3, 0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    ElevationGrid grid;
    AnalysisOptions options;
    const char* pointer;
  };
  AnalysisOptions negative_area, nan_epsilon, empty_window, window_beyond;
  negative_area.channel_area = -1.0;
  nan_epsilon.depression_epsilon = std::nan("");
  empty_window.window = AnalysisWindow{1, 1, 1, 3};
  window_beyond.window = AnalysisWindow{0, 0, 4, 5};
  const Case cases[] = {
      {{0, 4, 1.0, z}, {}, "/width"},
      {{4, 0, 1.0, z}, {}, "/height"},
      {{-3, 4, 1.0, z}, {}, "/width"},
      {{kMaxGridSide + 1, 1, 1.0, z}, {}, "/width"},
      {{kMaxGridSide, kMaxGridSide, 1.0, z}, {}, "/width"},  // more than kMaxGridCells
      {{4, 4, 0.0, z}, {}, "/cell_size"},
      {{4, 4, -2.0, z}, {}, "/cell_size"},
      {{4, 4, std::nan(""), z}, {}, "/cell_size"},
      {{4, 4, inf, z}, {}, "/cell_size"},
      {{4, 5, 1.0, z}, {}, "/elevation"},
      {{4, 4, 1.0, z, std::nullopt, short_water}, {}, "/water"},
      {{4, 4, 1.0, z, nan}, {}, "/sea_level"},
      {{4, 4, 1.0, z}, negative_area, "/channel_area"},
      {{4, 4, 1.0, z}, nan_epsilon, "/depression_epsilon"},
      {{4, 4, 1.0, z}, empty_window, "/window"},
      {{4, 4, 1.0, z}, window_beyond, "/window"},
  };
  for (const Case& c : cases) {
    const Result<Geomorphometry> g = analyze(c.grid, c.options);
    ASSERT_FALSE(g.ok()) << c.pointer;
    EXPECT_EQ(g.error().pointer, c.pointer) << g.error().message;
    EXPECT_EQ(g.error().kind, ErrorKind::invalid);
    EXPECT_FALSE(g.error().message.empty());
  }
  // Degenerate but valid: one cell, all sea, all flat.
  EXPECT_TRUE(analyze({1, 1, 1.0, std::span<const float>(z).first(1)}).ok());
  const Geomorphometry sea = analyze_or_die({4, 4, 1.0, z, 5.0f});
  EXPECT_EQ(sea.land_cells, 0);
  EXPECT_FALSE(sea.hypsometric_integral.has_value());
  EXPECT_TRUE(to_json(sea)["hypsometric_integral"].is_null());
  const Geomorphometry flat = analyze_or_die({4, 4, 1.0, z});
  EXPECT_EQ(flat.pits, 4);  // the interior cells have no lower neighbour
}

// ---------------------------------------------------------------------------------------------
// The CLI

const fs::path kScenes = fs::path(TERRAIN_SOURCE_DIR) / "config" / "scenes";

/// Runs the CLI with `arguments`, returning its exit status and stdout.
std::pair<int, std::string> run_cli(const std::string& arguments) {
  const fs::path out =
      fs::temp_directory_path() / ("terrain-analyze-" + std::to_string(::getpid()) + ".json");
  const std::string command =
      std::string(TERRAIN_CLI) + " " + arguments + " > " + out.string() + " 2> /dev/null";
  const int status = std::system(command.c_str());
  std::ifstream in(out);
  std::stringstream text;
  text << in.rdbuf();
  fs::remove(out);
  return {status, text.str()};
}

void expect_sane_figures(const nlohmann::json& j, int size) {
  EXPECT_EQ(j["grid"]["width"], size);
  EXPECT_EQ(j["grid"]["height"], size);
  EXPECT_GT(j["grid"]["cell_size_m"].get<double>(), 0.0);
  const auto land = j["land_cells"].get<std::int64_t>();
  EXPECT_GT(land, 0);
  EXPECT_LE(land, std::int64_t{size} * size);
  for (const auto& share : {j["pits"]["share"], j["closed_depression_share"]}) {
    EXPECT_GE(share.get<double>(), 0.0);
    EXPECT_LE(share.get<double>(), 1.0);
  }
  EXPECT_EQ(j["closed_depression_share"], j["closed_depressions"]["share"]);
  EXPECT_GE(j["drainage_density_per_km"].get<double>(), 0.0);
  EXPECT_GT(j["channels"]["cells"].get<std::int64_t>(), 0);
  const int order = j["strahler"]["max_order"];
  EXPECT_GE(order, 1);
  EXPECT_EQ(j["strahler"]["streams_per_order"].size(), static_cast<std::size_t>(order));
  EXPECT_TRUE(j["strahler"].contains("bifurcation_ratio"));
  ASSERT_TRUE(j["flint"].is_object());
  EXPECT_GE(j["flint"]["r_squared"].get<double>(), 0.0);
  EXPECT_LE(j["flint"]["r_squared"].get<double>(), 1.0);
  EXPECT_TRUE(std::isfinite(j["flint"]["theta"].get<double>()));
  EXPECT_GT(j["flint"]["cells"].get<std::int64_t>(), 0);
  // Edge-fed channels are some of the channels, and the fit without them has fewer cells.
  EXPECT_GE(j["channels"]["edge_fed_cells"].get<std::int64_t>(), 0);
  EXPECT_LE(j["channels"]["edge_fed_cells"], j["channels"]["cells"]);
  if (!j["flint_inside"].is_null()) {
    EXPECT_GE(j["flint_inside"]["r_squared"].get<double>(), 0.0);
    EXPECT_LE(j["flint_inside"]["r_squared"].get<double>(), 1.0);
    EXPECT_LE(j["flint_inside"]["cells"], j["flint"]["cells"]);
  }
  ASSERT_TRUE(j["hypsometric_integral"].is_number());
  EXPECT_GE(j["hypsometric_integral"].get<double>(), 0.0);
  EXPECT_LE(j["hypsometric_integral"].get<double>(), 1.0);
}

TEST(Geomorphometry, TheCliAnalyzesAnExampleScene) {
  const auto [status, text] =
      run_cli("analyze " + (kScenes / "hills-river.json").string() + " --size 128");
  ASSERT_EQ(status, 0);
  const nlohmann::json j = nlohmann::json::parse(text);
  expect_sane_figures(j, 128);
  EXPECT_EQ(j["input"]["kind"], "scene");
  EXPECT_EQ(j["input"]["water_cells"], 0);
  ASSERT_FALSE(j["slope_area"].empty());
  // --picture writes the drainage picture: a PNG of the grid's size.
  const fs::path png =
      fs::temp_directory_path() / ("terrain-analyze-" + std::to_string(::getpid()) + ".png");
  ASSERT_EQ(run_cli("analyze " + (kScenes / "hills-river.json").string() + " --size 96 --picture " +
                    png.string())
                .first,
            0);
  const Result<Raster> picture = read_heightfield(png.string());
  fs::remove(png);
  ASSERT_TRUE(picture.ok());
  EXPECT_EQ(picture->width, 96);
  EXPECT_EQ(picture->height, 96);
  // No --channel-area: the drop analysis chose one of its candidates, or fell back to 1%.
  const nlohmann::json& channels = j["channels"];
  ASSERT_EQ(channels["drop_analysis"].size(), 16u);
  if (channels["threshold_rule"] == "constant drop") {
    bool candidate = false;
    for (const auto& row : channels["drop_analysis"]) {
      candidate = candidate || row["area_threshold_m2"] == channels["area_threshold_m2"];
    }
    EXPECT_TRUE(candidate);
  } else {
    EXPECT_EQ(channels["threshold_rule"], "1% of the area");
  }
}

TEST(Geomorphometry, TheCliCountsNoPitsOrDepressionsUnderTheWaterLayer) {
  const auto [status, text] =
      run_cli("analyze " + (kScenes / "lake-dunes.json").string() + " --size 128");
  ASSERT_EQ(status, 0);
  const nlohmann::json j = nlohmann::json::parse(text);
  expect_sane_figures(j, 128);
  // The lake is wet land: flow crosses it, its floor is neither pits nor closed depressions.
  const auto wet = j["input"]["water_cells"].get<std::int64_t>();
  EXPECT_GT(wet, 0);
  EXPECT_EQ(j["wet_cells"].get<std::int64_t>(), wet);
  EXPECT_EQ(j["land_cells"].get<std::int64_t>(), 128 * 128);
  EXPECT_LE(j["closed_depressions"]["cells"].get<std::int64_t>() + wet, 128 * 128);
}

TEST(Geomorphometry, WetCellsAreNeitherPitsNorClosedDepressions) {
  // A bowl: every interior cell drains to the middle, a pit, and the bowl is one depression.
  constexpr int side = 9;
  std::vector<float> z(side * side);
  for (int j = 0; j < side; ++j) {
    for (int i = 0; i < side; ++i) {
      z[static_cast<std::size_t>(j * side + i)] = static_cast<float>(std::hypot(i - 4, j - 4));
    }
  }
  const Geomorphometry dry = *analyze({side, side, 1.0, z, std::nullopt, {}});
  EXPECT_EQ(dry.pits, 1);
  EXPECT_GT(dry.depression_cells, 0);
  // Under a lake over the middle 5 × 5 cells: nothing to count, and the shares are of dry land.
  std::vector<std::uint8_t> lake(z.size(), 0);
  for (int j = 2; j <= 6; ++j) {
    for (int i = 2; i <= 6; ++i) lake[static_cast<std::size_t>(j * side + i)] = 1;
  }
  const Geomorphometry wet = *analyze({side, side, 1.0, z, std::nullopt, {}, lake});
  EXPECT_EQ(wet.wet_cells, 25);
  EXPECT_EQ(wet.pits, 0);
  EXPECT_EQ(wet.land_cells, side * side);
  EXPECT_DOUBLE_EQ(wet.closed_depression_share,
                   static_cast<double>(wet.depression_cells) / (side * side - 25));
}

TEST(Geomorphometry, FlintsLawLeavesStandingWaterOut) {
  // A valley along row 4 falling to the west edge; a lake over eleven of its channel cells.
  constexpr int w = 32, h = 9;
  std::vector<float> z(w * h);
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      z[static_cast<std::size_t>(j * w + i)] = static_cast<float>(0.1 * i + 0.5 * std::abs(j - 4));
    }
  }
  AnalysisOptions options;
  options.channel_area = 20.0;
  const Geomorphometry open = *analyze({w, h, 1.0, z, std::nullopt, {}}, options);
  std::vector<std::uint8_t> wet(z.size(), 0);
  for (int i = 10; i <= 20; ++i) wet[static_cast<std::size_t>(4 * w + i)] = kStandingWater;
  const Geomorphometry lake = *analyze({w, h, 1.0, z, std::nullopt, {}, wet}, options);
  ASSERT_TRUE(open.flint && lake.flint);
  EXPECT_EQ(open.flint->cells - lake.flint->cells, 11);
  EXPECT_EQ(open.channel_cells, lake.channel_cells) << "the lake's cells still carry the flow";
  // And out of the slope–area profile: the same eleven cells fewer.
  std::int64_t open_cells = 0, lake_cells = 0;
  for (const SlopeAreaBin& bin : open.slope_area) open_cells += bin.cells;
  for (const SlopeAreaBin& bin : lake.slope_area) lake_cells += bin.cells;
  EXPECT_EQ(open_cells - lake_cells, 11);
  // Flowing water (a river) stays in the fit.
  for (int i = 10; i <= 20; ++i) wet[static_cast<std::size_t>(4 * w + i)] = kFlowingWater;
  EXPECT_EQ(analyze({w, h, 1.0, z, std::nullopt, {}, wet}, options)->flint->cells,
            open.flint->cells);
}

class GeomorphometryGeoTiff : public testing::TestWithParam<const char*> {};

// `terrain grid` writes the grid `analyze` evaluates, north up, with its pixel size (a pixel
// scale, or a transformation for mountain-range's rotated plane).
TEST_P(GeomorphometryGeoTiff, TheCliReadsTheCellSize) {
  const fs::path tif =
      fs::temp_directory_path() / ("terrain-analyze-" + std::to_string(::getpid()) + ".tif");
  const std::string scene = (kScenes / GetParam()).string();
  ASSERT_EQ(run_cli("grid " + scene + " --size 96 -o " + tif.string()).first, 0);
  const auto [status, text] = run_cli("analyze " + tif.string());
  const nlohmann::json raster = nlohmann::json::parse(text);
  const auto [scene_status, scene_text] = run_cli("analyze " + scene + " --size 96");
  const nlohmann::json direct = nlohmann::json::parse(scene_text);
  ASSERT_EQ(run_cli("analyze " + tif.string() + " --cell 0").first == 0, false);
  fs::remove(tif);
  ASSERT_EQ(status, 0);
  ASSERT_EQ(scene_status, 0);
  EXPECT_EQ(raster["input"]["kind"], "raster");
  EXPECT_EQ(raster["input"]["cell_size_from"], "GeoTIFF");
  EXPECT_DOUBLE_EQ(raster["grid"]["cell_size_m"].get<double>(),
                   direct["grid"]["cell_size_m"].get<double>());
  // Pits and closed depressions do not depend on the grid's orientation.
  EXPECT_EQ(raster["pits"], direct["pits"]);
  EXPECT_EQ(raster["closed_depressions"]["cells"], direct["closed_depressions"]["cells"]);
}

INSTANTIATE_TEST_SUITE_P(Geomorphometry, GeomorphometryGeoTiff,
                         testing::Values("mountain-range.json", "butte.json"));

TEST(Geomorphometry, TheCliRefusesBadOptions) {
  const std::string scene = (kScenes / "hills-river.json").string();
  for (const char* bad : {" --size 5000", " --size 1", " --size 12.5", " --area 1,2,0,3",
                          " --channel-area -4", " --sea-level x"}) {
    EXPECT_EQ(run_cli("analyze " + scene + bad).first == 0, false) << bad;
  }
  EXPECT_NE(run_cli("analyze /nonexistent/scene.json").first, 0);
}

}  // namespace
}  // namespace terrain
