// quantized-mesh-1.0 encoder, oct-encoded normals and layer.json (quantized_mesh.hpp). The
// decoder lives in quantized_mesh_decode.cpp and shares nothing with this file.
#include "terrain/quantized_mesh.hpp"

#include <GeographicLib/Geocentric.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

namespace terrain {

namespace {

using Vec3 = std::array<double, 3>;

constexpr int kMaxQuantized = 32767;
constexpr int kMaxTileRefinement = 20;  // j ≤ 20: q ≥ Q / 2^20
constexpr double kMinEdgeQuantum = 1.0 / 1024.0;
constexpr std::uint8_t kNormalsId = 1, kWaterMaskId = 2, kMetadataId = 4;

std::string num(double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

double dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec3& a) {
  return std::sqrt(dot(a, a));
}
Vec3 scaled(const Vec3& a, double s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
double dist(const Vec3& a, const Vec3& b) {
  return norm({a[0] - b[0], a[1] - b[1], a[2] - b[2]});
}

bool float_exact(double v) {
  return std::abs(v) < 1e38 && static_cast<double>(static_cast<float>(v)) == v;
}

bool power_of_two(double v) {
  int exponent = 0;
  return std::isfinite(v) && v > 0.0 && std::frexp(v, &exponent) == 0.5;
}

// JavaScript's Math.round (halves go up), which Cesium's toSNorm uses.
double js_round(double v) {
  return std::floor(v + 0.5);
}
double sign_not_zero(double v) {
  return v < 0.0 ? -1.0 : 1.0;
}

std::uint16_t zig_zag(int delta) {
  return static_cast<std::uint16_t>(static_cast<unsigned>(delta < 0 ? -2 * delta - 1 : 2 * delta));
}

class Writer {
 public:
  explicit Writer(std::vector<std::uint8_t>& out) : out_(out) {}
  void u8(std::uint8_t v) { out_.push_back(v); }
  void u16(std::uint16_t v) { little(v, 2); }
  void u32(std::uint32_t v) { little(v, 4); }
  void f32(float v) { little(std::bit_cast<std::uint32_t>(v), 4); }
  void f64(double v) { little(std::bit_cast<std::uint64_t>(v), 8); }
  void index(std::uint32_t v, bool wide) {
    if (wide) {
      u32(v);
    } else {
      u16(static_cast<std::uint16_t>(v));
    }
  }
  void bytes(const std::uint8_t* data, std::size_t size) {
    out_.insert(out_.end(), data, data + size);
  }
  std::size_t size() const { return out_.size(); }

 private:
  void little(std::uint64_t v, int count) {
    for (int i = 0; i < count; ++i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  std::vector<std::uint8_t>& out_;
};

// The smallest sphere of two candidates, as Cesium's BoundingSphere.fromPoints does: the box
// centre and a Ritter sphere; the radius is the largest distance from the chosen centre, so it
// holds every point whatever rounding the centre carries.
void bounding_sphere(const std::vector<Vec3>& points, Vec3& center, double& radius) {
  Vec3 lo = points[0], hi = points[0];
  std::array<std::size_t, 3> min_at{}, max_at{};
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      if (points[i][a] < lo[a]) {
        lo[a] = points[i][a];
        min_at[a] = i;
      }
      if (points[i][a] > hi[a]) {
        hi[a] = points[i][a];
        max_at[a] = i;
      }
    }
  }
  const auto farthest = [&](const Vec3& c) {
    double r = 0.0;
    for (const Vec3& p : points) r = std::max(r, dist(c, p));
    return r;
  };
  const Vec3 box{(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
  const double box_radius = farthest(box);

  int axis = 0;
  for (int a = 1; a < 3; ++a) {
    if (dist(points[min_at[a]], points[max_at[a]]) >
        dist(points[min_at[axis]], points[max_at[axis]])) {
      axis = a;
    }
  }
  const Vec3& p = points[min_at[axis]];
  const Vec3& q = points[max_at[axis]];
  Vec3 c{(p[0] + q[0]) / 2, (p[1] + q[1]) / 2, (p[2] + q[2]) / 2};
  double r = dist(p, q) / 2;
  for (const Vec3& x : points) {
    const double d = dist(c, x);
    if (d > r) {  // grow to hold x, keeping the far side of the old sphere
      const double grown = (r + d) / 2;
      const double shift = grown - r;
      for (int a = 0; a < 3; ++a) c[a] += (x[a] - c[a]) / d * shift;
      r = grown;
    }
  }
  const double ritter_radius = farthest(c);
  if (ritter_radius < box_radius) {
    center = c, radius = ritter_radius;
  } else {
    center = box, radius = box_radius;
  }
}

// Cesium's EllipsoidalOccluder.computeHorizonCullingPointPossiblyUnderEllipsoid with the
// direction to the bounding sphere's centre. Tiles too large for any finite point (the
// hemisphere-wide zoom-0 tiles) get a point far along that direction instead, which is culled
// only when the camera is behind the globe as seen from the tile.
Vec3 horizon_occlusion_point(const std::vector<Vec3>& positions, const Vec3& direction,
                             double minimum_height) {
  const GeographicLib::Geocentric& earth = GeographicLib::Geocentric::WGS84();
  const double a = earth.EquatorialRadius();
  const double b = a * (1.0 - earth.Flattening());
  Vec3 radii{a, a, b};
  if (minimum_height < 0.0 && b > -minimum_height) {
    radii = {a + minimum_height, a + minimum_height, b + minimum_height};
  }
  const auto to_scaled = [&](const Vec3& p) {
    return Vec3{p[0] / radii[0], p[1] / radii[1], p[2] / radii[2]};
  };
  Vec3 d = to_scaled(direction);
  const double d_norm = norm(d);
  if (d_norm == 0.0) return {0.0, 0.0, 0.0};
  d = scaled(d, 1.0 / d_norm);
  double magnitude = 0.0;
  bool valid = true;
  for (const Vec3& position : positions) {
    const Vec3 s = to_scaled(position);
    double m2 = dot(s, s);
    double m = std::sqrt(m2);
    const Vec3 dir = scaled(s, 1.0 / m);
    m2 = std::max(1.0, m2);
    m = std::max(1.0, m);
    const double cos_alpha = dot(dir, d);
    const double sin_alpha = norm(cross(dir, d));
    const double cos_beta = 1.0 / m;
    const double sin_beta = std::sqrt(m2 - 1.0) * cos_beta;
    const double candidate = 1.0 / (cos_alpha * cos_beta - sin_alpha * sin_beta);
    if (candidate < 0.0) {
      valid = false;
      break;
    }
    magnitude = std::max(magnitude, candidate);
  }
  if (!valid || !(magnitude > 0.0) || !std::isfinite(magnitude)) magnitude = 1e6;
  return scaled(d, magnitude);
}

// The exact normal from the slopes, rotated from east-north-up at (lat, lon) to ECEF.
Vec3 ecef_normal(double lon_deg, double lat_deg, double slope_east, double slope_north) {
  const double lon = lon_deg * std::numbers::pi / 180.0, lat = lat_deg * std::numbers::pi / 180.0;
  const double sl = std::sin(lon), cl = std::cos(lon), sp = std::sin(lat), cp = std::cos(lat);
  const Vec3 east{-sl, cl, 0.0}, north{-sp * cl, -sp * sl, cp}, up{cp * cl, cp * sl, sp};
  const double length = std::sqrt(slope_east * slope_east + slope_north * slope_north + 1.0);
  const double e = -slope_east / length, n = -slope_north / length, u = 1.0 / length;
  Vec3 v{};
  for (int i = 0; i < 3; ++i) v[i] = e * east[i] + n * north[i] + u * up[i];
  return v;
}

Status check_tile(const HeightTile& tile, const TileMesh& mesh, bool normals) {
  if (tile.scheme != TileScheme::geographic) {
    return Error{"quantized-mesh needs a geographic-scheme tile, got " +
                     std::string(scheme_name(tile.scheme)),
                 "/scheme"};
  }
  if (tile.layout != SampleLayout::cell_corners || tile.border != 0) {
    return Error{"quantized-mesh needs cell_corners samples without border", "/layout"};
  }
  const int n = tile.width;
  if (n < 2 || n > 32768 || tile.height != n || tile.cells + 1 != n) {
    return Error{"tile grid must be square with cells + 1 (2..32768) samples per side", "/width"};
  }
  if (mesh.grid_size != n) {
    return Error{"mesh grid size " + std::to_string(mesh.grid_size) +
                     " does not match the tile's " + std::to_string(n),
                 "/mesh/grid_size"};
  }
  const std::size_t count = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  if (tile.elevation.size() != count) {
    return Error{"elevation has " + std::to_string(tile.elevation.size()) + " samples, expected " +
                     std::to_string(count),
                 "/elevation"};
  }
  for (std::size_t i = 0; i < count; ++i) {
    if (!std::isfinite(tile.elevation[i])) {
      return Error{"elevation is not finite", "/elevation/" + std::to_string(i)};
    }
  }
  if (normals) {
    for (const auto* slopes : {&tile.slope_east, &tile.slope_north}) {
      const char* name = slopes == &tile.slope_east ? "/slope_east" : "/slope_north";
      if (slopes->size() != count) {
        return Error{"normals need one slope per sample, got " + std::to_string(slopes->size()),
                     name};
      }
      for (std::size_t i = 0; i < count; ++i) {
        if (!std::isfinite((*slopes)[i])) {
          return Error{"slope is not finite", name + std::string("/") + std::to_string(i)};
        }
      }
    }
  }
  const TileBounds& b = tile.bounds;
  if (!(b.west >= -180.0 && b.west < b.east && b.east <= 180.0 && b.south >= -90.0 &&
        b.south < b.north && b.north <= 90.0)) {
    return Error{"tile bounds must be degrees with west < east and south < north", "/bounds"};
  }
  if (mesh.vertices.empty()) return Error{"mesh has no vertices", "/mesh/vertices"};
  if (mesh.vertices.size() > std::numeric_limits<std::uint32_t>::max()) {
    return Error{"mesh has too many vertices", "/mesh/vertices"};
  }
  std::vector<std::uint8_t> seen(count, 0);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const std::uint32_t g = mesh.vertices[i];
    if (g >= count || seen[g] != 0) {
      return Error{g >= count ? "vertex outside the grid" : "grid sample listed twice",
                   "/mesh/vertices/" + std::to_string(i)};
    }
    seen[g] = 1;
  }
  if (mesh.triangles.size() % 3 != 0) {
    return Error{"triangle list length is not a multiple of 3", "/mesh/triangles"};
  }
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    if (mesh.triangles[i] >= mesh.vertices.size()) {
      return Error{"triangle index " + std::to_string(mesh.triangles[i]) + " out of range",
                   "/mesh/triangles/" + std::to_string(i)};
    }
  }
  return Ok{};
}

Status check_options(const QuantizedMeshOptions& options) {
  const double q = options.edge_quantum;
  if (!power_of_two(q) || q < std::ldexp(1.0, -30) || q > std::ldexp(1.0, 20)) {
    return Error{"edge_quantum must be a power of two between 2^-30 and 2^20 metres, got " + num(q),
                 "/options/edge_quantum"};
  }
  if (options.water_mask && options.water_mask->size() != 1 &&
      options.water_mask->size() != 256 * 256) {
    return Error{
        "water mask must have 1 or 65536 bytes, got " + std::to_string(options.water_mask->size()),
        "/options/water_mask"};
  }
  if (options.metadata) {
    if (options.metadata->size() > std::numeric_limits<std::uint32_t>::max() - 4 ||
        !nlohmann::json::accept(*options.metadata)) {
      return Error{"metadata is not a JSON text", "/options/metadata"};
    }
  }
  return Ok{};
}

}  // namespace

double edge_quantum_for(double elevation_range) {
  double q = kMinEdgeQuantum;
  if (!(elevation_range > 0.0)) return q;
  if (!std::isfinite(elevation_range)) return std::numeric_limits<double>::infinity();
  while ((kMaxQuantized - 1) * q < elevation_range) q *= 2.0;
  return q;
}

double edge_quantum_for(double lowest, double highest) {
  double q = edge_quantum_for(highest - lowest);
  if (!std::isfinite(q) || !std::isfinite(lowest) || !std::isfinite(highest)) {
    return std::numeric_limits<double>::infinity();
  }
  // A header's m lies up to one Q beyond the farthest height and M = m + 32767·q: both are
  // multiples of q, exact in float while |value|/q < 2^24.
  constexpr double kFloatExactSteps = 16777216.0;
  const double farthest = std::max(std::abs(lowest), std::abs(highest));
  while (farthest / q + 2.0 * (kMaxQuantized + 1) >= kFloatExactSteps) q *= 2.0;
  return q;
}

std::array<std::uint8_t, 2> oct_encode(const std::array<double, 3>& unit) {
  const double l1 = std::abs(unit[0]) + std::abs(unit[1]) + std::abs(unit[2]);
  double x = unit[0] / l1, y = unit[1] / l1;
  if (unit[2] < 0.0) {
    const double ox = x, oy = y;
    x = (1.0 - std::abs(oy)) * sign_not_zero(ox);
    y = (1.0 - std::abs(ox)) * sign_not_zero(oy);
  }
  const auto snorm = [](double v) {
    return static_cast<std::uint8_t>(js_round((std::clamp(v, -1.0, 1.0) * 0.5 + 0.5) * 255.0));
  };
  return {snorm(x), snorm(y)};
}

std::array<double, 3> oct_decode(std::uint8_t ex, std::uint8_t ey) {
  double x = ex / 255.0 * 2.0 - 1.0, y = ey / 255.0 * 2.0 - 1.0;
  const double z = 1.0 - (std::abs(x) + std::abs(y));
  if (z < 0.0) {
    const double ox = x;
    x = (1.0 - std::abs(y)) * sign_not_zero(ox);
    y = (1.0 - std::abs(ox)) * sign_not_zero(y);
  }
  const Vec3 v{x, y, z};
  return scaled(v, 1.0 / norm(v));
}

Result<std::vector<std::uint8_t>> encode_quantized_mesh(const HeightTile& tile,
                                                        const TileMesh& mesh,
                                                        const QuantizedMeshOptions& options) {
  if (Status s = check_tile(tile, mesh, options.normals); !s) return s.error();
  if (Status s = check_options(options); !s) return s.error();
  const int n = tile.width;
  const std::size_t vertex_count = mesh.vertices.size();

  // The high-water-mark code needs every index to be at most one above the highest so far:
  // number vertices by first use in the triangle list, unused ones last.
  std::vector<std::uint32_t> order;  // new position → index into mesh.vertices
  std::vector<std::uint32_t> renumber(vertex_count, std::numeric_limits<std::uint32_t>::max());
  order.reserve(vertex_count);
  for (std::uint32_t t : mesh.triangles) {
    if (renumber[t] == std::numeric_limits<std::uint32_t>::max()) {
      renumber[t] = static_cast<std::uint32_t>(order.size());
      order.push_back(t);
    }
  }
  for (std::uint32_t i = 0; i < vertex_count; ++i) {
    if (renumber[i] == std::numeric_limits<std::uint32_t>::max()) {
      renumber[i] = static_cast<std::uint32_t>(order.size());
      order.push_back(i);
    }
  }

  // Heights: edge vertices on multiples of Q, the rest on multiples of the tile's q.
  const double big_q = options.edge_quantum;
  const auto column_of = [n](std::uint32_t g) {
    return static_cast<int>(g % static_cast<unsigned>(n));
  };
  const auto row_of = [n](std::uint32_t g) {
    return static_cast<int>(g / static_cast<unsigned>(n));
  };
  const auto on_edge = [n](int column, int row) {
    return column == 0 || row == 0 || column == n - 1 || row == n - 1;
  };
  // The header range covers every sample (not only the vertices) and the rounded edges.
  std::vector<double> target(vertex_count);  // rounded (edge) or raw (interior) heights
  const auto [lowest, highest_sample] =
      std::minmax_element(tile.elevation.begin(), tile.elevation.end());
  double lo = *lowest, hi = *highest_sample;
  for (std::size_t i = 0; i < vertex_count; ++i) {
    const std::uint32_t g = mesh.vertices[order[i]];
    const double h = tile.elevation[g];
    target[i] = on_edge(column_of(g), row_of(g)) ? std::nearbyint(h / big_q) * big_q : h;
    lo = std::min(lo, target[i]);
    hi = std::max(hi, target[i]);
  }
  const double minimum = std::floor(lo / big_q) * big_q;
  double q = 0.0;
  for (int j = kMaxTileRefinement; j >= 0; --j) {
    const double candidate = std::ldexp(big_q, -j);
    if (kMaxQuantized * candidate >= hi - minimum &&
        float_exact(minimum + kMaxQuantized * candidate)) {
      q = candidate;
      break;
    }
  }
  if (q == 0.0 || !float_exact(minimum)) {
    return Error{"tile heights " + num(lo) + " .. " + num(hi) + " do not fit 32767 steps of " +
                     "edge_quantum " + num(big_q) + " with an exact float header",
                 "/options/edge_quantum"};
  }
  const double maximum = minimum + kMaxQuantized * q;
  std::vector<std::uint16_t> us(vertex_count), vs(vertex_count), ks(vertex_count);
  for (std::size_t i = 0; i < vertex_count; ++i) {
    const std::uint32_t g = mesh.vertices[order[i]];
    const long long span = n - 1;
    // Round half up in integers: column·32767/(n−1).
    us[i] = static_cast<std::uint16_t>((2LL * column_of(g) * kMaxQuantized + span) / (2 * span));
    vs[i] =
        static_cast<std::uint16_t>((2LL * (n - 1 - row_of(g)) * kMaxQuantized + span) / (2 * span));
    const double k = std::nearbyint((target[i] - minimum) / q);  // exact on edges
    ks[i] = static_cast<std::uint16_t>(std::clamp(k, 0.0, double{kMaxQuantized}));
  }

  // Positions as a client rebuilds them (u, v over the bounds, decoded heights) for the
  // bounding volumes; normals at the exact sample positions, which neighbours share bit for bit.
  const GeographicLib::Geocentric& earth = GeographicLib::Geocentric::WGS84();
  const TileBounds& b = tile.bounds;
  std::vector<Vec3> positions(vertex_count);
  for (std::size_t i = 0; i < vertex_count; ++i) {
    const double tu = us[i] / double{kMaxQuantized}, tv = vs[i] / double{kMaxQuantized};
    const double lon = (1.0 - tu) * b.west + tu * b.east;
    const double lat = (1.0 - tv) * b.south + tv * b.north;
    const double h = minimum + ((maximum - minimum) * ks[i]) / kMaxQuantized;
    earth.Forward(lat, lon, h, positions[i][0], positions[i][1], positions[i][2]);
  }
  Vec3 sphere_center{};
  double sphere_radius = 0.0;
  bounding_sphere(positions, sphere_center, sphere_radius);
  const Vec3 occlusion = horizon_occlusion_point(positions, sphere_center, minimum);

  std::vector<std::uint8_t> out;
  Writer w(out);
  for (double c : sphere_center) w.f64(c);
  w.f32(static_cast<float>(minimum));
  w.f32(static_cast<float>(maximum));
  for (double c : sphere_center) w.f64(c);
  w.f64(sphere_radius);
  for (double c : occlusion) w.f64(c);

  w.u32(static_cast<std::uint32_t>(vertex_count));
  for (const auto* values : {&us, &vs, &ks}) {
    int previous = 0;
    for (std::uint16_t value : *values) {
      w.u16(zig_zag(value - previous));
      previous = value;
    }
  }

  const bool wide = vertex_count > 65536;
  while (w.size() % (wide ? 4 : 2) != 0) w.u8(0);
  w.u32(static_cast<std::uint32_t>(mesh.triangles.size() / 3));
  std::uint32_t highest = 0;
  for (std::uint32_t t : mesh.triangles) {
    const std::uint32_t index = renumber[t];
    w.index(highest - index, wide);
    if (index == highest) ++highest;
  }

  // Edge lists sorted along their edge (south to north, west to east), as Cesium expects.
  std::vector<std::uint32_t> west, south, east, north;
  for (std::uint32_t i = 0; i < vertex_count; ++i) {
    if (us[i] == 0) west.push_back(i);
    if (vs[i] == 0) south.push_back(i);
    if (us[i] == kMaxQuantized) east.push_back(i);
    if (vs[i] == kMaxQuantized) north.push_back(i);
  }
  const auto by_v = [&](std::uint32_t x, std::uint32_t y) { return vs[x] < vs[y]; };
  const auto by_u = [&](std::uint32_t x, std::uint32_t y) { return us[x] < us[y]; };
  std::sort(west.begin(), west.end(), by_v);
  std::sort(south.begin(), south.end(), by_u);
  std::sort(east.begin(), east.end(), by_v);
  std::sort(north.begin(), north.end(), by_u);
  for (const auto* list : {&west, &south, &east, &north}) {
    w.u32(static_cast<std::uint32_t>(list->size()));
    for (std::uint32_t i : *list) w.index(i, wide);
  }

  if (options.normals) {
    w.u8(kNormalsId);
    w.u32(static_cast<std::uint32_t>(2 * vertex_count));
    for (std::size_t i = 0; i < vertex_count; ++i) {
      const std::uint32_t g = mesh.vertices[order[i]];
      const Vec3 normal = ecef_normal(tile.sample_crs_x(column_of(g)), tile.sample_crs_y(row_of(g)),
                                      tile.slope_east[g], tile.slope_north[g]);
      const auto oct = oct_encode(normal);
      w.u8(oct[0]);
      w.u8(oct[1]);
    }
  }
  if (options.water_mask) {
    w.u8(kWaterMaskId);
    w.u32(static_cast<std::uint32_t>(options.water_mask->size()));
    w.bytes(options.water_mask->data(), options.water_mask->size());
  }
  if (options.metadata) {
    const std::string& json = *options.metadata;
    w.u8(kMetadataId);
    w.u32(static_cast<std::uint32_t>(4 + json.size()));
    w.u32(static_cast<std::uint32_t>(json.size()));
    w.bytes(reinterpret_cast<const std::uint8_t*>(json.data()), json.size());
  }
  return out;
}

nlohmann::json quantized_mesh_metadata_json(
    const std::vector<std::vector<AvailabilityRectangle>>& levels_below) {
  nlohmann::json available = nlohmann::json::array();
  for (const auto& level : levels_below) {
    nlohmann::json rectangles = nlohmann::json::array();
    for (const AvailabilityRectangle& r : level) {
      rectangles.push_back(
          {{"startX", r.start_x}, {"startY", r.start_y}, {"endX", r.end_x}, {"endY", r.end_y}});
    }
    available.push_back(std::move(rectangles));
  }
  return {{"available", std::move(available)}};
}

nlohmann::json quantized_mesh_layer_json(const LayerJsonOptions& options) {
  nlohmann::json layer = {
      {"tilejson", "2.1.0"},
      {"name", options.name},
      {"description", options.description},
      {"version", options.version},
      {"format", "quantized-mesh-1.0"},
      {"scheme", "tms"},
      {"tiles", options.tiles},
      {"projection", "EPSG:4326"},
      {"bounds",
       {options.bounds.west, options.bounds.south, options.bounds.east, options.bounds.north}},
      {"minzoom", options.minzoom},
      {"maxzoom", options.maxzoom},
      {"extensions", options.extensions},
      {"attribution", options.attribution},
  };
  // An empty list would tell Cesium that no tile exists; without the field it assumes all do.
  if (!options.available.empty()) {
    layer["available"] = quantized_mesh_metadata_json(options.available)["available"];
  }
  // `available` stays complete for clients that read it beside the tiles' metadata; CesiumJS
  // then takes levels 0 and below from the availability tiles (levels 0, n, 2n, …).
  if (std::find(options.extensions.begin(), options.extensions.end(), "metadata") !=
      options.extensions.end()) {
    layer["metadataAvailability"] = kMetadataAvailabilityLevels;
  }
  return layer;
}

}  // namespace terrain
