// Quantized-mesh tiles of scenes at the extremes of valid elevations (scene input allows ±1e5 m):
// a flat scene 40 km up and one spanning −1e5..1e5 m are served at several zooms, decode to the
// height tile's heights within the edge quantum, and neighbours share their edge heights.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

#include "terrain/gzip.hpp"
#include "terrain/quantized_mesh.hpp"
#include "terrain/scene.hpp"
#include "terrain/tile_products.hpp"
#include "terrain/tile_source.hpp"

namespace terrain {
namespace {

TileSource source_of(const std::string& root, double base_elevation) {
  Result<Scene> scene = parse_scene_text(
      R"({"format": "terrain-scene/1", "extent": {"min": [-3000, -3000], "max": [3000, 3000]},
          "base_elevation": )" +
      nlohmann::json(base_elevation).dump() + R"(, "root": )" + root + "}");
  EXPECT_TRUE(scene.ok()) << scene.error().pointer << ": " << scene.error().message;
  Result<TileSource> source = TileSource::from_scene(*scene);
  EXPECT_TRUE(source.ok());
  return std::move(source).value();
}

struct DecodedTile {
  QuantizedMesh mesh;
  HeightTile heights;
};

DecodedTile decoded(ProductMaker& maker, const TileAddress& a) {
  Result<Product> product = maker.make(TileScheme::geographic, a, TileFormat::quantized_mesh, {});
  EXPECT_TRUE(product.ok()) << a.z << "/" << a.x << "/" << a.y << ": "
                            << (product.ok() ? "" : product.error().message);
  if (!product.ok()) return {};
  Result<std::vector<std::uint8_t>> bytes = gzip_decompress(product->bytes, 1u << 26);
  EXPECT_TRUE(bytes.ok());
  Result<QuantizedMesh> mesh = decode_quantized_mesh(*bytes);
  EXPECT_TRUE(mesh.ok()) << (mesh.ok() ? "" : mesh.error().message);
  Result<HeightTile> heights =
      maker.height_tile(TileScheme::geographic, a, TileFormat::quantized_mesh, {});
  EXPECT_TRUE(heights.ok());
  return {mesh.ok() ? *mesh : QuantizedMesh{}, heights.ok() ? *heights : HeightTile{}};
}

int grid_index(std::uint16_t quantized, int n) {
  return static_cast<int>(std::lround(quantized * double(n - 1) / 32767.0));
}

/// Decoded heights against the height tile: within half the edge quantum on edges (and at most
/// that inside, where the tile's own quantum is finer).
void expect_heights_match(const DecodedTile& t, double edge_quantum) {
  const int n = t.heights.width;
  ASSERT_GT(n, 1);
  ASSERT_FALSE(t.mesh.u.empty());
  for (std::size_t i = 0; i < t.mesh.u.size(); ++i) {
    const int column = grid_index(t.mesh.u[i], n), row = n - 1 - grid_index(t.mesh.v[i], n);
    const double expected = t.heights.elevation[static_cast<std::size_t>(row * n + column)];
    ASSERT_NEAR(t.mesh.height_metres(i), expected, edge_quantum / 2 + 1e-9 * std::abs(expected))
        << "vertex " << i;
  }
}

/// Heights along the west (column 0) or east (column n−1) edge, by row.
std::map<int, double> edge_heights(const DecodedTile& t, bool east) {
  const int n = t.heights.width;
  std::map<int, double> out;
  for (std::size_t i = 0; i < t.mesh.u.size(); ++i) {
    if (grid_index(t.mesh.u[i], n) == (east ? n - 1 : 0)) {
      out[grid_index(t.mesh.v[i], n)] = t.mesh.height_metres(i);
    }
  }
  return out;
}

void expect_served_at_several_zooms(const std::string& root, double base_elevation = 0.0) {
  ProductMaker maker(source_of(root, base_elevation));
  const Interval range = maker.source().elevation_range;
  const double edge_quantum = edge_quantum_for(range.lo, range.hi);
  for (const int z : {6, 10, 13}) {
    const TileRange tiles = tiles_covering_area(maker.source(), TileScheme::geographic, z);
    ASSERT_LE(tiles.min_x, tiles.max_x);
    const TileAddress west{z, tiles.min_x, tiles.min_y}, east{z, tiles.min_x + 1, tiles.min_y};
    const DecodedTile a = decoded(maker, west), b = decoded(maker, east);
    expect_heights_match(a, edge_quantum);
    expect_heights_match(b, edge_quantum);
    const std::map<int, double> a_east = edge_heights(a, true), b_west = edge_heights(b, false);
    ASSERT_FALSE(a_east.empty());
    EXPECT_EQ(a_east, b_west) << "zoom " << z;
  }
}

// Its heights span a few metres only, so its range alone asks for the finest quantum, 2^-10 m,
// on which 40 km is not exact in a float header.
TEST(QuantizedMeshElevations, FlatSceneFortyKilometresUpIsServed) {
  expect_served_at_several_zooms(R"({"type": "disc", "center": [0, 0], "radius": 2000,
      "elevation": 40000, "noise": {"kind": "fbm", "amplitude": 8, "wavelength": 900}})",
                                 40000.0);
}

TEST(QuantizedMeshElevations, SceneSpanningTheValidExtremesIsServed) {
  expect_served_at_several_zooms(R"({"type": "blend", "base": 0, "children": [
      {"type": "disc", "center": [-1500, 0], "radius": 1400, "elevation": 100000},
      {"type": "disc", "center": [1500, 0], "radius": 1400, "elevation": -100000}]})");
}

// A whole scene's quantum covers its range and keeps every header height exact in float.
TEST(QuantizedMeshElevations, EdgeQuantumKeepsHeadersExactFarFromZero) {
  EXPECT_EQ(edge_quantum_for(0.0, 1500.0), edge_quantum_for(1500.0));
  const double q = edge_quantum_for(39999.0, 40016.0);
  EXPECT_LT((40016.0 + 32768 * q) / q, 16777216.0);
  EXPECT_LE(edge_quantum_for(-1e5, 1e5), 8.0);
  EXPECT_GE(32766 * edge_quantum_for(-1e5, 1e5), 2e5);
}

}  // namespace
}  // namespace terrain
