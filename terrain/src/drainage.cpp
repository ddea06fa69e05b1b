// Priority-flood with an epsilon gradient, D8 routing, accumulation and Strahler orders
// (docs/analysis.md), written from Barnes, Lehman & Mulla (2014), Algorithm 3's description.
#include "terrain/drainage.hpp"

#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <string>

#include "flood_entry.hpp"

namespace terrain {
namespace {

Status validate(const ElevationGrid& grid) {
  if (grid.width < 1 || grid.width > kMaxGridSide) {
    return Error{"must be from 1 to " + std::to_string(kMaxGridSide) + " cells", "/width"};
  }
  if (grid.height < 1 || grid.height > kMaxGridSide) {
    return Error{"must be from 1 to " + std::to_string(kMaxGridSide) + " cells", "/height"};
  }
  const std::int64_t cells = std::int64_t{grid.width} * grid.height;
  if (cells > kMaxGridCells) {
    return Error{"the grid has more than " + std::to_string(kMaxGridCells) + " cells", "/width"};
  }
  if (!std::isfinite(grid.cell_size) || !(grid.cell_size > 0.0)) {
    return Error{"must be a finite number of metres greater than 0", "/cell_size"};
  }
  if (grid.elevation.size() != static_cast<std::size_t>(cells)) {
    return Error{"must hold width × height = " + std::to_string(cells) + " values", "/elevation"};
  }
  if (!grid.water.empty() && grid.water.size() != static_cast<std::size_t>(cells)) {
    return Error{"must be empty or hold width × height = " + std::to_string(cells) + " flags",
                 "/water"};
  }
  if (!grid.wet.empty() && grid.wet.size() != static_cast<std::size_t>(cells)) {
    return Error{"must be empty or hold width × height = " + std::to_string(cells) + " flags",
                 "/wet"};
  }
  if (grid.sea_level && !std::isfinite(*grid.sea_level)) {
    return Error{"must be a finite elevation", "/sea_level"};
  }
  return Ok{};
}

}  // namespace

double d8_distance(const Drainage& drainage, std::int32_t from, std::int32_t to) {
  const std::int32_t w = drainage.width;
  const bool diagonal = (from % w) != (to % w) && (from / w) != (to / w);
  return diagonal ? drainage.cell_size * std::sqrt(2.0) : drainage.cell_size;
}

Result<Drainage> route_drainage(const ElevationGrid& grid) {
  if (Status valid = validate(grid); !valid) return valid.error();
  const int w = grid.width;
  const int h = grid.height;
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  constexpr double kNoData = -std::numeric_limits<double>::infinity();

  Drainage d;
  d.width = w;
  d.height = h;
  d.cell_size = grid.cell_size;
  d.land.assign(n, 0);
  d.filled.assign(n, 0.0);
  d.receiver.assign(n, -1);
  d.order.reserve(n);
  d.area.assign(n, 0.0);
  for (std::size_t c = 0; c < n; ++c) {
    const float z = grid.elevation[c];
    const bool water = !grid.water.empty() && grid.water[c] != 0;
    d.land[c] = std::isfinite(z) && !(grid.sea_level && z <= *grid.sea_level) && !water;
    d.filled[c] = std::isfinite(z) ? static_cast<double>(z) : kNoData;
  }

  // Seeds: every outlet (not land, or on the edge), in linear index order.
  std::priority_queue<FloodEntry, std::vector<FloodEntry>, std::greater<>> open;
  std::vector<std::uint8_t> reached(n, 0);
  std::uint64_t sequence = 0;
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const std::size_t c =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(w) + static_cast<std::size_t>(i);
      const bool edge = i == 0 || j == 0 || i == w - 1 || j == h - 1;
      if (edge || d.land[c] == 0) {
        reached[c] = 1;
        open.push({d.filled[c], sequence++, static_cast<std::int32_t>(c)});
      }
    }
  }
  // Flood inwards from the lowest open cell. A cell reached from c is raised to at least the
  // next double above c's filled value, so pops come out in non-decreasing filled order and a
  // cell's strictly lower neighbours are all popped before it.
  while (!open.empty()) {
    const FloodEntry top = open.top();
    open.pop();
    d.order.push_back(top.cell);
    const int ci = top.cell % w;
    const int cj = top.cell / w;
    for (int k = 0; k < 8; ++k) {
      const int ni = ci + kD8Dx[k];
      const int nj = cj + kD8Dy[k];
      if (ni < 0 || nj < 0 || ni >= w || nj >= h) continue;
      const std::size_t nc =
          static_cast<std::size_t>(nj) * static_cast<std::size_t>(w) + static_cast<std::size_t>(ni);
      if (reached[nc] != 0) continue;
      reached[nc] = 1;
      const double floor = std::nextafter(top.value, std::numeric_limits<double>::infinity());
      if (d.filled[nc] < floor) d.filled[nc] = floor;
      open.push({d.filled[nc], sequence++, static_cast<std::int32_t>(nc)});
    }
  }

  // D8 steepest descent on the filled surface for every land cell that is not an outlet.
  for (int j = 1; j + 1 < h; ++j) {
    for (int i = 1; i + 1 < w; ++i) {
      const std::size_t c =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(w) + static_cast<std::size_t>(i);
      if (d.land[c] == 0) continue;
      // Never −1: the cell the flood came from is strictly lower.
      d.receiver[c] = steepest_descent(d, i, j);
    }
  }

  // Accumulation, upstream first.
  const double cell_area = grid.cell_size * grid.cell_size;
  for (std::size_t c = 0; c < n; ++c) d.area[c] = d.land[c] != 0 ? cell_area : 0.0;
  for (std::size_t k = n; k-- > 0;) {
    const std::int32_t c = d.order[k];
    const std::int32_t r = d.receiver[static_cast<std::size_t>(c)];
    // Water leaving the land (into the sea, a lake, no data) is not counted there.
    if (r >= 0 && d.land[static_cast<std::size_t>(r)] != 0) {
      d.area[static_cast<std::size_t>(r)] += d.area[static_cast<std::size_t>(c)];
    }
  }
  return d;
}

std::int32_t steepest_descent(const Drainage& d, int i, int j) {
  const int w = d.width, h = d.height;
  const auto index = [w](int x, int y) {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
  };
  const double here = d.filled[index(i, j)];
  double steepest = 0.0;
  std::int32_t best = -1;
  for (int k = 0; k < 8; ++k) {
    const int ni = i + kD8Dx[k], nj = j + kD8Dy[k];
    if (ni < 0 || nj < 0 || ni >= w || nj >= h) continue;
    const std::size_t nc = index(ni, nj);
    const double drop = here - d.filled[nc];
    if (!(drop > 0.0)) continue;
    const double slope = (kD8Dx[k] != 0 && kD8Dy[k] != 0) ? drop / std::sqrt(2.0) : drop;
    if (best < 0 || slope > steepest) {
      steepest = slope;
      best = static_cast<std::int32_t>(nc);
    }
  }
  return best;
}

std::vector<int> strahler_orders(std::span<const std::int32_t> receiver,
                                 std::span<const std::int32_t> order,
                                 std::span<const std::uint8_t> channel) {
  const std::size_t n = receiver.size();
  std::vector<int> strahler(n, 0);
  std::vector<int> highest_in(n, 0);              // highest order among channel donors
  std::vector<std::uint8_t> highest_count(n, 0);  // how many donors have it, saturating at 2
  for (std::size_t k = order.size(); k-- > 0;) {
    const auto c = static_cast<std::size_t>(order[k]);
    if (c >= n || channel[c] == 0) continue;
    strahler[c] = highest_count[c] == 0 ? 1 : highest_in[c] + (highest_count[c] >= 2 ? 1 : 0);
    const std::int32_t r = receiver[c];
    if (r < 0 || static_cast<std::size_t>(r) >= n || channel[static_cast<std::size_t>(r)] == 0) {
      continue;
    }
    const auto rc = static_cast<std::size_t>(r);
    if (strahler[c] > highest_in[rc]) {
      highest_in[rc] = strahler[c];
      highest_count[rc] = 1;
    } else if (strahler[c] == highest_in[rc] && highest_count[rc] < 2) {
      ++highest_count[rc];
    }
  }
  return strahler;
}

}  // namespace terrain
