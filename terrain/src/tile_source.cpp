#include "terrain/tile_source.hpp"

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/LocalCartesian.hpp>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>

namespace terrain {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;
// EPSG:3857 uses a sphere of the WGS84 equatorial radius.
constexpr double kMercatorRadius = kWebMercatorRadius;
constexpr double kMercatorHalfWorld = std::numbers::pi * kMercatorRadius;

double mercator_latitude(double y_metres) {
  return std::atan(std::sinh(y_metres / kMercatorRadius)) / kDegree;
}
double mercator_y(double latitude) {
  const double clamped = std::clamp(latitude, -85.0511287798066, 85.0511287798066);
  return kMercatorRadius * std::asinh(std::tan(clamped * kDegree));
}

const GeographicLib::Geocentric& ellipsoid() {
  return GeographicLib::Geocentric::WGS84();
}

bool is_power_of_two(int n) {
  return n > 0 && (n & (n - 1)) == 0;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// GeoFrame

GeoFrame::GeoFrame(const Georeference& georeference) : georeference_(georeference) {
  const double lat = georeference.latitude * kDegree, lon = georeference.longitude * kDegree;
  ellipsoid().Forward(georeference.latitude, georeference.longitude, 0.0, origin_[0], origin_[1],
                      origin_[2]);
  const double sl = std::sin(lat), cl = std::cos(lat), so = std::sin(lon), co = std::cos(lon);
  east_[0] = -so, east_[1] = co, east_[2] = 0.0;
  north_[0] = -sl * co, north_[1] = -sl * so, north_[2] = cl;
  up_[0] = cl * co, up_[1] = cl * so, up_[2] = sl;
  cos_heading_ = std::cos(georeference.heading * kDegree);
  sin_heading_ = std::sin(georeference.heading * kDegree);
  // On a sphere of radius R the "up" offset of a point at angle θ is R (cos θ − 1).
  min_up_ = ellipsoid().EquatorialRadius() * (std::cos(kMaxAngleDegrees * kDegree) - 1.0);
}

GeoFrame::Row GeoFrame::row(double latitude) const {
  const double phi = latitude * kDegree;
  const double s = std::sin(phi), c = std::cos(phi);
  const double a = ellipsoid().EquatorialRadius();
  const double f = ellipsoid().Flattening();
  const double e2 = f * (2.0 - f);
  const double n = a / std::sqrt(1.0 - e2 * s * s);
  return {n * c, n * (1.0 - e2) * s};
}

bool GeoFrame::project(const Row& r, double cos_lon, double sin_lon, double& x, double& y) const {
  const double d[3] = {r.cos_lat_n * cos_lon - origin_[0], r.cos_lat_n * sin_lon - origin_[1],
                       r.z - origin_[2]};
  const double up = up_[0] * d[0] + up_[1] * d[1] + up_[2] * d[2];
  const double e = east_[0] * d[0] + east_[1] * d[1];
  const double n = north_[0] * d[0] + north_[1] * d[1] + north_[2] * d[2];
  x = e * cos_heading_ - n * sin_heading_;
  y = e * sin_heading_ + n * cos_heading_;
  return up >= min_up_;
}

bool GeoFrame::to_scene(double latitude, double longitude, double& x, double& y) const {
  const double lon = longitude * kDegree;
  return project(row(latitude), std::cos(lon), std::sin(lon), x, y);
}

void GeoFrame::to_geographic(double x, double y, double& latitude, double& longitude) const {
  const double e = x * cos_heading_ + y * sin_heading_;
  const double n = -x * sin_heading_ + y * cos_heading_;
  // The ellipsoid point below (e, n, 0) along the origin's "up": a few fixed-point steps on the
  // height, which converge fast because the height changes slowly with the tangent offset.
  GeographicLib::LocalCartesian local(georeference_.latitude, georeference_.longitude, 0.0,
                                      ellipsoid());
  double up = 0.0, height = 0.0;
  for (int i = 0; i < 8; ++i) {
    local.Reverse(e, n, up, latitude, longitude, height);
    up -= height;
    if (std::abs(height) < 1e-6) break;
  }
}

void GeoFrame::scene_to_east_north(float gx, float gy, float& east, float& north) const {
  const auto c = static_cast<float>(cos_heading_), s = static_cast<float>(sin_heading_);
  east = gx * c + gy * s;
  north = -gx * s + gy * c;
}

// ---------------------------------------------------------------------------------------------
// TileSource

Result<TileSource> TileSource::from_scene(const Scene& scene) {
  TileSource source;
  Result<Program> terrain = compile(scene);
  if (!terrain) return terrain.error();
  source.terrain = std::make_shared<const Program>(std::move(*terrain));
  if (scene.water != nullptr) {
    Result<Program> water = compile_water(scene);
    if (!water) return water.error();
    source.water = std::make_shared<const Program>(std::move(*water));
  }
  const Box2 area = scene.area();
  const double cx = 0.5 * (static_cast<double>(area.lo.x) + area.hi.x);
  const double cy = 0.5 * (static_cast<double>(area.lo.y) + area.hi.y);
  const double half = 0.5 * std::max(static_cast<double>(area.hi.x) - area.lo.x,
                                     static_cast<double>(area.hi.y) - area.lo.y);
  source.local_square = {cx - half, cy - half, cx + half, cy + half};
  source.georeference = scene.georeference;
  source.material = scene.material;
  source.base_elevation = scene.base_elevation;
  source.elevation_range = scene.bounds.elevation.hull(Interval::point(scene.base_elevation));
  return source;
}

// ---------------------------------------------------------------------------------------------
// Requests

Status validate_request(const TileRequest& request) {
  if (Status address = validate_address(request.scheme, request.address); !address) {
    return address;
  }
  if (request.layout == SampleLayout::cell_centres) {
    if (!is_power_of_two(request.cells) || request.cells < 64 || request.cells > 512) {
      return Error{
          "tile size " + std::to_string(request.cells) + " is not one of 64, 128, 256, 512",
          "/size"};
    }
    if (request.border != 0 && request.border != 1) {
      return Error{"border must be 0 or 1", "/border"};
    }
  } else {
    if (!is_power_of_two(request.cells) || request.cells < 2 || request.cells > 512) {
      return Error{
          "mesh grid " + std::to_string(request.cells + 1) + " is not 2^k + 1 between 3 and 513",
          "/grid"};
    }
    if (request.border != 0) return Error{"meshes have no border", "/border"};
  }
  return Ok{};
}

TileBounds world_bounds(const TileSource& source, TileScheme scheme) {
  switch (scheme) {
    case TileScheme::local:
      return source.local_square;
    case TileScheme::webmercator:
      return {-kMercatorHalfWorld, -kMercatorHalfWorld, kMercatorHalfWorld, kMercatorHalfWorld};
    case TileScheme::geographic:
      return {-180.0, -90.0, 180.0, 90.0};
  }
  assert(false && "unknown scheme");
  return {};
}

double ground_spacing(const TileSource& source, TileScheme scheme, int z, int cells) {
  const double divisions = static_cast<double>(rows_at(scheme, z)) * cells;
  const double cos_lat = std::cos(source.georeference.latitude * kDegree);
  switch (scheme) {
    case TileScheme::local:
      return (source.local_square.north - source.local_square.south) / divisions;
    case TileScheme::webmercator:
      return 2.0 * kMercatorHalfWorld * cos_lat / divisions;
    case TileScheme::geographic:
      // One row spans 180°/divisions of latitude; columns as much of longitude, which is
      // shorter by cos(latitude): take the finer of the two.
      return std::numbers::pi * ellipsoid().EquatorialRadius() * std::min(1.0, cos_lat) / divisions;
  }
  assert(false && "unknown scheme");
  return 1.0;
}

TileRange tiles_covering_area(const TileSource& source, TileScheme scheme, int z) {
  const TileBounds world = world_bounds(source, scheme);
  const TileBounds& sq = source.local_square;
  TileBounds area = sq;  // in the scheme's coordinates
  if (scheme != TileScheme::local) {
    GeoFrame frame(source.georeference);
    double lat_lo = 90, lat_hi = -90, lon_lo = 180, lon_hi = -180;
    // The square's outline, sampled densely enough to follow the curvature of its image.
    constexpr int kSteps = 16;
    for (int i = 0; i <= kSteps; ++i) {
      const double t = static_cast<double>(i) / kSteps;
      const double xs[4] = {sq.west + t * (sq.east - sq.west), sq.east,
                            sq.west + t * (sq.east - sq.west), sq.west};
      const double ys[4] = {sq.south, sq.south + t * (sq.north - sq.south), sq.north,
                            sq.south + t * (sq.north - sq.south)};
      for (int k = 0; k < 4; ++k) {
        double lat = 0, lon = 0;
        frame.to_geographic(xs[k], ys[k], lat, lon);
        lat_lo = std::min(lat_lo, lat), lat_hi = std::max(lat_hi, lat);
        lon_lo = std::min(lon_lo, lon), lon_hi = std::max(lon_hi, lon);
      }
    }
    if (lon_hi - lon_lo > 180.0) lon_lo = -180.0, lon_hi = 180.0;  // crosses the antimeridian
    if (scheme == TileScheme::geographic) {
      area = {lon_lo, lat_lo, lon_hi, lat_hi};
    } else {
      area = {lon_lo * kDegree * kMercatorRadius, mercator_y(lat_lo),
              lon_hi * kDegree * kMercatorRadius, mercator_y(lat_hi)};
    }
  }
  const double columns = static_cast<double>(columns_at(scheme, z));
  const double rows = static_cast<double>(rows_at(scheme, z));
  const double fx0 = (area.west - world.west) / (world.east - world.west) * columns;
  const double fx1 = (area.east - world.west) / (world.east - world.west) * columns;
  const double fy0 = (world.north - area.north) / (world.north - world.south) * rows;
  const double fy1 = (world.north - area.south) / (world.north - world.south) * rows;
  TileRange range;
  range.min_x = static_cast<std::int64_t>(std::clamp(std::floor(fx0), 0.0, columns - 1));
  range.max_x = static_cast<std::int64_t>(std::clamp(std::ceil(fx1) - 1, 0.0, columns - 1));
  std::int64_t from_north_lo =
      static_cast<std::int64_t>(std::clamp(std::floor(fy0), 0.0, rows - 1));
  std::int64_t from_north_hi =
      static_cast<std::int64_t>(std::clamp(std::ceil(fy1) - 1, 0.0, rows - 1));
  if (scheme == TileScheme::geographic) {  // TMS: rows count from the south
    const auto r = static_cast<std::int64_t>(rows);
    range.min_y = r - 1 - from_north_hi;
    range.max_y = r - 1 - from_north_lo;
  } else {
    range.min_y = from_north_lo;
    range.max_y = from_north_hi;
  }
  return range;
}

// ---------------------------------------------------------------------------------------------
// TileGenerator

TileGenerator::TileGenerator(TileSource source)
    : source_(std::move(source)), frame_(source_.georeference), terrain_(*source_.terrain) {
  if (source_.water) water_ = std::make_unique<Evaluator>(*source_.water);
}

void TileGenerator::place_samples(HeightTile& tile, std::vector<std::uint8_t>& mapped) const {
  const auto count = static_cast<std::size_t>(tile.width) * static_cast<std::size_t>(tile.height);
  tile.scene_x.resize(count);
  tile.scene_y.resize(count);
  mapped.assign(count, 1);
  if (tile.scheme == TileScheme::local) {
    std::vector<double> xs(static_cast<std::size_t>(tile.width));
    for (int col = 0; col < tile.width; ++col)
      xs[static_cast<std::size_t>(col)] = tile.sample_crs_x(col);
    for (int row = 0; row < tile.height; ++row) {
      const double y = tile.sample_crs_y(row);
      std::copy(xs.begin(), xs.end(),
                tile.scene_x.begin() + static_cast<std::ptrdiff_t>(tile.index(0, row)));
      std::fill_n(tile.scene_y.begin() + static_cast<std::ptrdiff_t>(tile.index(0, row)),
                  tile.width, y);
    }
    return;
  }
  // Latitude depends on the row only and longitude on the column only: the trigonometry is
  // done once per row and column, the rest per sample.
  std::vector<double> cos_lon(static_cast<std::size_t>(tile.width));
  std::vector<double> sin_lon(static_cast<std::size_t>(tile.width));
  for (int col = 0; col < tile.width; ++col) {
    double lon = tile.sample_crs_x(col);
    if (tile.scheme == TileScheme::webmercator) lon = lon / kMercatorRadius / kDegree;
    cos_lon[static_cast<std::size_t>(col)] = std::cos(lon * kDegree);
    sin_lon[static_cast<std::size_t>(col)] = std::sin(lon * kDegree);
  }
  for (int row = 0; row < tile.height; ++row) {
    double lat = tile.sample_crs_y(row);
    if (tile.scheme == TileScheme::webmercator) lat = mercator_latitude(lat);
    // A border row beyond a pole (geographic scheme) mirrors nothing: clamp it to the pole.
    lat = std::clamp(lat, -90.0, 90.0);
    const GeoFrame::Row r = frame_.row(lat);
    for (int col = 0; col < tile.width; ++col) {
      const std::size_t at = tile.index(col, row);
      mapped[at] =
          frame_.project(r, cos_lon[static_cast<std::size_t>(col)],
                         sin_lon[static_cast<std::size_t>(col)], tile.scene_x[at], tile.scene_y[at])
              ? 1
              : 0;
    }
  }
}

void TileGenerator::evaluate(Evaluator& evaluator, const HeightTile& tile,
                             const std::vector<std::uint8_t>& mapped, float spacing,
                             std::vector<float>& elevation, std::vector<float>* gx,
                             std::vector<float>* gy, std::vector<float>* weight,
                             const BlockFilter& skip) {
  constexpr int kSide = 8;  // 8×8 = kBlockSize points per block: compact boxes cull well
  PointBlock block;
  FieldBlock out;
  int index[kBlockSize];
  for (int by = 0; by < tile.height; by += kSide) {
    for (int bx = 0; bx < tile.width; bx += kSide) {
      block.count = 0;
      block.spacing = spacing;
      for (int row = by; row < std::min(by + kSide, tile.height); ++row) {
        for (int col = bx; col < std::min(bx + kSide, tile.width); ++col) {
          const std::size_t at = tile.index(col, row);
          if (mapped[at] == 0) continue;
          index[block.count] = static_cast<int>(at);
          block.x[block.count] = static_cast<float>(tile.scene_x[at]);
          block.y[block.count] = static_cast<float>(tile.scene_y[at]);
          ++block.count;
        }
      }
      if (block.count == 0) continue;
      block.recompute_box();
      if (skip && skip(block, index)) continue;
      evaluator.evaluate(block, out);
      const auto scatter = [&](const float* values, std::vector<float>* to) {
        if (to == nullptr) return;
        for (int k = 0; k < block.count; ++k) (*to)[static_cast<std::size_t>(index[k])] = values[k];
      };
      scatter(out.f, &elevation);
      scatter(out.fx, gx);
      scatter(out.fy, gy);
      scatter(out.a, weight);
    }
  }
}

bool TileGenerator::evaluate_on_backend(const HeightTile& tile,
                                        const std::vector<std::uint8_t>& mapped,
                                        std::vector<float>& elevation, std::vector<float>& gx,
                                        std::vector<float>& gy) {
  last_backend_ = "cpu";
  if (!backend_) return false;
  // The same floats the CPU path evaluates (positions rounded once from double).
  std::vector<float> x, y;
  std::vector<std::size_t> at;
  x.reserve(mapped.size());
  y.reserve(mapped.size());
  at.reserve(mapped.size());
  for (std::size_t i = 0; i < mapped.size(); ++i) {
    if (mapped[i] == 0) continue;
    x.push_back(static_cast<float>(tile.scene_x[i]));
    y.push_back(static_cast<float>(tile.scene_y[i]));
    at.push_back(i);
  }
  std::vector<float> f(x.size()), fx(x.size()), fy(x.size());
  const Status done =
      backend_->evaluate(*source_.terrain, x, y, static_cast<float>(tile.ground_spacing), f.data(),
                         fx.data(), fy.data());
  if (!done) {
    last_backend_ = "cpu (fallback: " + done.error().message + ")";
    return false;
  }
  for (std::size_t k = 0; k < at.size(); ++k) {
    elevation[at[k]] = f[k];
    gx[at[k]] = fx[k];
    gy[at[k]] = fy[k];
  }
  last_backend_ = backend_->name();
  return true;
}

Result<HeightTile> TileGenerator::height_tile(const TileRequest& request) {
  std::vector<std::uint8_t> mapped;
  return height_tile(request, mapped);
}

HeightTile tile_layout_for(const TileRequest& request) {
  HeightTile tile;
  tile.scheme = request.scheme;
  tile.address = request.address;
  tile.layout = request.layout;
  tile.cells = request.cells;
  tile.border = request.border;
  tile.width = tile.height = request.layout == SampleLayout::cell_centres
                                 ? request.cells + 2 * request.border
                                 : request.cells + 1;
  return tile;
}

Result<HeightTile> TileGenerator::height_tile(const TileRequest& request,
                                              std::vector<std::uint8_t>& mapped) {
  if (Status valid = validate_request(request); !valid) return valid.error();
  HeightTile tile = tile_layout_for(request);
  tile.world = world_bounds(source_, request.scheme);
  tile.bounds = tile_footprint(tile.scheme, tile.world, tile.address);
  tile.ground_spacing = ground_spacing(source_, request.scheme, request.address.z, request.cells);

  place_samples(tile, mapped);
  const auto count = tile.scene_x.size();
  tile.elevation.assign(count, source_.base_elevation);
  tile.slope_east.assign(count, 0.0f);
  tile.slope_north.assign(count, 0.0f);
  if (!evaluate_on_backend(tile, mapped, tile.elevation, tile.slope_east, tile.slope_north)) {
    evaluate(terrain_, tile, mapped, static_cast<float>(tile.ground_spacing), tile.elevation,
             &tile.slope_east, &tile.slope_north, nullptr);
  }
  if (tile.scheme != TileScheme::local) {
    for (std::size_t i = 0; i < count; ++i) {
      frame_.scene_to_east_north(tile.slope_east[i], tile.slope_north[i], tile.slope_east[i],
                                 tile.slope_north[i]);
    }
  }
  return tile;
}

Result<HeightTile> TileGenerator::height_tile_with_water(const TileRequest& request,
                                                         std::vector<float>& water_surface,
                                                         float depth_of_interest) {
  water_surface.clear();
  std::vector<std::uint8_t> mapped;  // the samples' positions are placed once, for both trees
  Result<HeightTile> terrain = height_tile(request, mapped);
  if (!terrain || !water_) return terrain;
  const HeightTile& tile = *terrain;
  water_surface.assign(tile.elevation.size(), -1e30f);
  std::vector<float> weight(tile.elevation.size(), 0.0f);
  const auto spacing = static_cast<float>(tile.ground_spacing);
  // Most of a scene is dry: where the water's bounds over a block lie deeper below its ground
  // than the caller looks, the block keeps weight 0 (NaN below) without being evaluated. The
  // bounds are sound for the float evaluation; the margin covers their own rounding.
  const auto out_of_interest = [&](const PointBlock& block, const int* index) {
    float lowest_ground = INFINITY;
    for (int k = 0; k < block.count; ++k) {
      lowest_ground = std::min(lowest_ground, tile.elevation[static_cast<std::size_t>(index[k])]);
    }
    const NodeBounds bounds = water_->bounds({block.box, spacing, spacing});
    const float top = bounds.elevation.hi;
    const float margin = 1e-3f + 1e-5f * std::max(std::abs(top), std::abs(lowest_ground));
    return bounds.weight.hi < 0.5f || top + margin < lowest_ground - depth_of_interest;
  };
  evaluate(*water_, tile, mapped, spacing, water_surface, nullptr, nullptr, &weight,
           std::isfinite(depth_of_interest) ? BlockFilter(out_of_interest) : BlockFilter());
  for (std::size_t i = 0; i < water_surface.size(); ++i) {
    if (!(weight[i] >= 0.5f)) water_surface[i] = std::numeric_limits<float>::quiet_NaN();
  }
  return terrain;
}

Result<std::vector<std::uint8_t>> TileGenerator::water_mask(TileScheme scheme,
                                                            const TileAddress& address) {
  if (!water_) return std::vector<std::uint8_t>{0};
  std::vector<float> surface;
  Result<HeightTile> terrain =
      height_tile_with_water({scheme, address, SampleLayout::cell_centres, 256, 0}, surface, 0.0f);
  if (!terrain) return terrain.error();
  std::vector<std::uint8_t> mask(surface.size());
  bool any_land = false, any_water = false;
  for (std::size_t i = 0; i < mask.size(); ++i) {
    const bool wet = surface[i] > terrain->elevation[i];  // false for NaN: no water here
    mask[i] = wet ? 255 : 0;
    (wet ? any_water : any_land) = true;
  }
  if (!any_water) return std::vector<std::uint8_t>{0};
  if (!any_land) return std::vector<std::uint8_t>{255};
  return mask;
}

}  // namespace terrain
