// Sampler::grid: a tile's samples together. Each is what a lone sample at its direction gives,
// bit for bit; what is shared is only the work: the start of the descents, the detail noise, and
// the drainage model's floors, drawn once per floored edge onto the samples it reaches instead of
// walked to from every sample.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include "drain_floors.hpp"
#include "planet/planet.hpp"
#include "terrain/simd.hpp"
#include "warp.hpp"

namespace planet {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// Samples a floor is drawn onto at a time (draw_floor).
constexpr std::size_t kLanes = 4;

// A point's distance from the polar axis.
double axis_distance(const Vec3d& p) {
  return std::sqrt(p[0] * p[0] + p[1] * p[1]);
}

// The least distance from the polar axis of the chord from a to b: that of the segment between
// their projections onto the equator's plane from its origin.
double chord_axis_distance(const Vec3d& a, const Vec3d& b) {
  const double dx = b[0] - a[0], dy = b[1] - a[1];
  const double length2 = dx * dx + dy * dy;
  const double t = length2 > 0.0 ? std::clamp(-(a[0] * dx + a[1] * dy) / length2, 0.0, 1.0) : 0.0;
  const double x = a[0] + t * dx, y = a[1] + t * dy;
  return std::sqrt(x * x + y * y);
}

// Which part of the sphere a grid covers, widened by a floor's reach: every chord within reach
// of a sample has an end on the inner side of each bound (a chord with both ends beyond one is
// beyond it all along). Latitude bounds are on z, and on the distance from the polar axis, which
// bounds a grid beside a pole where z hardly changes (a chord's farthest point from the axis is
// an end, its nearest is computed); longitude bounds are on the meridians' planes, kept only
// while the grid spans less than a sixth of a turn.
struct GridBounds {
  double z_lo = -2.0, z_hi = 2.0;
  bool polar = false;  ///< beyond 45° of latitude: bounds on the distance from the axis too
  double axis_lo = -1.0, axis_hi = 2.0;
  bool meridians = false;
  Vec3d west{}, east{};  ///< normals pointing into the grid
  double reach = 0.0;

  bool near(const Vec3d& a, const Vec3d& b) const {
    if (a[2] < z_lo && b[2] < z_lo) return false;
    if (a[2] > z_hi && b[2] > z_hi) return false;
    if (polar && ((axis_distance(a) < axis_lo && axis_distance(b) < axis_lo) ||
                  chord_axis_distance(a, b) > axis_hi)) {
      return false;
    }
    if (meridians && ((dot(a, west) < -reach && dot(b, west) < -reach) ||
                      (dot(a, east) < -reach && dot(b, east) < -reach))) {
      return false;
    }
    return true;
  }
};

GridBounds grid_bounds(const SampleGrid& grid, std::span<const double> row_z,
                       std::span<const double> row_axis, bool polar, double reach) {
  GridBounds bounds;
  bounds.reach = reach;
  double z_lo = 2.0, z_hi = -2.0;
  for (const double z : row_z) {
    z_lo = std::min(z_lo, z);
    z_hi = std::max(z_hi, z);
  }
  bounds.z_lo = z_lo - reach;
  bounds.z_hi = z_hi + reach;
  if (polar) {
    const auto [axis_lo, axis_hi] = std::minmax_element(row_axis.begin(), row_axis.end());
    bounds.polar = true;
    bounds.axis_lo = *axis_lo - reach;
    bounds.axis_hi = *axis_hi + reach;
  }
  const double west = grid.longitude.front() * kDegree, east = grid.longitude.back() * kDegree;
  if (east - west < std::numbers::pi / 3.0) {
    bounds.meridians = true;
    bounds.west = {-std::sin(west), std::cos(west), 0.0};
    bounds.east = {std::sin(east), -std::cos(east), 0.0};
  }
  return bounds;
}

// The first index in [lo, hi) where `holds` does not, `holds` holding on a prefix of them.
template <typename Predicate>
int first_where_not(int lo, int hi, const Predicate& holds) {
  while (lo < hi) {
    const int mid = lo + (hi - lo) / 2;
    if (holds(mid)) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo;
}

// The same, searched outwards from `guess` in steps that double before bisecting: the drain
// edges are drawn in the order their triangles were reached, each near the last, so a search
// from the last one's answer takes two or three steps where a bisection of a row takes eight.
template <typename Predicate>
int first_where_not_from(int guess, int lo, int hi, const Predicate& holds) {
  guess = std::clamp(guess, lo, hi);
  int left = lo, right = hi;  // the answer lies in [left, right]
  if (guess < hi && holds(guess)) {
    left = guess + 1;
    for (int step = 1; left + step <= hi; step *= 2) {
      const int probe = left + step - 1;
      if (!holds(probe)) {
        right = probe;
        break;
      }
      left = probe + 1;
    }
  } else {
    right = guess;
    for (int step = 1; right - step >= lo; step *= 2) {
      const int probe = right - step;
      if (holds(probe)) {
        left = probe + 1;
        break;
      }
      right = probe;
    }
  }
  return first_where_not(left, right, holds);
}

// The columns whose longitude lies in [lo, hi] (increasing with the column): [first, end).
std::pair<int, int> columns_between(std::span<const double> longitude, double lo, double hi) {
  const auto first = std::lower_bound(longitude.begin(), longitude.end(), lo);
  const auto end = std::upper_bound(first, longitude.end(), hi);
  return {static_cast<int>(first - longitude.begin()), static_cast<int>(end - longitude.begin())};
}

// Samples packed for drawing floors (Sampler::draw_floors): one array per coordinate, the ground
// before (NaN off land) and the lowest floor so far, each padded by kLanes values beyond the
// last sample; in grid order, `cols` to a row, or in the order of their bins.
struct FloorSamples {
  const double* x;
  const double* y;
  const double* z;
  const double* ground;
  double* lowest;
  std::size_t cols;
};

// The floor of one drain edge drawn onto the packed samples [first, end), kLanes at a time: a
// sample beyond them (the next ones of the row or bin, or the padding) is out of reach of the
// edge or within it, and either way lowering it again changes nothing (lowered() reads the
// ground before every floor), so no remainder loop is needed. A NaN ground (off land) stays
// NaN: lowered() compares it false and returns it. Cloned for AVX-512 and AVX2 (the same
// numbers: no contraction, and a select returns one of its operands).
// `sparse`: a rectangle of rows and columns around an edge holds about twice the samples within
// its reach, so kLanes samples all farther than the reach from its chord are passed over, which
// leaves every value as it was (lowered() returns their ground). Bins hug the edge more closely,
// and there the test costs more than it saves.
template <bool sparse>
TERRAIN_SIMD_CLONES void draw_floor(const floors::DrainSegment& segment,
                                    const floors::FloorShape& shape, const FloorSamples& samples,
                                    std::size_t first, std::size_t end) {
  const double search2 = shape.search_chord() * shape.search_chord();
  for (std::size_t i = first; i < end; i += kLanes) {
    if constexpr (sparse) {
      bool near = false;
      for (std::size_t j = 0; j < kLanes; ++j) {
        const Vec3d off =
            floors::foot_on(segment, {samples.x[i + j], samples.y[i + j], samples.z[i + j]}).off;
        near |= dot(off, off) <= search2;
      }
      if (!near) continue;
    }
    std::array<double, kLanes> ground_after{};
    for (std::size_t j = 0; j < kLanes; ++j) {
      ground_after[j] =
          floors::lowered(samples.ground[i + j], segment,
                          {samples.x[i + j], samples.y[i + j], samples.z[i + j]}, shape);
    }
    for (std::size_t j = 0; j < kLanes; ++j) {
      samples.lowest[i + j] = std::min(samples.lowest[i + j], ground_after[j]);
    }
  }
}

// Unit vectors east and north of direction c, the axes of the plane a warped band's samples are
// binned in (any pair orthogonal to c would do: the bins only need a projection that moves no
// two points farther apart than they are).
std::pair<Vec3d, Vec3d> tangent_axes(const Vec3d& c) {
  const double across = std::sqrt(c[0] * c[0] + c[1] * c[1]);
  const Vec3d east =
      across > 1e-9 ? Vec3d{-c[1] / across, c[0] / across, 0.0} : Vec3d{0.0, 1.0, 0.0};
  return {east, cross(c, east)};
}

}  // namespace

// The floored edges (drains and valleys) of `level` that a sample's walk could reach: the
// triangles from the samples' leaves across every edge `near` the samples (a walk from a sample
// crosses only edges within reach of it, which are near the samples, so these are every triangle
// any sample's walk reaches), each floored edge of them once, from the lower-numbered of its two
// triangles, handed to `draw` where it is `near` the samples too. Both ways of drawing floors
// (draw_floors, draw_floors_by_bins) find their edges so.
template <typename Near, typename Draw>
void Sampler::for_each_floored_edge(const Near& near, const Draw& draw) {
  if (++mark_ == 0) {
    std::fill(marks_.begin(), marks_.end(), 0U);
    mark_ = 1;
  }
  const auto marked = [&](std::int32_t t) {
    const auto u = static_cast<std::size_t>(t);
    return u < marks_.size() && marks_[u] == mark_;
  };
  const auto mark = [&](std::int32_t t) {
    const auto u = static_cast<std::size_t>(t);
    if (u >= marks_.size()) marks_.resize(std::max(hierarchy_.tris.size(), u + 1), 0U);
    marks_[u] = mark_;
    reached_.push_back(t);
  };
  reached_.clear();
  for (const std::int32_t leaf : leaves_) {
    if (!marked(leaf)) mark(leaf);
  }
  for (std::size_t next = 0; next < reached_.size(); ++next) {
    const std::int32_t u = reached_[next];
    hierarchy_.ensure_partner(u);
    const Tri tri = hierarchy_.tris[static_cast<std::size_t>(u)];
    for (std::size_t k = 0; k < 3; ++k) {
      const std::int32_t across = tri.nb[k];
      if (across < 0 || marked(across)) continue;
      if (!near(hierarchy_.vertices[tri.v[k]].p, hierarchy_.vertices[tri.v[(k + 1) % 3]].p)) {
        continue;
      }
      mark(across);
    }
  }
  for (const std::int32_t u : reached_) {
    const Tri& tri = hierarchy_.tris[static_cast<std::size_t>(u)];
    for (std::size_t k = 0; k < 3; ++k) {
      if (!floors::floored_edge(hierarchy_, tri, k)) continue;
      const std::int32_t across = tri.nb[k];
      if (across >= 0 && marked(across) && across < u) continue;
      const Vertex& a = hierarchy_.vertices[tri.v[k]];
      const Vertex& b = hierarchy_.vertices[tri.v[(k + 1) % 3]];
      if (near(a.p, b.p)) draw(a, b);
    }
  }
}

void Sampler::grid(const SampleGrid& grid, int level, double octaves, const GridSink& out) {
  assert(grid.latitude.size() == static_cast<std::size_t>(grid.rows));
  assert(grid.longitude.size() == static_cast<std::size_t>(grid.cols));
  // The floors find their rows and columns by binary searches over these orders.
  assert(std::is_sorted(grid.latitude.begin(), grid.latitude.end(), std::greater<>()));
  assert(std::is_sorted(grid.longitude.begin(), grid.longitude.end()));
  // Once, here: the leaves kept for the floors must outlive every descent of the grid.
  trim_when_large();
  // Without floors each block is finished as soon as it is sampled (a tile's pending samples are
  // megabytes that a block's are not). With them, a band of kFloorBandRows rows waits for its
  // floors and is finished together: a sample's floors are those of the drain edges within reach
  // of it, whichever grid draws them, so a band is a grid of its own and gives the same bits. A
  // band's pending samples and packed arrays (about a megabyte) stay nearer the core than a
  // whole tile's (eight times that); the drain edges near a band's first and last rows are found
  // and set up for both bands beside them.
  const bool floors = drainage_floors();
  const int band = floors ? kFloorBandRows : grid.rows;
  for (int r0 = 0; r0 < grid.rows; r0 += band) {
    const auto first = static_cast<std::size_t>(r0);
    const auto rows = static_cast<std::size_t>(std::min(band, grid.rows - r0));
    const SampleGrid part{static_cast<int>(rows),
                          grid.cols,
                          grid.latitude.subspan(first, rows),
                          grid.longitude,
                          grid.sin_lat.subspan(first, rows),
                          grid.cos_lat.subspan(first, rows),
                          grid.sin_lon,
                          grid.cos_lon};
    grid_rows(part, first * static_cast<std::size_t>(grid.cols), level, octaves, floors, out);
  }
}

void Sampler::grid_rows(const SampleGrid& grid, std::size_t base, int level, double octaves,
                        bool floors, const GridSink& out) {
  pending_.clear();
  order_.clear();
  leaves_.clear();
  pending_directions_.clear();
  if (floors) {
    // Every sample of the band waits: room for all at once, or a fresh sampler copies them as
    // they grow (and touches twice the pages).
    const std::size_t count =
        static_cast<std::size_t>(grid.rows) * static_cast<std::size_t>(grid.cols);
    pending_.reserve(count);
    order_.reserve(count);
    leaves_.reserve(count);
    pending_directions_.reserve(count);
  }
  // The band's directions, each where the planet's warp moves it (all at once: the warp's noise
  // goes several directions at a time where the CPU has vectors for it).
  const Geodesy& geodesy = planet_->geodesy();
  const auto cols = static_cast<std::size_t>(grid.cols);
  warped_.resize(static_cast<std::size_t>(grid.rows) * cols);
  for (std::size_t r = 0; r < static_cast<std::size_t>(grid.rows); ++r) {
    for (std::size_t c = 0; c < cols; ++c) {
      warped_[r * cols + c] =
          geodesy.direction(grid.sin_lat[r], grid.cos_lat[r], grid.sin_lon[c], grid.cos_lon[c]);
    }
  }
  warp_scratch_.resize(3 * warped_.size());
  detail::warped(planet_->warp_octaves(level), warped_.data(), warped_.size(), warped_.data(),
                 warp_scratch_.data());
  const auto direction = [&](int r, int c) {
    return warped_[static_cast<std::size_t>(r) * cols + static_cast<std::size_t>(c)];
  };
  // Samples go in blocks that share the start of their descent: the deepest triangle holding the
  // block's outline (with a margin), found once per block. Each sample still checks that it lies
  // inside that triangle and otherwise descends from the octahedron, so every height is the one
  // a lone sample gets (see DescentStart); the block only saves the common part of the ~2 levels
  // per zoom that all its samples would descend alike.
  constexpr int kBlock = 16;
  std::vector<Vec3d> outline;
  for (int r0 = 0; r0 < grid.rows; r0 += kBlock) {
    const int r1 = std::min(grid.rows, r0 + kBlock) - 1;
    for (int c0 = 0; c0 < grid.cols; c0 += kBlock) {
      const int c1 = std::min(grid.cols, c0 + kBlock) - 1;
      outline.clear();
      for (int c = c0; c <= c1; ++c) {
        outline.push_back(direction(r0, c));
        outline.push_back(direction(r1, c));
      }
      for (int r = r0 + 1; r < r1; ++r) {
        outline.push_back(direction(r, c0));
        outline.push_back(direction(r, c1));
      }
      const DescentStart start =
          find_descent_start(direction((r0 + r1) / 2, (c0 + c1) / 2), outline, level);
      // Rows in alternate directions (a serpentine), so that each sample lies beside the last
      // and the descent's walk from the last leaf takes a step or two (0.4 % of a refined zoom-10
      // tile's samples still descend afresh, against 6 % when every row went east).
      for (int r = r0; r <= r1; ++r) {
        const bool eastward = (r - r0) % 2 == 0;
        for (int step = 0; step <= c1 - c0; ++step) {
          const int c = eastward ? c0 + step : c1 - step;
          const Vec3d p = direction(r, c);
          const std::int32_t leaf = descend(p, level, start);
          // Floors are drawn from the leaves of the level (an open-sea leaf is coarser, and the
          // land beside it takes no floors from its level).
          if (floors && hierarchy_.tris[static_cast<std::size_t>(leaf)].level == level) {
            leaves_.push_back(leaf);
          }
          order_.push_back(base +
                           static_cast<std::size_t>(r) * static_cast<std::size_t>(grid.cols) +
                           static_cast<std::size_t>(c));
          pending_directions_.push_back(p);
          pending_.push_back(undetailed(leaf, p, level, false));
        }
      }
      if (!floors) finish_pending(octaves, out);
    }
  }
  if (floors) {
    if (planet_->warps(level)) {
      draw_floors_by_bins(level);
    } else {
      draw_floors(grid, base, level);
    }
    finish_pending(octaves, out);
  }
}

void Sampler::finish_pending(double octaves, const GridSink& out) {
  detailed_.clear();
  const bool detailed = planet_->has_detail_octaves(octaves) && octaves > 0.0;
  if (detailed) {
    for (std::size_t k = 0; k < pending_.size(); ++k) {
      if (pending_[k].weight > 0.0) detailed_.push_back(pending_directions_[k]);
    }
  }
  detail_.resize(detailed_.size());
  if (!detailed_.empty()) planet_->detail(detailed_, octaves, detail_);
  std::size_t next = 0;
  for (std::size_t k = 0; k < pending_.size(); ++k) {
    const Undetailed& sample = pending_[k];
    out(order_[k], detailed && sample.weight > 0.0 ? finish(sample, detail_[next++])
                                                   : finish(sample, std::nullopt));
  }
  pending_.clear();
  order_.clear();
  pending_directions_.clear();
}

void Sampler::draw_floors(const SampleGrid& grid, std::size_t base, int level) {
  const std::size_t count = pending_.size();
  if (std::none_of(pending_.begin(), pending_.end(),
                   [](const Undetailed& s) { return s.face == FaceType::land; })) {
    return;
  }
  const floors::FloorShape shape = floors::floor_shape(planet_->rules(), level);
  const double reach = shape.search_chord();
  // The grounds before and after and the directions, packed in grid order, one array per
  // coordinate, so that drawing a floor along a row vectorises (the samples' records are ten
  // times larger); NaN off land, which no floor lowers; padded for draw_floor.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ground_.assign(count + kLanes, nan);
  for (std::vector<double>& axis : direction_) axis.assign(count + kLanes, 0.0);
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t i = order_[k] - base;
    for (std::size_t j = 0; j < 3; ++j) direction_[j][i] = pending_directions_[k][j];
    if (pending_[k].face == FaceType::land) ground_[i] = pending_[k].out.ground;
  }
  floor_ = ground_;
  // Rows by z: a sample within reach of a point of the chord differs from it in z by the reach
  // at most, and the chord's z lies between its ends'. Rows' z falls with the row.
  // Their distances from the polar axis rise with the row in the north and fall in the south.
  // Beyond 45° of latitude those change faster than z from row to row, so the rows within reach
  // are found by both: beside a pole z changes by a hair's breadth and its bounds held every row
  // of a tile (a tile beside the north pole took 60 times as long as one on plain land).
  std::vector<double>& row_z = row_z_;
  std::vector<double>& row_axis = row_axis_;
  row_z.resize(static_cast<std::size_t>(grid.rows));
  row_axis.resize(row_z.size());
  for (int r = 0; r < grid.rows; ++r) {
    const std::size_t first = static_cast<std::size_t>(r) * static_cast<std::size_t>(grid.cols);
    row_z[static_cast<std::size_t>(r)] = direction_[2][first];
    row_axis[static_cast<std::size_t>(r)] =
        axis_distance({direction_[0][first], direction_[1][first], 0.0});
  }
  const bool north = row_z.back() >= row_axis.back();
  const bool south = row_z.front() <= -row_axis.front();
  const GridBounds bounds = grid_bounds(grid, row_z, row_axis, north || south, reach);

  // Each floored edge (drain or valley) once, from the lower-numbered of its two triangles, onto
  // the samples of the rows and columns within reach of it.
  const FloorSamples samples{direction_[0].data(), direction_[1].data(),
                             direction_[2].data(), ground_.data(),
                             floor_.data(),        static_cast<std::size_t>(grid.cols)};
  const auto draw = [&](const floors::DrainSegment& segment, int r_first, int r_end, int c_first,
                        int c_end) {
    for (int r = r_first; r < r_end; ++r) {
      const std::size_t row = static_cast<std::size_t>(r) * samples.cols;
      draw_floor<true>(segment, shape, samples, row + static_cast<std::size_t>(c_first),
                       row + static_cast<std::size_t>(c_end));
    }
  };
  const Geodesy& geodesy = planet_->geodesy();
  const double flattening = planet_->definition().flattening;
  const double west = grid.longitude.front(), east = grid.longitude.back();
  // A meridian's plane holds its column's samples (to rounding), so a sample within reach of a
  // point of the chord has that point within the reach of its column's plane.
  const double slab = reach + 1e-15;
  // The last edge's rows and columns, where the next one's are looked for first.
  int r_first = 0, r_end = 0, c_first = 0, c_end = 0;
  for_each_floored_edge(
      [&](const Vec3d& a, const Vec3d& b) { return bounds.near(a, b); },
      [&](const Vertex& a, const Vertex& b) {
        const floors::DrainSegment segment = floors::drain_segment(a, b, shape);
        const double z_lo = std::min(a.p[2], b.p[2]) - slab, z_hi = std::max(a.p[2], b.p[2]) + slab;
        r_first = first_where_not_from(r_first, 0, grid.rows, [&](int r) {
          return row_z[static_cast<std::size_t>(r)] > z_hi;
        });
        r_end = first_where_not_from(r_end, r_first, grid.rows, [&](int r) {
          return row_z[static_cast<std::size_t>(r)] >= z_lo;
        });
        if (north || south) {
          const double axis_lo = chord_axis_distance(a.p, b.p) - slab;
          const double axis_hi = std::max(axis_distance(a.p), axis_distance(b.p)) + slab;
          const auto before = [&](int r) {
            const double axis = row_axis[static_cast<std::size_t>(r)];
            return north ? axis < axis_lo : axis > axis_hi;
          };
          const auto within = [&](int r) {
            const double axis = row_axis[static_cast<std::size_t>(r)];
            return north ? axis <= axis_hi : axis >= axis_lo;
          };
          r_first = std::max(r_first, first_where_not(r_first, r_end, before));
          r_end = std::min(r_end, first_where_not(r_first, r_end, within));
        }
        if (r_first >= r_end) return;
        if (bounds.meridians) {
          // The plane of column c: (−sin λ_c, cos λ_c, 0)·q falls as c goes east while the grid
          // spans less than a sixth of a turn.
          const auto across_meridian = [&](std::size_t c, const Vec3d& q) {
            return -q[0] * grid.sin_lon[c] + q[1] * grid.cos_lon[c];
          };
          c_first = first_where_not_from(c_first, 0, grid.cols, [&](int c) {
            const auto column = static_cast<std::size_t>(c);
            return std::min(across_meridian(column, a.p), across_meridian(column, b.p)) > slab;
          });
          c_end = first_where_not_from(c_end, c_first, grid.cols, [&](int c) {
            const auto column = static_cast<std::size_t>(c);
            return std::max(across_meridian(column, a.p), across_meridian(column, b.p)) >= -slab;
          });
          draw(segment, r_first, r_end, c_first, c_end);
          return;
        }
        // A grid a sixth of a turn wide or more (zooms 0 and 1): columns by longitude. Degrees
        // within reach: the reach as an angle, widened for the ellipsoid's geodetic latitude (at
        // most 1 + 2f of it) and for the arc's bulge beyond the chord.
        const double margin =
            ((1.0 + 2.0 * flattening) * reach * 1.001 + 0.125 * dot(segment.ab, segment.ab)) /
                kDegree +
            1e-9;
        double lat_a = 0.0, lon_a = 0.0, lat_b = 0.0, lon_b = 0.0;
        geodesy.direction_to_geographic(a.p, lat_a, lon_a);
        geodesy.direction_to_geographic(b.p, lat_b, lon_b);
        if (lon_b - lon_a > 180.0) lon_b -= 360.0;
        if (lon_a - lon_b > 180.0) lon_b += 360.0;
        const double polar = std::max(std::abs(lat_a), std::abs(lat_b)) + margin;
        const double widen = polar < 89.0 ? margin / std::cos(polar * kDegree) : 360.0;
        for (const double turn : {-360.0, 0.0, 360.0}) {
          const double lon_lo = std::min(lon_a, lon_b) + turn - widen;
          const double lon_hi = std::max(lon_a, lon_b) + turn + widen;
          if (lon_hi < west || lon_lo > east) continue;
          const auto [first, end] = columns_between(grid.longitude, lon_lo, lon_hi);
          draw(segment, r_first, r_end, first, end);
        }
      });
  for (std::size_t k = 0; k < count; ++k) {
    const double lowest = floor_[order_[k] - base];
    if (!std::isnan(lowest)) pending_[k].out.ground = lowest;
  }
}

void Sampler::draw_floors_by_bins(int level) {
  // Only land samples take floors, so only they are binned.
  land_.clear();
  for (std::size_t k = 0; k < pending_.size(); ++k) {
    if (pending_[k].face == FaceType::land) land_.push_back(k);
  }
  if (land_.empty()) return;
  const floors::FloorShape shape = floors::floor_shape(planet_->rules(), level);
  const double reach = shape.search_chord() + 1e-14;

  // The samples' directions are warped (Planet::warp), so a band's rows are no longer lines of
  // latitude: the samples are binned instead, by their coordinates in the plane tangent to the
  // band's middle sample. Projecting onto it moves no two points farther apart than they are,
  // so a sample within reach of a point of a chord lies within reach of it in both coordinates,
  // and an edge's bins are those its end points' box, widened by the reach, overlaps.
  // (Not a structured binding: clang 14, which builds the fuzzers, cannot capture one.)
  const std::pair<Vec3d, Vec3d> axes = tangent_axes(pending_directions_[land_[land_.size() / 2]]);
  const Vec3d east = axes.first, north = axes.second;
  double u_lo = std::numeric_limits<double>::infinity(), u_hi = -u_lo, v_lo = u_lo, v_hi = -u_lo;
  for (const std::size_t k : land_) {
    const double u = dot(pending_directions_[k], east), v = dot(pending_directions_[k], north);
    u_lo = std::min(u_lo, u);
    u_hi = std::max(u_hi, u);
    v_lo = std::min(v_lo, v);
    v_hi = std::max(v_hi, v);
  }
  // Bins about a sample wide (reach is a sample and a half), fewer where a band is wide (zooms
  // 0 and 1, where the plane folds the far side of the sphere onto the near one).
  double bin = shape.reach_chord() / 1.5;
  const double land = static_cast<double>(land_.size());
  while ((u_hi - u_lo) / bin * ((v_hi - v_lo) / bin) > 4.0 * land + 4096.0) bin *= 2.0;
  const auto cells = [&](double extent) {
    return static_cast<std::size_t>(std::max(0.0, std::floor(extent / bin))) + 1;
  };
  const std::size_t nu = cells(u_hi - u_lo), nv = cells(v_hi - v_lo);
  const auto cell = [&](double value, double lo, std::size_t n) {
    const double index = std::floor((value - lo) / bin);
    return static_cast<std::size_t>(std::clamp(index, 0.0, static_cast<double>(n - 1)));
  };
  // A counting sort of the land samples by bin, row of bins by row of bins.
  bin_start_.assign(nu * nv + 1, 0);
  bin_of_.resize(land_.size());
  for (std::size_t i = 0; i < land_.size(); ++i) {
    const Vec3d& q = pending_directions_[land_[i]];
    bin_of_[i] = cell(dot(q, north), v_lo, nv) * nu + cell(dot(q, east), u_lo, nu);
    ++bin_start_[bin_of_[i] + 1];
  }
  for (std::size_t b = 0; b < nu * nv; ++b) bin_start_[b + 1] += bin_start_[b];
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ground_.assign(land_.size() + kLanes, nan);
  for (std::vector<double>& axis : direction_) axis.assign(land_.size() + kLanes, 0.0);
  slot_.resize(land_.size());
  {
    std::vector<std::size_t>& next = bin_next_;
    next.assign(bin_start_.begin(), bin_start_.end() - 1);
    for (std::size_t i = 0; i < land_.size(); ++i) {
      const std::size_t slot = next[bin_of_[i]]++;
      slot_[i] = slot;
      const Vec3d& q = pending_directions_[land_[i]];
      for (std::size_t j = 0; j < 3; ++j) direction_[j][slot] = q[j];
      ground_[slot] = pending_[land_[i]].out.ground;
    }
  }
  floor_ = ground_;
  // Whether the chord from a to b comes within reach of the land samples' box.
  const auto near = [&](const Vec3d& a, const Vec3d& b) {
    const double ua = dot(a, east), ub = dot(b, east), va = dot(a, north), vb = dot(b, north);
    return std::max(ua, ub) >= u_lo - reach && std::min(ua, ub) <= u_hi + reach &&
           std::max(va, vb) >= v_lo - reach && std::min(va, vb) <= v_hi + reach;
  };

  // Each floored edge (drain or valley) once, from the lower-numbered of its two triangles, onto
  // the samples of the bins within reach of it: one run of the packed arrays per row of bins.
  const FloorSamples samples{direction_[0].data(), direction_[1].data(), direction_[2].data(),
                             ground_.data(),       floor_.data(),        0};
  for_each_floored_edge(near, [&](const Vertex& a, const Vertex& b) {
    const double ua = dot(a.p, east), ub = dot(b.p, east), va = dot(a.p, north),
                 vb = dot(b.p, north);
    const std::size_t u_first = cell(std::min(ua, ub) - reach, u_lo, nu);
    const std::size_t u_last = cell(std::max(ua, ub) + reach, u_lo, nu);
    const std::size_t v_first = cell(std::min(va, vb) - reach, v_lo, nv);
    const std::size_t v_last = cell(std::max(va, vb) + reach, v_lo, nv);
    const floors::DrainSegment segment = floors::drain_segment(a, b, shape);
    for (std::size_t row = v_first; row <= v_last; ++row) {
      draw_floor<false>(segment, shape, samples, bin_start_[row * nu + u_first],
                        bin_start_[row * nu + u_last + 1]);
    }
  });
  for (std::size_t i = 0; i < land_.size(); ++i) {
    const double lowest = floor_[slot_[i]];
    if (!std::isnan(lowest)) pending_[land_[i]].out.ground = lowest;
  }
}

}  // namespace planet
