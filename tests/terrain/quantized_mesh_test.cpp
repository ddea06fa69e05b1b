// quantized-mesh-1.0: encoder and decoder against each other and against the specification on
// synthetic geographic tiles (positions, heights within their quanta, triangles, edge lists,
// normals, bounding volumes, extensions), bit-identical shared edges between neighbours with
// different height ranges, layer.json, and refusal of malformed input.
#include "terrain/quantized_mesh.hpp"

#include <gtest/gtest.h>
#include <GeographicLib/Geocentric.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "example_tile_sources.hpp"
#include "quantized_mesh_dip.hpp"
#include "terrain/gzip.hpp"
#include "terrain/mesh.hpp"
#include "terrain/tile_products.hpp"

namespace terrain {
namespace {

using Vec3 = std::array<double, 3>;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kA = 6378137.0;  // WGS84
constexpr double kF = 1.0 / 298.257223563;
constexpr double kE2 = kF * (2.0 - kF);

// A smooth height field of longitude and latitude (degrees) with exact derivatives, so that
// tiles computed from it agree wherever they share sample positions.
struct Hills {
  double height(double lon, double lat) const {
    return 1000.0 +
           600.0 * std::sin(2 * std::numbers::pi * lon / 1.7) *
               std::cos(2 * std::numbers::pi * lat / 2.3) +
           150.0 * std::sin(2 * std::numbers::pi * (lon + lat) / 0.37);
  }
  // ∂h/∂east and ∂h/∂north in metres per metre on the WGS84 ellipsoid.
  void slopes(double lon, double lat, double& east, double& north) const {
    const double k1 = 2 * std::numbers::pi / 1.7, k2 = 2 * std::numbers::pi / 2.3,
                 k3 = 2 * std::numbers::pi / 0.37;
    const double dlon = 600.0 * k1 * std::cos(k1 * lon) * std::cos(k2 * lat) +
                        150.0 * k3 * std::cos(k3 * (lon + lat));
    const double dlat = -600.0 * k2 * std::sin(k1 * lon) * std::sin(k2 * lat) +
                        150.0 * k3 * std::cos(k3 * (lon + lat));
    const double s = std::sin(lat * kDeg);
    const double w = std::sqrt(1.0 - kE2 * s * s);
    const double prime_vertical = kA / w, meridian = kA * (1.0 - kE2) / (w * w * w);
    east = dlon / kDeg / (prime_vertical * std::cos(lat * kDeg));
    north = dlat / kDeg / meridian;
  }
};

HeightTile make_tile(int z, std::int64_t x, std::int64_t y, int cells, const Hills& hills = {}) {
  HeightTile tile;
  tile.scheme = TileScheme::geographic;
  tile.address = {z, x, y};
  tile.layout = SampleLayout::cell_corners;
  tile.cells = cells;
  tile.border = 0;
  tile.width = tile.height = cells + 1;
  tile.world = {-180.0, -90.0, 180.0, 90.0};
  tile.bounds = {tile.sample_crs_x(0), tile.sample_crs_y(cells), tile.sample_crs_x(cells),
                 tile.sample_crs_y(0)};
  const auto count = static_cast<std::size_t>(tile.width) * static_cast<std::size_t>(tile.width);
  tile.elevation.resize(count);
  tile.slope_east.resize(count);
  tile.slope_north.resize(count);
  for (int row = 0; row < tile.height; ++row) {
    for (int column = 0; column < tile.width; ++column) {
      const double lon = tile.sample_crs_x(column), lat = tile.sample_crs_y(row);
      const std::size_t i = tile.index(column, row);
      tile.elevation[i] = static_cast<float>(hills.height(lon, lat));
      double east = 0.0, north = 0.0;
      hills.slopes(lon, lat, east, north);
      tile.slope_east[i] = static_cast<float>(east);
      tile.slope_north[i] = static_cast<float>(north);
    }
  }
  return tile;
}

// Scene-wide height range of Hills: 1000 ± 750.
const double kEdgeQuantum = edge_quantum_for(1500.0);

TileMesh rtin(const HeightTile& tile, float max_error = 2.0f) {
  return triangulate_rtin(tile.elevation.data(), tile.width, max_error);
}

QuantizedMeshOptions all_extensions() {
  QuantizedMeshOptions options;
  options.edge_quantum = kEdgeQuantum;
  options.normals = true;
  options.water_mask = std::vector<std::uint8_t>{0};
  options.metadata = quantized_mesh_metadata_json({{{0, 0, 1, 1}}}).dump();
  return options;
}

std::vector<std::uint8_t> encode(const HeightTile& tile, const TileMesh& mesh,
                                 const QuantizedMeshOptions& options) {
  auto r = encode_quantized_mesh(tile, mesh, options);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().pointer + ": " + r.error().message);
  return r.ok() ? std::move(r).value() : std::vector<std::uint8_t>{};
}

QuantizedMesh decode(const std::vector<std::uint8_t>& bytes) {
  auto r = decode_quantized_mesh(bytes);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().pointer + ": " + r.error().message);
  return r.ok() ? std::move(r).value() : QuantizedMesh{};
}

// The grid column and row a decoded vertex stands for (exact for n − 1 ≤ 32767).
int column_of(const QuantizedMesh& qm, std::size_t i, int n) {
  return static_cast<int>(std::lround(qm.u[i] * double(n - 1) / 32767.0));
}
int row_of(const QuantizedMesh& qm, std::size_t i, int n) {
  return n - 1 - static_cast<int>(std::lround(qm.v[i] * double(n - 1) / 32767.0));
}

// Where a client puts a vertex: u, v interpolated over the tile's bounds, the decoded height.
Vec3 client_position(const QuantizedMesh& qm, std::size_t i, const TileBounds& b) {
  const double tu = qm.u[i] / 32767.0, tv = qm.v[i] / 32767.0;
  Vec3 p{};
  GeographicLib::Geocentric::WGS84().Forward((1 - tv) * b.south + tv * b.north,
                                             (1 - tu) * b.west + tu * b.east, qm.height_metres(i),
                                             p[0], p[1], p[2]);
  return p;
}

Vec3 exact_normal(const HeightTile& tile, int column, int row) {
  const double lon = tile.sample_crs_x(column) * kDeg, lat = tile.sample_crs_y(row) * kDeg;
  const std::size_t i = tile.index(column, row);
  const double se = tile.slope_east[i], sn = tile.slope_north[i];
  const double len = std::sqrt(se * se + sn * sn + 1.0);
  const Vec3 east{-std::sin(lon), std::cos(lon), 0.0};
  const Vec3 north{-std::sin(lat) * std::cos(lon), -std::sin(lat) * std::sin(lon), std::cos(lat)};
  const Vec3 up{std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat)};
  Vec3 v{};
  for (int k = 0; k < 3; ++k) v[k] = (-se * east[k] - sn * north[k] + up[k]) / len;
  return v;
}

double dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

TEST(QuantizedMesh, RoundTripsPositionsHeightsAndTriangles) {
  const HeightTile tile = make_tile(7, 170, 90, 64);
  const TileMesh mesh = rtin(tile);
  const QuantizedMesh qm = decode(encode(tile, mesh, all_extensions()));
  const int n = tile.width;
  ASSERT_EQ(qm.vertex_count(), mesh.vertices.size());
  ASSERT_EQ(qm.indices.size(), mesh.triangles.size());

  // The header's height range: m on a multiple of Q, and (M − m)/32767 = Q/2^j.
  const double m = qm.header.minimum_height, big_m = qm.header.maximum_height;
  const double q = (big_m - m) / 32767.0;
  EXPECT_EQ(std::fmod(m, kEdgeQuantum), 0.0);
  int exponent = 0;
  EXPECT_EQ(std::frexp(kEdgeQuantum / q, &exponent), 0.5) << "q = " << q;
  EXPECT_GE(kEdgeQuantum / q, 1.0);
  const auto [lowest, highest] = std::minmax_element(tile.elevation.begin(), tile.elevation.end());
  EXPECT_LE(m, *lowest);
  EXPECT_GE(big_m, *highest);

  std::vector<std::uint32_t> grid_of(qm.vertex_count());
  std::set<std::uint32_t> decoded_samples;
  for (std::size_t i = 0; i < qm.vertex_count(); ++i) {
    const int column = column_of(qm, i, n), row = row_of(qm, i, n);
    // u, v exactly as specified: column/(n−1) and (n−1−row)/(n−1) of 32767, rounded.
    EXPECT_EQ(qm.u[i], std::lround(column * 32767.0 / (n - 1)));
    EXPECT_EQ(qm.v[i], std::lround((n - 1 - row) * 32767.0 / (n - 1)));
    grid_of[i] = static_cast<std::uint32_t>(row * n + column);
    decoded_samples.insert(grid_of[i]);
    // Longitude and latitude a client derives are the sample's to within half a u/v step.
    const double tu = qm.u[i] / 32767.0, tv = qm.v[i] / 32767.0;
    const TileBounds& b = tile.bounds;
    EXPECT_NEAR((1 - tu) * b.west + tu * b.east, tile.sample_crs_x(column),
                0.5 / 32767.0 * (b.east - b.west) + 1e-12);
    EXPECT_NEAR((1 - tv) * b.south + tv * b.north, tile.sample_crs_y(row),
                0.5 / 32767.0 * (b.north - b.south) + 1e-12);

    const double h = tile.elevation[grid_of[i]];
    const double decoded = qm.height_metres(i);
    const bool edge = column == 0 || row == 0 || column == n - 1 || row == n - 1;
    if (edge) {
      EXPECT_EQ(decoded, std::nearbyint(h / kEdgeQuantum) * kEdgeQuantum);
    } else {
      EXPECT_LE(std::abs(decoded - h), q / 2) << "vertex " << i;
      EXPECT_EQ(std::fmod(decoded - m, q), 0.0);
    }
  }
  EXPECT_EQ(decoded_samples, std::set<std::uint32_t>(mesh.vertices.begin(), mesh.vertices.end()));

  // The same triangles, corner for corner.
  for (std::size_t k = 0; k < mesh.triangles.size(); ++k) {
    EXPECT_EQ(grid_of[qm.indices[k]], mesh.vertices[mesh.triangles[k]]) << "corner " << k;
  }
  // Vertices are numbered by first use, as the high-water-mark encoding wants.
  std::uint32_t next = 0;
  for (std::uint32_t index : qm.indices) {
    EXPECT_LE(index, next);
    if (index == next) ++next;
  }
}

TEST(QuantizedMesh, EdgeListsHoldExactlyTheBoundaryVerticesAlongTheirEdge) {
  const HeightTile tile = make_tile(7, 170, 90, 64);
  const QuantizedMesh qm = decode(encode(tile, rtin(tile, 20.0f), all_extensions()));
  const auto expected = [&](bool (*on)(const QuantizedMesh&, std::size_t), bool by_u) {
    std::vector<std::uint32_t> list;
    for (std::uint32_t i = 0; i < qm.vertex_count(); ++i) {
      if (on(qm, i)) list.push_back(i);
    }
    std::sort(list.begin(), list.end(), [&](std::uint32_t a, std::uint32_t b) {
      return by_u ? qm.u[a] < qm.u[b] : qm.v[a] < qm.v[b];
    });
    return list;
  };
  EXPECT_EQ(qm.west,
            expected([](const QuantizedMesh& m, std::size_t i) { return m.u[i] == 0; }, false));
  EXPECT_EQ(qm.south,
            expected([](const QuantizedMesh& m, std::size_t i) { return m.v[i] == 0; }, true));
  EXPECT_EQ(qm.east,
            expected([](const QuantizedMesh& m, std::size_t i) { return m.u[i] == 32767; }, false));
  EXPECT_EQ(qm.north,
            expected([](const QuantizedMesh& m, std::size_t i) { return m.v[i] == 32767; }, true));
  // Full-resolution edges: every boundary sample, strictly increasing along the edge.
  for (const auto* list : {&qm.west, &qm.south, &qm.east, &qm.north}) {
    EXPECT_EQ(list->size(), std::size_t(tile.width));
  }
  for (std::size_t k = 1; k < qm.west.size(); ++k)
    EXPECT_LT(qm.v[qm.west[k - 1]], qm.v[qm.west[k]]);
  for (std::size_t k = 1; k < qm.north.size(); ++k) {
    EXPECT_LT(qm.u[qm.north[k - 1]], qm.u[qm.north[k]]);
  }
}

TEST(QuantizedMesh, OctEncodingMatchesCesiumOnKnownVectors) {
  // By hand from AttributeCompression.octEncode: toSNorm(x) = round((x/2 + 1/2)·255).
  EXPECT_EQ(oct_encode({0.0, 0.0, 1.0}), (std::array<std::uint8_t, 2>{128, 128}));
  EXPECT_EQ(oct_encode({0.0, 0.0, -1.0}), (std::array<std::uint8_t, 2>{255, 255}));
  EXPECT_EQ(oct_encode({1.0, 0.0, 0.0}), (std::array<std::uint8_t, 2>{255, 128}));
  EXPECT_EQ(oct_encode({-1.0, 0.0, 0.0}), (std::array<std::uint8_t, 2>{0, 128}));
  EXPECT_EQ(oct_encode({0.0, -1.0, 0.0}), (std::array<std::uint8_t, 2>{128, 0}));
  const Vec3 up = oct_decode(128, 128);
  EXPECT_NEAR(up[2], 1.0, 1e-4);
  const Vec3 down = oct_decode(255, 255);
  EXPECT_NEAR(down[2], -1.0, 1e-12);
  // Every code decodes to a unit vector that encodes back to itself.
  for (int x = 0; x < 256; x += 5) {
    for (int y = 0; y < 256; y += 3) {
      const Vec3 v = oct_decode(static_cast<std::uint8_t>(x), static_cast<std::uint8_t>(y));
      EXPECT_NEAR(dot(v, v), 1.0, 1e-12);
    }
  }
}

TEST(QuantizedMesh, NormalsDecodeWithinOctErrorOfTheExactOnes) {
  const HeightTile tile = make_tile(7, 170, 90, 64);
  const QuantizedMesh qm = decode(encode(tile, rtin(tile), all_extensions()));
  ASSERT_TRUE(qm.normals.has_value());
  ASSERT_EQ(qm.normals->size(), 2 * qm.vertex_count());
  double worst = 0.0;
  for (std::size_t i = 0; i < qm.vertex_count(); ++i) {
    const Vec3 exact = exact_normal(tile, column_of(qm, i, tile.width), row_of(qm, i, tile.width));
    const Vec3 decoded = oct_decode((*qm.normals)[2 * i], (*qm.normals)[2 * i + 1]);
    worst = std::max(worst, std::acos(std::min(1.0, dot(exact, decoded))) / kDeg);
  }
  // 8-bit oct encoding: cells of 2/255 in the octahedron's parameter square.
  EXPECT_LT(worst, 1.0) << "degrees";
}

TEST(QuantizedMesh, CentreAndBoundingSphereHoldEveryVertex) {
  const HeightTile tile = make_tile(7, 170, 90, 64);
  const QuantizedMesh qm = decode(encode(tile, rtin(tile), all_extensions()));
  const QuantizedMeshHeader& h = qm.header;
  EXPECT_EQ(h.center, h.bounding_sphere_center);
  double farthest = 0.0;
  for (std::size_t i = 0; i < qm.vertex_count(); ++i) {
    const Vec3 p = client_position(qm, i, tile.bounds);
    const Vec3 d{p[0] - h.bounding_sphere_center[0], p[1] - h.bounding_sphere_center[1],
                 p[2] - h.bounding_sphere_center[2]};
    farthest = std::max(farthest, std::sqrt(dot(d, d)));
  }
  EXPECT_LE(farthest, h.bounding_sphere_radius * (1 + 1e-12));
  // Tight: a 1.4°-square tile's sphere is about half its 200 km diagonal.
  EXPECT_GT(h.bounding_sphere_radius, 0.99 * farthest);
  EXPECT_LT(h.bounding_sphere_radius, 120e3);
}

TEST(QuantizedMesh, HorizonOcclusionPointHidesTheTileOnlyWhenEveryVertexIsHidden) {
  const HeightTile tile = make_tile(7, 170, 90, 64);
  const QuantizedMesh qm = decode(encode(tile, rtin(tile), all_extensions()));
  const Vec3 p = qm.header.horizon_occlusion_point;
  // Heights are positive, so the scaled space is the WGS84 one (no shrunk ellipsoid).
  const double b = kA * (1 - kF);
  const auto scaled = [&](const Vec3& v) { return Vec3{v[0] / kA, v[1] / kA, v[2] / b}; };
  std::vector<Vec3> vertices;
  for (std::size_t i = 0; i < qm.vertex_count(); ++i) {
    vertices.push_back(scaled(client_position(qm, i, tile.bounds)));
  }
  ASSERT_GT(dot(p, p), 1.0);
  // Along the direction to the bounding sphere's centre.
  const Vec3 c = scaled(qm.header.bounding_sphere_center);
  const double cos_angle = dot(p, c) / std::sqrt(dot(p, p) * dot(c, c));
  EXPECT_NEAR(cos_angle, 1.0, 1e-12);
  // Every vertex is on the visible side of the horizon plane of the point (v·p ≥ 1).
  for (const Vec3& v : vertices) EXPECT_GE(dot(v, p), 1.0);

  // Cesium's isScaledSpacePointVisible for the point; exact occlusion by the unit sphere for the
  // vertices (the segment from the camera dips inside it).
  const auto point_occluded = [&](const Vec3& camera) {
    const Vec3 vt{p[0] - camera[0], p[1] - camera[1], p[2] - camera[2]};
    const double vh2 = dot(camera, camera) - 1.0;
    const double vt_dot_vc = -dot(vt, camera);
    return vt_dot_vc > vh2 && vt_dot_vc * vt_dot_vc / dot(vt, vt) > vh2;
  };
  const auto vertex_hidden = [](const Vec3& camera, const Vec3& v) {
    const Vec3 d{v[0] - camera[0], v[1] - camera[1], v[2] - camera[2]};
    const double t = std::clamp(-dot(camera, d) / dot(d, d), 0.0, 1.0);
    const Vec3 closest{camera[0] + t * d[0], camera[1] + t * d[1], camera[2] + t * d[2]};
    return dot(closest, closest) < 1.0;
  };
  std::mt19937 rng(12);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> altitude(1.0001, 3.0);
  int occluded = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    Vec3 camera{gauss(rng), gauss(rng), gauss(rng)};
    const double r = altitude(rng) / std::sqrt(dot(camera, camera));
    for (double& x : camera) x *= r;
    if (!point_occluded(camera)) continue;
    ++occluded;
    for (const Vec3& v : vertices) {
      ASSERT_TRUE(vertex_hidden(camera, v)) << "culled although a vertex is visible";
    }
  }
  EXPECT_GT(occluded, 300);
}

TEST(QuantizedMesh, WaterMaskAndMetadataRoundTrip) {
  const HeightTile tile = make_tile(7, 170, 90, 16);
  const TileMesh mesh = triangulate_grid(tile.width);
  QuantizedMeshOptions options;
  options.edge_quantum = kEdgeQuantum;
  std::vector<std::uint8_t> mask(256 * 256);
  for (std::size_t i = 0; i < mask.size(); ++i) {
    mask[i] = static_cast<std::uint8_t>(i / 256 < 100 ? 255 : i % 251);  // northern rows water
  }
  options.water_mask = mask;
  const nlohmann::json metadata =
      quantized_mesh_metadata_json({{{600, 180, 601, 181}}, {{1200, 360, 1203, 363}}});
  options.metadata = metadata.dump();
  const QuantizedMesh qm = decode(encode(tile, mesh, options));
  EXPECT_FALSE(qm.normals.has_value());
  ASSERT_TRUE(qm.water_mask.has_value());
  EXPECT_EQ(*qm.water_mask, mask);
  ASSERT_TRUE(qm.metadata.has_value());
  const nlohmann::json parsed = nlohmann::json::parse(*qm.metadata);
  EXPECT_EQ(parsed, metadata);
  EXPECT_EQ(parsed["available"][1][0]["endX"], 1203);
  EXPECT_EQ(parsed["available"][0][0]["startY"], 180);

  options.water_mask = std::vector<std::uint8_t>{255};
  options.metadata.reset();
  const QuantizedMesh all_water = decode(encode(tile, mesh, options));
  EXPECT_EQ(all_water.water_mask, std::vector<std::uint8_t>{255});
  EXPECT_FALSE(all_water.metadata.has_value());
}

TEST(QuantizedMesh, EncodingIsDeterministicAndSurvivesGzip) {
  const HeightTile tile = make_tile(7, 170, 90, 64);
  const TileMesh mesh = rtin(tile);
  const auto a = encode(tile, mesh, all_extensions());
  const auto b = encode(make_tile(7, 170, 90, 64), rtin(tile), all_extensions());
  EXPECT_EQ(a, b);
  auto packed_a = gzip_compress(a);
  auto packed_b = gzip_compress(b);
  ASSERT_TRUE(packed_a.ok() && packed_b.ok());
  EXPECT_EQ(*packed_a, *packed_b);
  EXPECT_LT(packed_a->size(), a.size());
  auto unpacked = gzip_decompress(*packed_a, a.size());
  ASSERT_TRUE(unpacked.ok());
  EXPECT_EQ(*unpacked, a);
}

TEST(QuantizedMesh, LargeMeshesUse32BitIndicesWithAlignment) {
  const HeightTile tile = make_tile(7, 170, 90, 256);
  const TileMesh mesh = triangulate_grid(tile.width);  // 66 049 vertices: more than 64 Ki
  const auto bytes = encode(tile, mesh, all_extensions());
  const QuantizedMesh qm = decode(bytes);
  ASSERT_EQ(qm.vertex_count(), 66049u);
  // Header, count, 3 arrays, 2 bytes of padding to 4-byte alignment, triangle count, indices.
  const std::size_t indices_at = 88 + 4 + 6 * 66049 + 2 + 4;
  EXPECT_EQ(indices_at % 4, 0u);
  ASSERT_EQ(qm.indices.size(), mesh.triangles.size());
  std::vector<std::uint32_t> grid_of(qm.vertex_count());
  for (std::size_t i = 0; i < qm.vertex_count(); ++i) {
    grid_of[i] = static_cast<std::uint32_t>(row_of(qm, i, tile.width) * tile.width +
                                            column_of(qm, i, tile.width));
  }
  for (std::size_t k = 0; k < mesh.triangles.size(); ++k) {
    ASSERT_EQ(grid_of[qm.indices[k]], mesh.vertices[mesh.triangles[k]]);
  }
  const std::size_t edges = 4 * (4 + 4 * std::size_t{257});
  const std::size_t extensions = (5 + 2 * 66049) + (5 + 1) + (5 + 4 + qm.metadata->size());
  EXPECT_EQ(bytes.size(), indices_at + 4 * mesh.triangles.size() + edges + extensions);
}

// Two neighbours computed from the same function at the same global positions.
void expect_identical_shared_edge(const HeightTile& a, const HeightTile& b, bool east_west,
                                  bool different_quanta) {
  const QuantizedMesh qa = decode(encode(a, rtin(a), all_extensions()));
  const QuantizedMesh qb = decode(encode(b, rtin(b), all_extensions()));
  // Different height ranges, hence different headers and tile quanta.
  ASSERT_TRUE(qa.header.minimum_height != qb.header.minimum_height ||
              qa.header.maximum_height != qb.header.maximum_height);
  if (different_quanta) {
    ASSERT_NE(qa.header.maximum_height - qa.header.minimum_height,
              qb.header.maximum_height - qb.header.minimum_height);
  }
  const int n = a.width;
  // Shared samples by their position along the edge.
  const auto collect = [n](const QuantizedMesh& qm, bool want_column, int line) {
    std::map<int, std::size_t> along;
    for (std::size_t i = 0; i < qm.vertex_count(); ++i) {
      const int column = column_of(qm, i, n), row = row_of(qm, i, n);
      if ((want_column ? column : row) == line) along[want_column ? row : column] = i;
    }
    return along;
  };
  // a's east column meets b's west column; a's north row (0) meets b's south row (n − 1).
  const auto side_a = east_west ? collect(qa, true, n - 1) : collect(qa, false, 0);
  const auto side_b = east_west ? collect(qb, true, 0) : collect(qb, false, n - 1);
  ASSERT_EQ(side_a.size(), std::size_t(n));
  ASSERT_EQ(side_b.size(), std::size_t(n));
  double lerp_gap = 0.0;
  for (const auto& [position, ia] : side_a) {
    const std::size_t ib = side_b.at(position);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(qa.height_metres(ia)),
              std::bit_cast<std::uint64_t>(qb.height_metres(ib)))
        << "at " << position << ": " << qa.height_metres(ia) << " vs " << qb.height_metres(ib);
    EXPECT_EQ((*qa.normals)[2 * ia], (*qb.normals)[2 * ib]);
    EXPECT_EQ((*qa.normals)[2 * ia + 1], (*qb.normals)[2 * ib + 1]);
    // Cesium itself decodes with lerp(m, M, k/32767), which rounds: the two sides then differ
    // by at most a few ulps (nanometres), far below anything a renderer resolves.
    const auto lerp = [](const QuantizedMesh& qm, std::size_t i) {
      const double t = qm.height[i] / 32767.0;
      return (1.0 - t) * qm.header.minimum_height + t * qm.header.maximum_height;
    };
    lerp_gap = std::max(lerp_gap, std::abs(lerp(qa, ia) - lerp(qb, ib)));
  }
  EXPECT_LT(lerp_gap, 1e-9);
}

TEST(QuantizedMesh, EastWestNeighboursDecodeIdenticalSharedEdges) {
  // Same tile quantum q = Q, different minima.
  expect_identical_shared_edge(make_tile(7, 170, 90, 64), make_tile(7, 171, 90, 64), true, false);
  // Smaller tiles: q = Q/8 in the western one, Q/16 in the eastern one.
  expect_identical_shared_edge(make_tile(12, 5440, 2880, 64), make_tile(12, 5441, 2880, 64), true,
                               true);
}

TEST(QuantizedMesh, NorthSouthNeighboursDecodeIdenticalSharedEdges) {
  // TMS rows grow north: (x, y + 1) is the northern neighbour.
  expect_identical_shared_edge(make_tile(7, 170, 90, 64), make_tile(7, 170, 91, 64), false, false);
  expect_identical_shared_edge(make_tile(12, 5440, 2880, 64), make_tile(12, 5440, 2881, 64), false,
                               true);
}

// CesiumJS draws flat triangles between ECEF vertices: over a flat area, a large triangle of a
// coarse tile cuts under the globe. Far from the scene the geographic tiles are flat, the worst
// case; the adaptive mesh and the full grid must both stay within the error the tileset declares.
TEST(QuantizedMesh, SceneTilesDipUnderTheCurvedSurfaceByAtMostTheDeclaredError) {
  ProductMaker maker(testing::example_source("mountain-range"));
  for (const bool regular : {false, true}) {
    ProductOptions options;
    options.regular = regular;
    for (int z = 0; z <= 6; ++z) {
      const TileRange scene = tiles_covering_area(maker.source(), TileScheme::geographic, z);
      double worst = 0.0;
      std::size_t vertices = 0;
      const auto tiles = testing::curvature_probe_tiles(z, {{z, scene.min_x, scene.min_y}});
      for (const TileAddress& a : tiles) {
        Result<Product> product =
            maker.make(TileScheme::geographic, a, TileFormat::quantized_mesh, options);
        ASSERT_TRUE(product.ok()) << product.error().message;
        const QuantizedMesh qm = decode(gzip_decompress(product->bytes, 1u << 26).value());
        const double dip =
            testing::max_dip_below_surface(qm, testing::geographic_tile_bounds(a), regular ? 4 : 8);
        EXPECT_LE(dip, testing::cesium_level_maximum_geometric_error(z))
            << (regular ? "regular " : "adaptive ") << a.z << "/" << a.x << "/" << a.y;
        worst = std::max(worst, dip);
        vertices += qm.u.size();
      }
      std::printf("%s zoom %d: %.1f vertices per tile, largest dip %.0f m, declared error %.0f m\n",
                  regular ? "regular" : "adaptive", z, double(vertices) / double(tiles.size()),
                  worst, testing::cesium_level_maximum_geometric_error(z));
    }
  }
}

TEST(QuantizedMesh, EdgeQuantumIsTheSmallestFittingPowerOfTwo) {
  EXPECT_EQ(edge_quantum_for(0.0), 1.0 / 1024.0);
  EXPECT_EQ(edge_quantum_for(-5.0), 1.0 / 1024.0);
  EXPECT_EQ(edge_quantum_for(1500.0), 0.0625);
  EXPECT_EQ(edge_quantum_for(32766.0), 1.0);
  EXPECT_EQ(edge_quantum_for(32767.0), 2.0);
  EXPECT_EQ(edge_quantum_for(9000.0), 0.5);
}

TEST(QuantizedMesh, LayerJsonHasTheFieldsCesiumTerrainProviderReads) {
  LayerJsonOptions options;
  options.name = "demo";
  options.description = "synthetic hills";
  options.attribution = "us";
  options.maxzoom = 12;
  options.available = {{{0, 0, 1, 0}}, {{0, 0, 3, 1}}};
  const nlohmann::json layer = quantized_mesh_layer_json(options);
  EXPECT_EQ(layer["tilejson"], "2.1.0");
  EXPECT_EQ(layer["format"], "quantized-mesh-1.0");
  EXPECT_EQ(layer["version"], "1.2.0");
  EXPECT_EQ(layer["scheme"], "tms");
  EXPECT_EQ(layer["projection"], "EPSG:4326");
  EXPECT_EQ(layer["name"], "demo");
  EXPECT_EQ(layer["description"], "synthetic hills");
  EXPECT_EQ(layer["attribution"], "us");
  EXPECT_EQ(layer["tiles"], nlohmann::json::array({"{z}/{x}/{y}.terrain?v={version}"}));
  EXPECT_EQ(layer["bounds"], nlohmann::json::array({-180.0, -90.0, 180.0, 90.0}));
  EXPECT_EQ(layer["minzoom"], 0);
  EXPECT_EQ(layer["maxzoom"], 12);
  EXPECT_EQ(layer["extensions"],
            nlohmann::json::array({"octvertexnormals", "watermask", "metadata"}));
  EXPECT_EQ(layer["available"][1][0],
            (nlohmann::json{{"startX", 0}, {"startY", 0}, {"endX", 3}, {"endY", 1}}));
  EXPECT_FALSE(quantized_mesh_layer_json(LayerJsonOptions{}).contains("available"));
}

// CesiumJS creates the bookkeeping for tile metadata only when layer.json has
// metadataAvailability, yet parses the metadata extension whenever it is listed: without the
// field every tile failed (TypeError in CesiumTerrainProvider) and nothing was drawn.
TEST(QuantizedMesh, LayerJsonListingMetadataSaysWhichLevelsCarryAvailability) {
  LayerJsonOptions options;
  options.available = {{{0, 0, 1, 0}}};
  EXPECT_EQ(quantized_mesh_layer_json(options)["metadataAvailability"],
            kMetadataAvailabilityLevels);
  options.extensions = {"octvertexnormals", "watermask"};
  EXPECT_FALSE(quantized_mesh_layer_json(options).contains("metadataAvailability"));
}

TEST(QuantizedMesh, EncoderRefusesMalformedInput) {
  const HeightTile good = make_tile(7, 170, 90, 16);
  const TileMesh mesh = triangulate_grid(good.width);
  const auto refused = [&](const HeightTile& tile, const TileMesh& m,
                           const QuantizedMeshOptions& options, const std::string& pointer) {
    auto r = encode_quantized_mesh(tile, m, options);
    ASSERT_FALSE(r.ok()) << "expected a refusal at " << pointer;
    EXPECT_EQ(r.error().pointer.rfind(pointer, 0), 0u)
        << r.error().pointer << ": " << r.error().message;
  };
  QuantizedMeshOptions options;
  options.edge_quantum = kEdgeQuantum;
  ASSERT_TRUE(encode_quantized_mesh(good, mesh, options).ok());

  HeightTile t = good;
  t.scheme = TileScheme::webmercator;
  refused(t, mesh, options, "/scheme");
  t = good;
  t.layout = SampleLayout::cell_centres;
  refused(t, mesh, options, "/layout");
  t = good;
  t.elevation.pop_back();
  refused(t, mesh, options, "/elevation");
  t = good;
  t.elevation[7] = std::nanf("");
  refused(t, mesh, options, "/elevation/7");
  t = good;
  t.bounds.east = t.bounds.west;
  refused(t, mesh, options, "/bounds");
  refused(good, triangulate_grid(9), options, "/mesh/grid_size");
  TileMesh bad = mesh;
  bad.triangles[5] = static_cast<std::uint32_t>(bad.vertices.size());
  refused(good, bad, options, "/mesh/triangles/5");
  bad = mesh;
  bad.triangles.pop_back();
  refused(good, bad, options, "/mesh/triangles");
  bad = mesh;
  bad.vertices[3] = 17 * 17;
  refused(good, bad, options, "/mesh/vertices/3");
  bad = mesh;
  bad.vertices[3] = bad.vertices[2];
  refused(good, bad, options, "/mesh/vertices/3");

  QuantizedMeshOptions o = options;
  o.normals = true;
  t = good;
  t.slope_north.clear();
  refused(t, mesh, o, "/slope_north");
  o = options;
  o.edge_quantum = 0.3;
  refused(good, mesh, o, "/options/edge_quantum");
  o.edge_quantum = -1.0;
  refused(good, mesh, o, "/options/edge_quantum");
  o.edge_quantum = 1.0 / 1024.0;  // 32767 steps of 1 mm cannot span this tile's heights
  refused(good, mesh, o, "/options/edge_quantum");
  o = options;
  o.water_mask = std::vector<std::uint8_t>(3, 0);
  refused(good, mesh, o, "/options/water_mask");
  o = options;
  o.metadata = "{not json";
  refused(good, mesh, o, "/options/metadata");
}

TEST(QuantizedMesh, DecoderRefusesTruncatedAndCorruptTiles) {
  const HeightTile tile = make_tile(7, 170, 90, 2);
  const TileMesh mesh = triangulate_grid(3);  // 9 vertices, 8 triangles, 16-bit indices
  QuantizedMeshOptions plain;
  plain.edge_quantum = kEdgeQuantum;
  const auto mandatory = encode(tile, mesh, plain);
  const auto full = encode(tile, mesh, all_extensions());
  ASSERT_TRUE(std::equal(mandatory.begin(), mandatory.end(), full.begin()));
  const std::size_t metadata_bytes = all_extensions().metadata->size();
  // Valid lengths: the mandatory part, then after each whole extension.
  const std::set<std::size_t> whole = {mandatory.size(), mandatory.size() + 5 + 18,
                                       mandatory.size() + 5 + 18 + 6,
                                       mandatory.size() + 5 + 18 + 6 + 9 + metadata_bytes};
  ASSERT_EQ(*whole.rbegin(), full.size());
  for (std::size_t cut = 0; cut <= full.size(); ++cut) {
    const auto r = decode_quantized_mesh(std::span(full.data(), cut));
    EXPECT_EQ(r.ok(), whole.count(cut) == 1) << "prefix of " << cut << " bytes";
  }

  // Offsets in this small tile.
  constexpr std::size_t kVertexCount = 88, kU = 92, kTriangleCount = 92 + 6 * 9,
                        kIndices = kTriangleCount + 4, kWestCount = kIndices + 2 * 24;
  const auto corrupted = [&](std::size_t at, std::vector<std::uint8_t> values) {
    auto bytes = full;
    std::copy(values.begin(), values.end(), bytes.begin() + static_cast<std::ptrdiff_t>(at));
    return decode_quantized_mesh(bytes);
  };
  EXPECT_FALSE(corrupted(kVertexCount, {0xff, 0xff, 0xff, 0xff}).ok());
  EXPECT_FALSE(corrupted(kU, {0xfe, 0xff}).ok());  // zig-zag 65534: u = 32767, then beyond
  EXPECT_FALSE(corrupted(kU, {0x01, 0x00}).ok());  // u = −1
  EXPECT_FALSE(corrupted(kTriangleCount, {0xff, 0xff, 0x00, 0x00}).ok());
  EXPECT_FALSE(corrupted(kIndices, {0x01, 0x00}).ok());  // first code must be 0
  EXPECT_FALSE(corrupted(kIndices + 2, {0x09, 0x00}).ok());
  EXPECT_FALSE(corrupted(kWestCount, {0x7f, 0x00, 0x00, 0x00}).ok());
  EXPECT_FALSE(corrupted(kWestCount + 4, {0x09, 0x00}).ok());        // vertex 9 of 9
  EXPECT_FALSE(corrupted(16, {0, 0, 0, 0, 0, 0, 0xf8, 0x7f}).ok());  // NaN in CenterZ
  EXPECT_FALSE(corrupted(24, {0x00, 0x00, 0x80, 0x7f}).ok());        // infinite minimum height
  // Minimum above maximum.
  EXPECT_FALSE(corrupted(24, {0x00, 0x00, 0x7f, 0x7f}).ok());
  const std::size_t normals = mandatory.size();
  EXPECT_FALSE(corrupted(normals + 1, {17, 0, 0, 0}).ok());       // normals: 17 bytes for 9
  EXPECT_FALSE(corrupted(normals + 1, {0xff, 0xff, 0, 0}).ok());  // beyond the data
  const std::size_t water = normals + 5 + 18;
  EXPECT_FALSE(corrupted(water, {1}).ok());  // a second normals extension
  const std::size_t metadata = water + 6;
  EXPECT_FALSE(corrupted(metadata + 5, {0, 0, 0, 0}).ok());  // JSON length disagrees
  EXPECT_FALSE(corrupted(metadata + 9, {'['}).ok());         // not JSON any more
  // Unknown extensions are skipped.
  const auto unknown = corrupted(water, {9});
  ASSERT_TRUE(unknown.ok());
  EXPECT_EQ(unknown->unknown_extensions, std::vector<std::uint8_t>{9});
  EXPECT_FALSE(unknown->water_mask.has_value());

  // Arbitrary damage: refused or decoded, never a crash, and decoded indices stay in range.
  std::mt19937 rng(4);
  for (int trial = 0; trial < 2000; ++trial) {
    auto bytes = full;
    for (int k = 0; k < 3; ++k) bytes[rng() % bytes.size()] = static_cast<std::uint8_t>(rng());
    const auto r = decode_quantized_mesh(bytes);
    if (!r.ok()) continue;
    for (std::uint32_t i : r->indices) ASSERT_LT(i, r->vertex_count());
    for (const auto* list : {&r->west, &r->south, &r->east, &r->north}) {
      for (std::uint32_t i : *list) ASSERT_LT(i, r->vertex_count());
    }
  }
}

}  // namespace
}  // namespace terrain
