// Lakes, channels and their carving (docs/erosion.md, "Drainage"), on the routing of drainage.cpp.
#include "terrain/rivers.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "free_storage.hpp"
#include "terrain/erosion.hpp"

namespace terrain {
namespace {

// A valley floor falls this much per metre toward its channel, so no floor cell is flat.
constexpr double kFloorSlope = 0.01;

struct Lakes {
  std::vector<std::uint8_t> lake;  ///< 1 for cells of a kept lake
  /// The spill level of each lake cell's lake, as the water layer stores it (float32).
  std::vector<float> level;
  int count = 0;
};

/// The depressions of the routed grid: 8-connected cells the flood raised. Those at least
/// `min_depth` deep somewhere are lakes at their spill level; the others stay filled.
Lakes find_lakes(const Drainage& d, std::span<const float> elevation, double min_depth) {
  const std::size_t n = d.cells();
  const int w = d.width, h = d.height;
  Lakes out;
  out.lake.assign(n, 0);
  out.level.assign(n, 0.0f);
  const auto raised = [&](std::size_t c) {
    return d.land[c] != 0 && d.filled[c] > static_cast<double>(elevation[c]);
  };
  std::vector<std::uint8_t> seen(n, 0);
  std::vector<std::int32_t> component;
  for (std::size_t start = 0; start < n; ++start) {
    if (seen[start] != 0 || !raised(start)) continue;
    // One depression, breadth first from its lowest-index cell.
    component.clear();
    component.push_back(static_cast<std::int32_t>(start));
    seen[start] = 1;
    double deepest = 0.0, level = d.filled[start];
    for (std::size_t k = 0; k < component.size(); ++k) {
      const auto c = static_cast<std::size_t>(component[k]);
      deepest = std::max(deepest, d.filled[c] - static_cast<double>(elevation[c]));
      level = std::min(level, d.filled[c]);
      const int ci = static_cast<int>(c % static_cast<std::size_t>(w));
      const int cj = static_cast<int>(c / static_cast<std::size_t>(w));
      for (int m = 0; m < 8; ++m) {
        const int ni = ci + kD8Dx[m], nj = cj + kD8Dy[m];
        if (ni < 0 || nj < 0 || ni >= w || nj >= h) continue;
        const std::size_t nc = static_cast<std::size_t>(nj) * static_cast<std::size_t>(w) +
                               static_cast<std::size_t>(ni);
        if (seen[nc] != 0 || !raised(nc)) continue;
        seen[nc] = 1;
        component.push_back(static_cast<std::int32_t>(nc));
      }
    }
    if (deepest < min_depth) continue;
    ++out.count;
    for (const std::int32_t c : component) {
      out.lake[static_cast<std::size_t>(c)] = 1;
      out.level[static_cast<std::size_t>(c)] = static_cast<float>(level);
    }
  }
  return out;
}

/// 1 within kWaterReachCells (Chebyshev distance) of a cell whose water stands above its ground,
/// else 0: a square dilation, rows then columns.
std::vector<float> water_weight(const std::vector<float>& water, const std::vector<float>& ground,
                                int w, int h) {
  const std::size_t n = water.size();
  std::vector<std::uint8_t> near(n, 0), wet(n, 0);
  for (std::size_t c = 0; c < n; ++c) wet[c] = water[c] > ground[c] ? 1 : 0;
  const auto at = [w](int i, int j) {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(w) + static_cast<std::size_t>(i);
  };
  for (int j = 0; j < h; ++j) {  // along rows
    for (int i = 0; i < w; ++i) {
      if (wet[at(i, j)] == 0) continue;
      for (int x = std::max(i - kWaterReachCells, 0); x <= std::min(i + kWaterReachCells, w - 1);
           ++x) {
        near[at(x, j)] = 1;
      }
    }
  }
  std::vector<float> weight(n, 0.0f);
  for (int j = 0; j < h; ++j) {  // then along columns
    for (int i = 0; i < w; ++i) {
      if (near[at(i, j)] == 0) continue;
      for (int y = std::max(j - kWaterReachCells, 0); y <= std::min(j + kWaterReachCells, h - 1);
           ++y) {
        weight[at(i, y)] = 1.0f;
      }
    }
  }
  return weight;
}

}  // namespace

Status validate_rivers(const ElevationGrid& grid, const RiverParams& p) {
  const auto within = [](double v, double lo, double hi) {
    return std::isfinite(v) && v >= lo && v <= hi;
  };
  if (!within(p.channel_area, kMinChannelArea, kMaxChannelArea)) {
    return Error{"must be an area in m² from 1 to 1e13", "/channel_area"};
  }
  if (!within(p.width, 0.0, kMaxChannelWidth) || !(p.width > 0.0)) {
    return Error{"must be a width in metres greater than 0, at most 1e4", "/width"};
  }
  if (!within(p.depth, 0.0, kMaxChannelDepth) || !(p.depth > 0.0)) {
    return Error{"must be a depth in metres greater than 0, at most 1e3", "/depth"};
  }
  if (!within(p.bank_slope, kMinBankSlope, kMaxBankSlope)) {
    return Error{"must be a rise per run from 0.05 to 20", "/bank_slope"};
  }
  if (!within(p.lake_depth, 0.0, kMaxLakeDepth) || !(p.lake_depth > 0.0)) {
    return Error{"must be a depth in metres greater than 0, at most 1e4", "/lake_depth"};
  }
  if (p.sea_level && !std::isfinite(*p.sea_level)) {
    return Error{"must be a finite elevation", "/sea_level"};
  }
  if (grid.width < 3 || grid.height < 3) return Error{"must be at least 3 cells", "/width"};
  return Ok{};
}

Result<RiverNetwork> carve_rivers(const ElevationGrid& input, const RiverParams& p) {
  if (Status valid = validate_rivers(input, p); !valid) return valid.error();
  ElevationGrid grid = input;
  grid.water = {};
  if (p.sea_level) grid.sea_level = static_cast<float>(*p.sea_level);
  Result<Drainage> routed = route_drainage(grid);
  if (!routed) return routed.error();
  const Drainage& d = *routed;  // until the second routing
  const std::size_t n = d.cells();
  const int w = grid.width, h = grid.height;
  const double cell = grid.cell_size;

  // δ: what each channel cell keeps below the one upstream, four float32 ulps of the largest
  // magnitude at least, so beds and water descend in float32 too.
  double magnitude = 1.0;
  for (const float z : grid.elevation) {
    if (std::isfinite(z)) magnitude = std::max(magnitude, std::fabs(static_cast<double>(z)));
  }
  const double delta =
      std::max(1e-4 * cell, 4.0 * (std::nextafter(static_cast<float>(magnitude), INFINITY) -
                                   static_cast<float>(magnitude)));

  RiverNetwork out;
  Lakes lakes = find_lakes(d, grid.elevation, p.lake_depth);
  out.lakes = lakes.count;
  // The surface rivers run on: shallow depressions filled, lake floors and the sea as they were.
  const auto ground = [&](std::size_t c) {
    const bool filled = d.land[c] != 0 && lakes.lake[c] == 0;
    return filled ? d.filled[c] : static_cast<double>(grid.elevation[c]);
  };

  // Channels: land outside lakes draining at least the threshold area, sized by their area.
  // What only channel cells have (bed, water, width, depth) is kept per channel, in cell order
  // (`slot` maps a cell to its channel's index): channels are a few percent of the cells, and
  // a 2048² grid cannot afford six arrays of doubles over all of them.
  out.channel.assign(n, 0);
  out.downstream.assign(n, -1);
  std::vector<std::int32_t> slot(n, -1);
  std::vector<std::int32_t> cell_of;
  for (std::size_t c = 0; c < n; ++c) {
    if (d.land[c] == 0 || lakes.lake[c] != 0 || d.area[c] < p.channel_area) continue;
    out.channel[c] = 1;
    slot[c] = static_cast<std::int32_t>(cell_of.size());
    cell_of.push_back(static_cast<std::int32_t>(c));
  }
  const std::size_t k_channels = cell_of.size();
  const auto at = [&](std::size_t c) { return static_cast<std::size_t>(slot[c]); };
  std::vector<double> bed(k_channels, 0.0), water(k_channels, 0.0), half_width(k_channels, 0.0),
      depth(k_channels, 0.0);
  for (std::size_t k = 0; k < k_channels; ++k) {
    const double q = d.area[static_cast<std::size_t>(cell_of[k])] / p.channel_area;
    half_width[k] = 0.5 * p.width * std::sqrt(q);
    depth[k] = p.depth * portable_pow(q, 0.4);
  }
  for (std::size_t c = 0; c < n; ++c) {
    const std::int32_t r = d.receiver[c];
    if (out.channel[c] != 0 && r >= 0 && out.channel[static_cast<std::size_t>(r)] != 0) {
      out.downstream[c] = r;
    }
  }
  // A channel deepens with its area, but no faster downstream than half the ground's fall: a
  // confluence's jump in depth is spread over the reach below it, so the bed's slope stays
  // between 1 and 1.5 times the ground's and the channel keeps the valley's Flint's law.
  {
    std::vector<double> reachable(k_channels, 0.0);
    std::vector<std::uint8_t> fed(k_channels, 0);
    for (std::size_t k = n; k-- > 0;) {
      const auto c = static_cast<std::size_t>(d.order[k]);
      if (out.channel[c] == 0) continue;
      const std::size_t sc = at(c);
      if (fed[sc] != 0) depth[sc] = std::min(depth[sc], reachable[sc]);
      const std::int32_t r = out.downstream[c];
      if (r < 0) continue;
      const auto rc = static_cast<std::size_t>(r);
      const double fall = std::max(ground(c) - ground(rc), 0.0);
      reachable[at(rc)] = std::max(reachable[at(rc)], depth[sc] + 0.5 * fall);
      fed[at(rc)] = 1;
    }
  }
  for (std::size_t k = 0; k < k_channels; ++k) {
    bed[k] = ground(static_cast<std::size_t>(cell_of[k])) - depth[k];
    water[k] = bed[k] + kWaterShareOfDepth * depth[k];
  }
  // Each channel cell's value at least δ below the one upstream: lowered downstream (upstream
  // first, so a cell has all its donors' before it passes its own on), never raised. `index`
  // maps a cell to where `v` keeps it.
  const auto descend = [&](std::vector<double>& v, const auto& index) {
    for (std::size_t k = n; k-- > 0;) {
      const auto c = static_cast<std::size_t>(d.order[k]);
      if (const std::int32_t r = out.downstream[c]; r >= 0) {
        double& below = v[index(static_cast<std::size_t>(r))];
        below = std::min(below, v[index(c)] - delta);
      }
    }
  };
  descend(bed, at);
  descend(water, at);

  // The carve: each channel cell's cross-section — a floor of its width sloping gently to the
  // centre line, banks beyond — cut into the ground around it. A cell takes the section it lies
  // deepest inside (the least distance beyond a floor's edge; then the lower section), and a
  // channel cell its own bed: taking the lowest section would let a wide river's floor run at
  // the floor's slope instead of its own.
  std::vector<double> carved(n, std::numeric_limits<double>::infinity());
  std::vector<std::int32_t> owner(n, -1);
  {
    std::vector<double> beyond_floor(n, std::numeric_limits<double>::infinity());
    for (std::size_t k = 0; k < k_channels; ++k) {
      const auto c = static_cast<std::size_t>(cell_of[k]);
      const double reach = half_width[k] + depth[k] / p.bank_slope;
      // Clamped before the cast: a huge width over tiny cells is no integer.
      const int radius = static_cast<int>(
          std::min(static_cast<double>(kMaxCarveRadius), std::ceil(reach / cell - 1e-9)));
      const int ci = static_cast<int>(c % static_cast<std::size_t>(w));
      const int cj = static_cast<int>(c / static_cast<std::size_t>(w));
      for (int nj = std::max(cj - radius, 0); nj <= std::min(cj + radius, h - 1); ++nj) {
        for (int ni = std::max(ci - radius, 0); ni <= std::min(ci + radius, w - 1); ++ni) {
          const std::size_t x = static_cast<std::size_t>(nj) * static_cast<std::size_t>(w) +
                                static_cast<std::size_t>(ni);
          if (d.land[x] == 0 || lakes.lake[x] != 0 || out.channel[x] != 0) continue;
          const double di = ni - ci, dj = nj - cj;
          const double distance = cell * std::sqrt(di * di + dj * dj);
          const double outside = distance - half_width[k];
          const double section =
              bed[k] + kFloorSlope * distance + p.bank_slope * std::max(outside, 0.0);
          if (outside < beyond_floor[x] || (outside == beyond_floor[x] && section < carved[x])) {
            beyond_floor[x] = outside;
            carved[x] = section;
            owner[x] = static_cast<std::int32_t>(c);
          }
        }
      }
    }
  }
  for (std::size_t k = 0; k < k_channels; ++k) {
    const auto c = static_cast<std::size_t>(cell_of[k]);
    carved[c] = bed[k];
    owner[c] = static_cast<std::int32_t>(c);
  }
  // The carved ground, in place: the lower of the ground and the section cut into it.
  for (std::size_t c = 0; c < n; ++c) carved[c] = std::min(ground(c), carved[c]);
  // Beds stay below the ones upstream whatever sections cut beside them.
  descend(carved, [](std::size_t c) { return c; });
  out.strahler = strahler_orders(out.downstream, d.order, out.channel);

  // In float32: every land cell outside lakes and the sea drains. Routed again with the lakes as
  // water, a cell not above its receiver (rounding, a pocket the sections left) is raised four
  // ulps above it, receivers first. The first routing's arrays go first (but which cells are
  // land): the second routing needs as much room.
  out.terrain.resize(n);
  for (std::size_t c = 0; c < n; ++c) out.terrain[c] = static_cast<float>(carved[c]);
  std::vector<std::uint8_t> land = std::move(routed->land);
  routed = Drainage{};
  free_storage(carved);
  {
    ElevationGrid final_grid = grid;
    final_grid.elevation = out.terrain;
    final_grid.water = lakes.lake;
    Result<Drainage> final_routing = route_drainage(final_grid);
    if (!final_routing) return final_routing.error();
    for (const std::int32_t cell_index : final_routing->order) {
      const auto c = static_cast<std::size_t>(cell_index);
      const std::int32_t r = final_routing->receiver[c];
      if (r < 0) continue;
      // Four ulps above: an evaluator's rounding of the bicubic at the sample may not undo it.
      float above = out.terrain[static_cast<std::size_t>(r)];
      for (int ulp = 0; ulp < 4; ++ulp) above = std::nextafter(above, INFINITY);
      if (out.terrain[c] < above && !(out.terrain[c] > out.terrain[static_cast<std::size_t>(r)])) {
        out.terrain[c] = above;
      }
    }
  }

  // The water surface: lakes, the sea, channels, and beside them their water where it stands
  // above the carved ground; elsewhere below the ground.
  out.water.resize(n);
  for (std::size_t c = 0; c < n; ++c) {
    const float ground_here = out.terrain[c];
    float surface = ground_here - kDryDepth;
    if (lakes.lake[c] != 0) {
      surface = lakes.level[c];
    } else if (out.channel[c] != 0) {
      // A channel's own water, above its bed (and whatever section cut lower beside it).
      surface = std::max(static_cast<float>(water[at(c)]), ground_here);
    } else if (p.sea_level && land[c] == 0 && std::isfinite(grid.elevation[c])) {
      surface = static_cast<float>(*p.sea_level);
    } else if (const std::int32_t o = owner[c]; o >= 0) {
      const auto level = static_cast<float>(water[at(static_cast<std::size_t>(o))]);
      if (level > ground_here) surface = level;
    }
    out.water[c] = surface;
  }
  free_storage(owner);
  free_storage(slot);
  free_storage(lakes.level);
  out.water_weight = water_weight(out.water, out.terrain, w, h);
  out.lake = std::move(lakes.lake);
  return out;
}

}  // namespace terrain
