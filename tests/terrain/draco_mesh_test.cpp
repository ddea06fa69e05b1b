// Draco and glTF-binary tile meshes, decoded with draco::Decoder (the GLB container parsed here)
// and compared with the tiles they came from.
#include "terrain/draco_mesh.hpp"

#include <draco/compression/config/compression_shared.h>
#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>
#include <draco/metadata/geometry_metadata.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "synthetic_tiles.hpp"
#include "terrain/mesh_geometry.hpp"

namespace terrain {
namespace {

using test_tiles::synthetic_tile;
using Bytes = std::vector<std::uint8_t>;
using Json = nlohmann::json;

constexpr double kQ = 1.0 / 128;

// Octahedral quantisation with b bits per coordinate: the decoded normal is off by at most a
// few of the 2 / (2^b − 1) steps of the octahedron's square, the sphere being at most
// stretched by ~2 over it.
double normal_tolerance(int bits) {
  return 4.0 / static_cast<double>((1 << bits) - 1);
}

DracoOptions options_with(double skirt_height) {
  DracoOptions o;
  o.position_quantum = kQ;
  o.skirt_height = skirt_height;
  return o;
}

// ---- Decoding -----------------------------------------------------------------------------

struct Decoded {
  std::array<double, 3> translation{};
  std::vector<std::array<float, 3>> local;
  std::vector<std::array<double, 3>> world;  ///< translation + local, in doubles
  std::vector<std::array<float, 3>> normals;
  std::size_t faces = 0;
};

std::unique_ptr<draco::Mesh> decode_mesh(const std::uint8_t* data, std::size_t size) {
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(data), size);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) {
    ADD_FAILURE() << "Draco cannot decode: " << decoded.status().error_msg_string();
    return nullptr;
  }
  return std::move(decoded).value();
}

Decoded read_mesh(const draco::Mesh& mesh, const draco::PointAttribute* position,
                  const draco::PointAttribute* normal, const std::array<double, 3>& translation) {
  Decoded d;
  d.translation = translation;
  d.faces = mesh.num_faces();
  if (position == nullptr || normal == nullptr) {
    ADD_FAILURE() << "missing POSITION or NORMAL";
    return d;
  }
  EXPECT_EQ(position->num_components(), 3);
  EXPECT_EQ(normal->num_components(), 3);
  for (draco::PointIndex i(0); i < mesh.num_points(); ++i) {
    std::array<float, 3> p{}, n{};
    position->GetMappedValue(i, p.data());
    normal->GetMappedValue(i, n.data());
    d.local.push_back(p);
    d.world.push_back({translation[0] + p[0], translation[1] + p[1], translation[2] + p[2]});
    d.normals.push_back(n);
  }
  return d;
}

std::optional<Decoded> decode_drc(const Bytes& drc) {
  const std::unique_ptr<draco::Mesh> mesh = decode_mesh(drc.data(), drc.size());
  if (!mesh) return std::nullopt;
  const draco::GeometryMetadata* metadata = mesh->GetMetadata();
  std::vector<double> translation;
  if (metadata == nullptr || !metadata->GetEntryDoubleArray("translation", &translation) ||
      translation.size() != 3) {
    ADD_FAILURE() << "no translation metadata";
    return std::nullopt;
  }
  double quantum = 0.0;
  EXPECT_TRUE(metadata->GetEntryDouble("position_quantum", &quantum));
  EXPECT_EQ(quantum, kQ);
  return read_mesh(*mesh, mesh->GetNamedAttribute(draco::GeometryAttribute::POSITION),
                   mesh->GetNamedAttribute(draco::GeometryAttribute::NORMAL),
                   {translation[0], translation[1], translation[2]});
}

std::uint32_t u32(const Bytes& b, std::size_t at) {
  return static_cast<std::uint32_t>(b[at]) | static_cast<std::uint32_t>(b[at + 1]) << 8 |
         static_cast<std::uint32_t>(b[at + 2]) << 16 | static_cast<std::uint32_t>(b[at + 3]) << 24;
}

struct Glb {
  Json json;
  Bytes bin;
};

// The GLB container as the glTF 2.0 spec lays it out: a 12-byte header ("glTF", version 2, total
// length), a JSON chunk and a BIN chunk, each 4-byte aligned.
std::optional<Glb> parse_glb(const Bytes& bytes) {
  if (bytes.size() < 28) {
    ADD_FAILURE() << "too short for a GLB";
    return std::nullopt;
  }
  EXPECT_EQ(u32(bytes, 0), 0x46546C67u) << "magic";
  EXPECT_EQ(u32(bytes, 4), 2u) << "version";
  EXPECT_EQ(u32(bytes, 8), bytes.size()) << "length";
  EXPECT_EQ(bytes.size() % 4, 0u);
  const std::uint32_t json_length = u32(bytes, 12);
  EXPECT_EQ(u32(bytes, 16), 0x4E4F534Au) << "first chunk is JSON";
  EXPECT_EQ(json_length % 4, 0u);
  const std::size_t bin_at = 20 + static_cast<std::size_t>(json_length);
  if (bin_at + 8 > bytes.size()) {
    ADD_FAILURE() << "no BIN chunk";
    return std::nullopt;
  }
  const std::uint32_t bin_length = u32(bytes, bin_at);
  EXPECT_EQ(u32(bytes, bin_at + 4), 0x004E4942u) << "second chunk is BIN";
  EXPECT_EQ(bin_length % 4, 0u);
  EXPECT_EQ(bin_at + 8 + bin_length, bytes.size());
  Glb glb;
  glb.json = Json::parse(bytes.begin() + 20, bytes.begin() + static_cast<std::ptrdiff_t>(bin_at));
  glb.bin.assign(bytes.begin() + static_cast<std::ptrdiff_t>(bin_at + 8), bytes.end());
  return glb;
}

Bytes pack_glb(const std::string& json_text, const Bytes& bin) {
  std::string json = json_text;
  while (json.size() % 4 != 0) json.push_back(' ');
  Bytes out;
  const auto put = [&out](std::size_t v) {
    for (int s = 0; s < 32; s += 8) out.push_back(static_cast<std::uint8_t>(v >> s));
  };
  put(0x46546C67);
  put(2);
  put(28 + json.size() + bin.size());
  put(json.size());
  put(0x4E4F534A);
  out.insert(out.end(), json.begin(), json.end());
  put(bin.size());
  put(0x004E4942);
  out.insert(out.end(), bin.begin(), bin.end());
  return out;
}

// Decodes the Draco data that the primitive's extension references.
std::optional<Decoded> decode_glb(const Glb& glb) {
  const Json& primitive = glb.json.at("meshes").at(0).at("primitives").at(0);
  const Json& draco_ext = primitive.at("extensions").at("KHR_draco_mesh_compression");
  const Json& view = glb.json.at("bufferViews").at(draco_ext.at("bufferView").get<std::size_t>());
  EXPECT_EQ(view.at("buffer"), 0);
  const std::size_t offset = view.value("byteOffset", std::size_t{0});
  const auto length = view.at("byteLength").get<std::size_t>();
  if (offset + length > glb.bin.size()) {
    ADD_FAILURE() << "bufferView outside the BIN chunk";
    return std::nullopt;
  }
  const std::unique_ptr<draco::Mesh> mesh = decode_mesh(glb.bin.data() + offset, length);
  if (!mesh) return std::nullopt;
  const Json& t = glb.json.at("nodes").at(0).at("translation");
  return read_mesh(
      *mesh,
      mesh->GetAttributeByUniqueId(draco_ext.at("attributes").at("POSITION").get<std::uint32_t>()),
      mesh->GetAttributeByUniqueId(draco_ext.at("attributes").at("NORMAL").get<std::uint32_t>()),
      {t.at(0).get<double>(), t.at(1).get<double>(), t.at(2).get<double>()});
}

std::optional<Decoded> encode_and_decode_glb(const HeightTile& tile, const TileMesh& mesh,
                                             const DracoOptions& options) {
  const Result<Bytes> glb = encode_glb(tile, mesh, options);
  if (!glb.ok()) {
    ADD_FAILURE() << glb.error().pointer << ": " << glb.error().message;
    return std::nullopt;
  }
  const std::optional<Glb> parsed = parse_glb(*glb);
  if (!parsed) return std::nullopt;
  return decode_glb(*parsed);
}

// ---- Matching decoded vertices with samples -------------------------------------------------

using Key = std::pair<std::int64_t, std::int64_t>;

// The lattice column (east) and row (south) of a scene position.
Key lattice_key(double scene_x, double scene_y) {
  return {std::llround(scene_x / kQ), -std::llround(scene_y / kQ)};
}

// Decoded vertices by lattice column and row, highest first (the surface above its skirt).
std::map<Key, std::vector<std::size_t>> by_key(const Decoded& d) {
  std::map<Key, std::vector<std::size_t>> m;
  for (std::size_t i = 0; i < d.world.size(); ++i) {
    const double kx = d.world[i][0] / kQ, kz = d.world[i][2] / kQ;
    EXPECT_EQ(kx, std::round(kx)) << "vertex " << i << " is off the lattice";
    EXPECT_EQ(kz, std::round(kz)) << "vertex " << i << " is off the lattice";
    EXPECT_EQ(d.world[i][1] / kQ, std::round(d.world[i][1] / kQ));
    auto& list = m[{std::llround(kx), std::llround(kz)}];
    list.push_back(i);
    std::sort(list.begin(), list.end(),
              [&d](std::size_t a, std::size_t b) { return d.world[a][1] > d.world[b][1]; });
  }
  return m;
}

std::array<float, 3> gltf_normal(const HeightTile& tile, std::uint32_t sample) {
  const std::array<float, 3> n =
      normal_from_slopes(tile.slope_east[sample], tile.slope_north[sample]);
  return {n[0], n[2], -n[1]};
}

bool on_boundary(const HeightTile& tile, std::uint32_t sample) {
  const int row = static_cast<int>(sample) / tile.width,
            column = static_cast<int>(sample) % tile.width;
  return row == 0 || column == 0 || row == tile.width - 1 || column == tile.width - 1;
}

// Every mesh vertex decodes within Q/2 of its sample (x east, y up, z south) with its normal
// within the octahedral error; boundary samples also have a skirt copy skirt_height lower with
// the same decoded normal; nothing else is decoded.
void expect_matches_tile(const Decoded& d, const HeightTile& tile, const TileMesh& mesh,
                         double skirt_height, int normal_bits = 10) {
  const auto groups = by_key(d);
  std::size_t expected_vertices = 0;
  double worst_normal = 0.0;
  for (const std::uint32_t s : mesh.vertices) {
    const auto it = groups.find(lattice_key(tile.scene_x[s], tile.scene_y[s]));
    ASSERT_NE(it, groups.end()) << "sample " << s << " was not decoded";
    const bool skirted = skirt_height > 0 && on_boundary(tile, s);
    ASSERT_EQ(it->second.size(), skirted ? 2u : 1u) << "sample " << s;
    expected_vertices += it->second.size();
    const std::size_t top = it->second[0];
    const std::array<double, 3>& p = d.world[top];
    EXPECT_LE(std::fabs(p[0] - tile.scene_x[s]), kQ / 2) << s;
    EXPECT_LE(std::fabs(p[1] - tile.elevation[s]), kQ / 2) << s;
    EXPECT_LE(std::fabs(p[2] + tile.scene_y[s]), kQ / 2) << s;
    const std::array<float, 3> n = gltf_normal(tile, s);
    for (int a = 0; a < 3; ++a) {
      worst_normal = std::max(worst_normal, std::fabs(double{d.normals[top][a]} - n[a]));
    }
    if (skirted) {
      const std::size_t bottom = it->second[1];
      EXPECT_EQ(d.world[bottom][0], p[0]);
      EXPECT_EQ(d.world[bottom][2], p[2]);
      EXPECT_LE(std::fabs(d.world[bottom][1] - (tile.elevation[s] - skirt_height)), kQ / 2) << s;
      EXPECT_EQ(d.normals[bottom], d.normals[top]) << "skirt normal of sample " << s;
    }
  }
  EXPECT_LE(worst_normal, normal_tolerance(normal_bits));
  EXPECT_EQ(d.world.size(), expected_vertices) << "decoded vertices that are no sample";
}

std::size_t boundary_edges(const HeightTile& tile) {
  return 4 * static_cast<std::size_t>(tile.width - 1);
}

// ---- Tests ----------------------------------------------------------------------------------

TEST(DracoMesh, DrcDecodesToTheTileSamplesWithinHalfAQuantum) {
  const HeightTile tile = synthetic_tile(2, 1, 2, 16);
  const TileMesh mesh = triangulate_grid(tile.width);
  const Result<Bytes> drc = encode_draco(tile, mesh, options_with(0.0));
  ASSERT_TRUE(drc.ok()) << drc.error().message;
  ASSERT_GT(drc->size(), 9u);
  EXPECT_EQ(std::string(drc->begin(), drc->begin() + 5), "DRACO");
  EXPECT_EQ(int{(*drc)[7]}, static_cast<int>(draco::TRIANGULAR_MESH));
  EXPECT_EQ(int{(*drc)[8]}, static_cast<int>(draco::MESH_EDGEBREAKER_ENCODING));
  const std::optional<Decoded> d = decode_drc(*drc);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->faces, mesh.triangles.size() / 3);
  expect_matches_tile(*d, tile, mesh, 0.0);
}

TEST(DracoMesh, GlbHoldsOneDracoPrimitivePlacedByItsNodeTranslation) {
  const HeightTile tile = synthetic_tile(2, 1, 2, 16);
  const TileMesh mesh = triangulate_grid(tile.width);
  const Result<Bytes> bytes = encode_glb(tile, mesh, options_with(0.0));
  ASSERT_TRUE(bytes.ok()) << bytes.error().message;
  const std::optional<Glb> glb = parse_glb(*bytes);
  ASSERT_TRUE(glb);
  const Json& j = glb->json;
  EXPECT_EQ(j.at("asset").at("version"), "2.0");
  EXPECT_FALSE(j.at("asset").at("generator").get<std::string>().empty());
  EXPECT_EQ(j.at("extensionsUsed"), Json::array({"KHR_draco_mesh_compression"}));
  EXPECT_EQ(j.at("extensionsRequired"), Json::array({"KHR_draco_mesh_compression"}));
  EXPECT_EQ(j.at("scene"), 0);
  EXPECT_EQ(j.at("scenes"), Json::parse(R"([{"nodes":[0]}])"));
  ASSERT_EQ(j.at("nodes").size(), 1u);
  EXPECT_EQ(j.at("nodes").at(0).at("mesh"), 0);
  ASSERT_EQ(j.at("meshes").size(), 1u);
  ASSERT_EQ(j.at("meshes").at(0).at("primitives").size(), 1u);
  const Json& primitive = j.at("meshes").at(0).at("primitives").at(0);
  EXPECT_EQ(primitive.value("mode", 4), 4);
  for (const Json& accessor : j.at("accessors")) {
    EXPECT_FALSE(accessor.contains("bufferView")) << "Draco supplies the data";
  }
  const Json& view = j.at("bufferViews").at(0);
  EXPECT_EQ(view.at("byteOffset"), 0);
  EXPECT_EQ(j.at("buffers").at(0).at("byteLength"), view.at("byteLength"));
  EXPECT_LT(glb->bin.size() - view.at("byteLength").get<std::size_t>(), 4u);

  const std::optional<Decoded> d = decode_glb(*glb);
  ASSERT_TRUE(d);
  expect_matches_tile(*d, tile, mesh, 0.0);
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(d->translation[a] / kQ, std::round(d->translation[a] / kQ)) << "off the lattice";
  }

  // The accessors describe exactly what Draco decodes, min/max included.
  const Json& position =
      j.at("accessors").at(primitive.at("attributes").at("POSITION").get<std::size_t>());
  const Json& normal =
      j.at("accessors").at(primitive.at("attributes").at("NORMAL").get<std::size_t>());
  const Json& indices = j.at("accessors").at(primitive.at("indices").get<std::size_t>());
  EXPECT_EQ(position.at("componentType"), 5126);
  EXPECT_EQ(position.at("type"), "VEC3");
  EXPECT_EQ(normal.at("type"), "VEC3");
  EXPECT_EQ(position.at("count"), d->local.size());
  EXPECT_EQ(normal.at("count"), d->local.size());
  EXPECT_EQ(indices.at("count"), 3 * d->faces);
  EXPECT_EQ(indices.at("componentType"), 5123);
  EXPECT_EQ(d->faces, mesh.triangles.size() / 3);
  std::array<float, 3> lo = d->local[0], hi = d->local[0];
  for (const auto& p : d->local) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(position.at("min").at(a).get<float>(), lo[a]);
    EXPECT_EQ(position.at("max").at(a).get<float>(), hi[a]);
    EXPECT_EQ(position.at("min").at(a).get<double>(), static_cast<double>(lo[a]));
    EXPECT_EQ(position.at("max").at(a).get<double>(), static_cast<double>(hi[a]));
  }
}

TEST(DracoMesh, SkirtsHangBelowEveryBoundaryVertexWithItsNormal) {
  const HeightTile tile = synthetic_tile(3, 5, 2, 8);
  const TileMesh mesh = triangulate_grid(tile.width);
  const std::optional<Decoded> d = encode_and_decode_glb(tile, mesh, options_with(25.0));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->faces, mesh.triangles.size() / 3 + 2 * boundary_edges(tile));
  EXPECT_EQ(d->world.size(), mesh.vertices.size() + boundary_edges(tile));
  expect_matches_tile(*d, tile, mesh, 25.0);

  const Result<Bytes> drc = encode_draco(tile, mesh, options_with(25.0));
  ASSERT_TRUE(drc.ok());
  const std::optional<Decoded> from_drc = decode_drc(*drc);
  ASSERT_TRUE(from_drc);
  expect_matches_tile(*from_drc, tile, mesh, 25.0);
}

TEST(DracoMesh, CoarseMeshesCarryOnlyTheirOwnVertices) {
  // Corners and centre of a 5×5 grid, as an adaptive mesher would leave a flat area.
  const HeightTile tile = synthetic_tile(4, 7, 9, 4);
  TileMesh mesh;
  mesh.grid_size = 5;
  mesh.vertices = {0, 4, 12, 20, 24};  // nw, ne, centre, sw, se
  mesh.triangles = {2, 1, 0, 2, 0, 3, 2, 3, 4, 2, 4, 1};
  const std::optional<Decoded> d = encode_and_decode_glb(tile, mesh, options_with(10.0));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->faces, 4u + 8u);
  expect_matches_tile(*d, tile, mesh, 10.0);
}

// Neighbours built from the same function share their edge samples bit for bit; so must the
// decoded meshes, in world coordinates, whatever each tile's origin.
void expect_shared_edge_identical(const HeightTile& a, const HeightTile& b, bool east_west,
                                  const DracoOptions& options) {
  const TileMesh mesh = triangulate_grid(a.width);
  const std::optional<Decoded> da = encode_and_decode_glb(a, mesh, options);
  const std::optional<Decoded> db = encode_and_decode_glb(b, mesh, options);
  ASSERT_TRUE(da && db);
  EXPECT_NE(da->translation, db->translation);
  const auto ga = by_key(*da), gb = by_key(*db);
  const int last = a.width - 1;
  for (int i = 0; i < a.width; ++i) {
    const std::size_t sa = east_west ? a.index(last, i) : a.index(i, last);
    const std::size_t sb = east_west ? b.index(0, i) : b.index(i, 0);
    ASSERT_EQ(a.scene_x[sa], b.scene_x[sb]);
    ASSERT_EQ(a.scene_y[sa], b.scene_y[sb]);
    ASSERT_EQ(a.elevation[sa], b.elevation[sb]);
    const Key key = lattice_key(a.scene_x[sa], a.scene_y[sa]);
    ASSERT_TRUE(ga.count(key) && gb.count(key)) << "edge sample " << i;
    const std::size_t va = ga.at(key)[0], vb = gb.at(key)[0];
    EXPECT_EQ(da->world[va], db->world[vb]) << "edge sample " << i;
    EXPECT_EQ(da->normals[va], db->normals[vb]) << "edge sample " << i;
    // The local positions differ: the tiles have different origins.
    if (east_west) {
      EXPECT_NE(da->local[va][0], db->local[vb][0]);
    }
  }
}

TEST(DracoMesh, EastWestNeighboursDecodeTheirSharedEdgeBitForBit) {
  expect_shared_edge_identical(synthetic_tile(3, 2, 5, 16), synthetic_tile(3, 3, 5, 16), true,
                               options_with(0.0));
  expect_shared_edge_identical(synthetic_tile(5, 17, 11, 8), synthetic_tile(5, 18, 11, 8), true,
                               options_with(40.0));
  // Tiles a few metres wide: the smallest range that covers them would not reach Draco intact.
  expect_shared_edge_identical(synthetic_tile(10, 517, 300, 4), synthetic_tile(10, 518, 300, 4),
                               true, options_with(0.0));
}

TEST(DracoMesh, NorthSouthNeighboursDecodeTheirSharedEdgeBitForBit) {
  // Local rows grow southwards: (3, 2, 6) lies south of (3, 2, 5).
  expect_shared_edge_identical(synthetic_tile(3, 2, 5, 16), synthetic_tile(3, 2, 6, 16), false,
                               options_with(0.0));
  expect_shared_edge_identical(synthetic_tile(5, 17, 11, 8), synthetic_tile(5, 17, 12, 8), false,
                               options_with(40.0));
  expect_shared_edge_identical(synthetic_tile(10, 517, 300, 4), synthetic_tile(10, 517, 301, 4),
                               false, options_with(0.0));
}

TEST(DracoMesh, IdenticalInputGivesIdenticalBytes) {
  const TileMesh mesh = triangulate_grid(17);
  const DracoOptions options = options_with(30.0);
  const Result<Bytes> drc1 = encode_draco(synthetic_tile(2, 3, 1, 16), mesh, options);
  const Result<Bytes> drc2 = encode_draco(synthetic_tile(2, 3, 1, 16), mesh, options);
  const Result<Bytes> glb1 = encode_glb(synthetic_tile(2, 3, 1, 16), mesh, options);
  const Result<Bytes> glb2 = encode_glb(synthetic_tile(2, 3, 1, 16), mesh, options);
  ASSERT_TRUE(drc1.ok() && drc2.ok() && glb1.ok() && glb2.ok());
  EXPECT_EQ(*drc1, *drc2);
  EXPECT_EQ(*glb1, *glb2);
}

TEST(DracoMesh, LargeTilesUseUnsignedIntIndices) {
  const HeightTile tile = synthetic_tile(0, 0, 0, 256);  // 257² vertices: more than 65535
  const Result<Bytes> bytes = encode_glb(tile, triangulate_grid(tile.width), options_with(0.0));
  ASSERT_TRUE(bytes.ok()) << bytes.error().message;
  const std::optional<Glb> glb = parse_glb(*bytes);
  ASSERT_TRUE(glb);
  const Json& primitive = glb->json.at("meshes").at(0).at("primitives").at(0);
  EXPECT_EQ(
      glb->json.at("accessors").at(primitive.at("indices").get<std::size_t>()).at("componentType"),
      5125);
}

TEST(DracoMesh, RefusesMalformedInput) {
  const HeightTile good_tile = synthetic_tile(1, 0, 0, 4);
  const TileMesh grid = triangulate_grid(good_tile.width);
  struct Input {
    HeightTile tile;
    TileMesh mesh;
    DracoOptions options;
  };
  struct Case {
    std::string what;
    std::function<void(Input&)> edit;
    std::string pointer;
  };
  std::vector<Case> cases = {
      // The tile.
      {"cell_centres layout", [](Input& in) { in.tile.layout = SampleLayout::cell_centres; },
       "/tile/layout"},
      {"short elevation", [](Input& in) { in.tile.elevation.pop_back(); }, "/tile/elevation"},
      {"long slope_east", [](Input& in) { in.tile.slope_east.push_back(0); }, "/tile/slope_east"},
      {"no slope_north", [](Input& in) { in.tile.slope_north.clear(); }, "/tile/slope_north"},
      {"short scene_x", [](Input& in) { in.tile.scene_x.pop_back(); }, "/tile/scene_x"},
      {"short scene_y", [](Input& in) { in.tile.scene_y.pop_back(); }, "/tile/scene_y"},
      {"rows unlike columns", [](Input& in) { in.tile.height = 4; }, "/tile/width"},
      {"NaN elevation", [](Input& in) { in.tile.elevation[7] = std::nanf(""); },
       "/tile/elevation/7"},
      {"infinite scene_y", [](Input& in) { in.tile.scene_y[9] = -HUGE_VAL; }, "/tile/scene_y/9"},
      {"NaN slope", [](Input& in) { in.tile.slope_north[3] = std::nanf(""); },
       "/tile/slope_north/3"},
      // The mesh.
      {"mesh of another grid", [](Input& in) { in.mesh = triangulate_grid(9); }, "/mesh/grid_size"},
      {"empty mesh",
       [](Input& in) {
         in.mesh.vertices.clear();
         in.mesh.triangles.clear();
       },
       "/mesh/triangles"},
      {"no triangles", [](Input& in) { in.mesh.triangles.clear(); }, "/mesh/triangles"},
      {"index list not in threes", [](Input& in) { in.mesh.triangles.pop_back(); },
       "/mesh/triangles"},
      {"vertex outside the grid", [](Input& in) { in.mesh.vertices[3] = 25; }, "/mesh/vertices/3"},
      {"vertex listed twice", [](Input& in) { in.mesh.vertices[3] = 2; }, "/mesh/vertices/3"},
      {"triangle of a missing vertex", [](Input& in) { in.mesh.triangles[7] = 25; },
       "/mesh/triangles/7"},
      {"degenerate triangle", [](Input& in) { in.mesh.triangles[4] = in.mesh.triangles[3]; },
       "/mesh/triangles/3"},
      {"vertex in no triangle",  // the first cell's two triangles are the only ones at vertex 0
       [](Input& in) {
         in.mesh.triangles.erase(in.mesh.triangles.begin(), in.mesh.triangles.begin() + 6);
       },
       "/mesh/vertices/0"},
      {"inconsistent orientation",  // the second triangle turned clockwise
       [](Input& in) { std::swap(in.mesh.triangles[4], in.mesh.triangles[5]); },
       "/mesh/triangles/5"},
      // The options.
      {"quantum coarser than the sample spacing (375 m)",
       [](Input& in) { in.options.position_quantum = 512.0; }, "/options/position_quantum"},
      {"tile wider than 2^23 quanta", [](Input& in) { in.options.position_quantum = 0x1p-14; },
       "/options/position_quantum"},
      {"negative skirt", [](Input& in) { in.options.skirt_height = -5.0; },
       "/options/skirt_height"},
      {"NaN skirt", [](Input& in) { in.options.skirt_height = std::nan(""); },
       "/options/skirt_height"},
      {"skirt shallower than a quantum", [](Input& in) { in.options.skirt_height = kQ / 2; },
       "/options/skirt_height"},
      {"1 normal bit", [](Input& in) { in.options.normal_bits = 1; }, "/options/normal_bits"},
      {"17 normal bits", [](Input& in) { in.options.normal_bits = 17; }, "/options/normal_bits"},
      {"compression level 11", [](Input& in) { in.options.compression_level = 11; },
       "/options/compression_level"},
  };
  for (const double q : {0.01, 0.0, -kQ, std::nan(""), HUGE_VAL, 0x1p-17, 0x1p17}) {
    cases.push_back({"quantum " + std::to_string(q),
                     [q](Input& in) { in.options.position_quantum = q; },
                     "/options/position_quantum"});
  }

  for (const Case& c : cases) {
    Input in{good_tile, grid, options_with(0.0)};
    c.edit(in);
    const Result<Bytes> drc = encode_draco(in.tile, in.mesh, in.options);
    const Result<Bytes> glb = encode_glb(in.tile, in.mesh, in.options);
    ASSERT_FALSE(drc.ok()) << c.what;
    ASSERT_FALSE(glb.ok()) << c.what;
    EXPECT_EQ(drc.error().pointer, c.pointer) << c.what << ": " << drc.error().message;
    EXPECT_EQ(glb.error().pointer, c.pointer) << c.what;
    EXPECT_FALSE(drc.error().message.empty()) << c.what;
  }
}

TEST(PositionQuantum, IsThePowerOfTwoCentimetreUnlessTheSceneNeedsCoarser) {
  EXPECT_EQ(position_quantum_for(3000.5, 800.0), 0x1p-7);
  EXPECT_EQ(position_quantum_for(32768.0, 0.0), 0x1p-7);  // exactly 2^22 quanta
  EXPECT_EQ(position_quantum_for(32768.5, 0.0), 0x1p-6);
  EXPECT_EQ(position_quantum_for(100000.0, 5000.0), 0x1p-5);
  EXPECT_EQ(position_quantum_for(100.0, 100000.0), 0x1p-5);  // elevation dominates
  EXPECT_EQ(position_quantum_for(4.0e7, 9000.0), 16.0);      // a planet's circumference
  EXPECT_EQ(position_quantum_for(std::nan(""), -1.0), 0x1p-7);
  EXPECT_EQ(position_quantum_for(HUGE_VAL, 0.0), 0x1p-7);
  EXPECT_EQ(position_quantum_for(1e30, 0.0), 0x1p16);
  // A zoom-0 tile of the synthetic scene encodes with the quantum chosen for it.
  const HeightTile root = synthetic_tile(0, 0, 0, 8);
  DracoOptions options;
  options.position_quantum = position_quantum_for(root.world.east - root.world.west, 1000.0);
  options.skirt_height = 100.0;
  EXPECT_TRUE(encode_glb(root, triangulate_grid(root.width), options).ok());
}

// Writes the .glb tiles the gltf_validator CTest checks, into $TERRAIN_GLTF_SAMPLE_DIR (set by
// that test's fixture; elsewhere a temporary folder), and one broken on purpose, with no asset.
TEST(GltfSamples, WriteValidatorInputs) {
  const char* env = std::getenv("TERRAIN_GLTF_SAMPLE_DIR");
  const std::filesystem::path dir =
      env != nullptr && *env != '\0'
          ? std::filesystem::path(env)
          : std::filesystem::path(::testing::TempDir()) / "terrain-gltf-samples";
  std::filesystem::create_directories(dir);
  const auto write = [&dir](const std::string& name, const Bytes& bytes) {
    std::ofstream out(dir / name, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
    ASSERT_TRUE(out.good()) << (dir / name);
  };
  const auto encode = [](const HeightTile& tile, const TileMesh& mesh, double skirt) {
    const Result<Bytes> glb = encode_glb(tile, mesh, options_with(skirt));
    EXPECT_TRUE(glb.ok()) << glb.error().message;
    return glb.ok() ? *glb : Bytes{};
  };
  const HeightTile hills = synthetic_tile(2, 1, 2, 16);
  const Bytes hills_glb = encode(hills, triangulate_grid(hills.width), 0.0);
  write("hills.glb", hills_glb);
  write("hills-skirt.glb", encode(hills, triangulate_grid(hills.width), 50.0));
  HeightTile flat = synthetic_tile(1, 1, 0, 8);
  std::fill(flat.elevation.begin(), flat.elevation.end(), 12.5f);
  std::fill(flat.slope_east.begin(), flat.slope_east.end(), 0.0f);
  std::fill(flat.slope_north.begin(), flat.slope_north.end(), 0.0f);
  write("flat.glb", encode(flat, triangulate_grid(flat.width), 0.0));
  const HeightTile large = synthetic_tile(0, 0, 0, 256);
  write("large.glb", encode(large, triangulate_grid(large.width), 20.0));

  std::optional<Glb> broken = parse_glb(hills_glb);
  ASSERT_TRUE(broken);
  broken->json.erase("asset");
  write("broken.glb", pack_glb(broken->json.dump(), broken->bin));
}

}  // namespace
}  // namespace terrain
