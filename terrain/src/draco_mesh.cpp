// Draco and glTF-binary encodings of tile meshes on a scene-wide position lattice.
//
// Why the seams are exact: every position is snapped to integer multiples of Q (a power of two)
// in scene coordinates, the tile origin is a lattice point, and Draco is told to quantise with
// origin 0 and range Q·(2^bits − 1), so its step is exactly Q and its integers are the lattice
// offsets from the tile origin. With at most 2^23 − 1 steps every quantise and dequantise
// operation Draco performs in float is exact (see the limits below), so a vertex decodes to
// origin + k·Q whichever tile carries it.
#include "terrain/draco_mesh.hpp"

// Imported targets' include directories are system directories for CMake, so Draco's own
// warnings stay out of our -Werror build.
#include <draco/compression/config/compression_shared.h>
#include <draco/compression/encode.h>
#include <draco/core/draco_version.h>
#include <draco/core/encoder_buffer.h>
#include <draco/mesh/mesh.h>
#include <draco/metadata/geometry_metadata.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "terrain/mesh_geometry.hpp"

namespace terrain {

namespace {

// Draco computes `floor(value / Q + 0.5f)` in float: exact only while value / Q < 2^23, where
// float still has a bit for the half. Dequantised positions k·Q are then exact floats too.
constexpr int kMaxPositionBits = 23;
constexpr double kMinQuantum = 0x1p-16, kMaxQuantum = 0x1p16;

bool is_power_of_two(double q) {
  int exponent = 0;
  return std::isfinite(q) && q > 0.0 && std::frexp(q, &exponent) == 0.5;
}

// Draco hands encoder options to its encoders as decimal text (std::to_string, read back with
// atof): only values that survive that round trip reach the bitstream unchanged.
bool survives_draco_options(float value) {
  return static_cast<float>(std::atof(std::to_string(value).c_str())) == value;
}

Status check_options(const DracoOptions& o) {
  if (!is_power_of_two(o.position_quantum) || o.position_quantum < kMinQuantum ||
      o.position_quantum > kMaxQuantum) {
    return Error{"position quantum must be a power of two between 2^-16 and 2^16 metres",
                 "/options/position_quantum"};
  }
  if (o.normal_bits < 2 || o.normal_bits > 16) {
    return Error{"normal bits must be between 2 and 16", "/options/normal_bits"};
  }
  if (!std::isfinite(o.skirt_height) || o.skirt_height < 0.0 ||
      (o.skirt_height > 0.0 && o.skirt_height < o.position_quantum)) {
    // Shallower skirts would snap onto the surface and leave zero-area walls.
    return Error{"skirt height must be 0 or at least the position quantum",
                 "/options/skirt_height"};
  }
  if (o.compression_level < 0 || o.compression_level > 10) {
    return Error{"compression level must be between 0 and 10", "/options/compression_level"};
  }
  return Ok{};
}

struct EncodedTile {
  std::vector<std::uint8_t> draco;
  std::array<double, 3> translation{};  ///< glTF axes, a lattice point
  std::array<float, 3> max{};           ///< local; the minimum is 0 on every axis
  std::uint32_t vertex_count = 0;
  std::size_t index_count = 0;
  int position_id = 0;  ///< Draco unique ids of the attributes
  int normal_id = 0;
};

using Lattice = std::array<std::int64_t, 3>;

Result<EncodedTile> encode_tile(const HeightTile& tile, const TileMesh& mesh,
                                const DracoOptions& options, bool with_metadata) {
  if (Status s = check_options(options); !s) return s.error();
  Result<MeshGeometry> resolved = mesh_geometry(tile, mesh);
  if (!resolved) return resolved.error();
  MeshGeometry& g = *resolved;
  // Edgebreaker only encodes vertices that triangles reach: a lone vertex would vanish and the
  // accessor counts would lie.
  std::vector<bool> used(g.positions.size(), false);
  for (std::uint32_t v : g.triangles) used[v] = true;
  if (auto it = std::find(used.begin(), used.end(), false); it != used.end()) {
    const auto v = static_cast<std::size_t>(it - used.begin());
    return Error{"vertex " + std::to_string(v) + " is in no triangle",
                 "/mesh/vertices/" + std::to_string(v)};
  }
  // Skirts reach no deeper than the lattice spans below the tile's own relief: a mesh simplified
  // by kilometres asks for kilometres of skirt, which would take its positions past the 2^23
  // quanta a tile may span. The 4 quanta spare cover the snapping of both ends.
  double skirt_height = options.skirt_height;
  if (skirt_height > 0.0) {
    double lowest = std::numeric_limits<double>::infinity(), highest = -lowest;
    for (const std::array<double, 3>& p : g.positions) {
      lowest = std::min(lowest, p[2]);
      highest = std::max(highest, p[2]);
    }
    const double q = options.position_quantum;
    const double room = q * static_cast<double>(kMaxPositionQuanta - 3) - (highest - lowest);
    if (room >= q) skirt_height = std::min(skirt_height, room);
  }
  if (Status s = add_skirts(g, skirt_height); !s) {
    return Error{s.error().message, "/mesh" + s.error().pointer};
  }

  // Lattice coordinates in glTF axes: x east, y up, z south. Dividing by a power of two is
  // exact, so the rounding sees the sample's own bits and two tiles agree on shared samples.
  const double q = options.position_quantum;
  const auto snap = [q](double v, std::int64_t& out) {
    const double k = std::round(v / q);
    if (!(std::fabs(k) < 0x1p52)) return false;
    out = static_cast<std::int64_t>(k);
    return true;
  };
  std::vector<Lattice> lattice(g.positions.size());
  for (std::size_t i = 0; i < g.positions.size(); ++i) {
    const std::array<double, 3>& p = g.positions[i];
    std::int64_t north = 0;
    if (!snap(p[0], lattice[i][0]) || !snap(p[2], lattice[i][1]) || !snap(p[1], north)) {
      return Error{"vertex " + std::to_string(i) + " is too far from the scene origin",
                   "/options/position_quantum"};
    }
    lattice[i][2] = -north;
  }
  Lattice low = lattice[0], high = lattice[0];
  for (const Lattice& l : lattice) {
    for (int a = 0; a < 3; ++a) {
      low[a] = std::min(low[a], l[a]);
      high[a] = std::max(high[a], l[a]);
    }
  }
  std::uint64_t span = 0;
  for (int a = 0; a < 3; ++a) {
    const auto axis_span = static_cast<std::uint64_t>(high[a] - low[a]);
    if (axis_span >= (std::uint64_t{1} << kMaxPositionBits)) {
      return Error{"the tile spans " + std::to_string(axis_span) + " position quanta along " +
                       "xyz"[a] + "; at most 2^23 − 1 decode exactly: use a coarser quantum",
                   "/options/position_quantum"};
    }
    span = std::max(span, axis_span);
  }
  {
    std::vector<Lattice> sorted = lattice;
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
      // Draco's connectivity merges points with equal positions.
      return Error{
          "two vertices snap to the same lattice point: the position quantum is too "
          "coarse for the sample spacing",
          "/options/position_quantum"};
    }
  }
  // The smallest bit count whose range covers the tile and reaches Draco intact; the range is
  // exact in float (Q is a power of two, 2^bits − 1 < 2^24) and gives a step of exactly Q.
  int bits = std::max(1, static_cast<int>(std::bit_width(span)));
  const auto range_for = [q](int b) {
    return static_cast<float>(q * static_cast<double>((std::uint64_t{1} << b) - 1));
  };
  while (bits <= kMaxPositionBits && !survives_draco_options(range_for(bits))) ++bits;
  if (bits > kMaxPositionBits) {
    return Error{"no Draco quantisation range is exact for this position quantum",
                 "/options/position_quantum"};
  }

  EncodedTile out;
  const auto n = static_cast<std::uint32_t>(g.positions.size());
  draco::Mesh dm;
  dm.set_num_points(n);
  draco::GeometryAttribute position;
  position.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false,
                sizeof(float) * 3, 0);
  const int position_att = dm.AddAttribute(position, true, n);
  draco::GeometryAttribute normal;
  normal.Init(draco::GeometryAttribute::NORMAL, nullptr, 3, draco::DT_FLOAT32, false,
              sizeof(float) * 3, 0);
  const int normal_att = dm.AddAttribute(normal, true, n);
  for (std::uint32_t i = 0; i < n; ++i) {
    std::array<float, 3> local{};
    for (int a = 0; a < 3; ++a) {
      local[a] = static_cast<float>(static_cast<double>(lattice[i][a] - low[a]) * q);
    }
    // glTF axes (x east, y up, z south) from (east, north, up).
    const std::array<float, 3>& nn = g.normals[i];
    const std::array<float, 3> gltf_normal{nn[0], nn[2], -nn[1]};
    dm.attribute(position_att)->SetAttributeValue(draco::AttributeValueIndex(i), local.data());
    dm.attribute(normal_att)->SetAttributeValue(draco::AttributeValueIndex(i), gltf_normal.data());
  }
  for (std::size_t t = 0; t < g.triangles.size(); t += 3) {
    dm.AddFace({draco::PointIndex(g.triangles[t]), draco::PointIndex(g.triangles[t + 1]),
                draco::PointIndex(g.triangles[t + 2])});
  }
  for (int a = 0; a < 3; ++a) {
    out.translation[a] = static_cast<double>(low[a]) * q;
    out.max[a] = static_cast<float>(static_cast<double>(high[a] - low[a]) * q);
  }
  if (with_metadata) {
    auto metadata = std::make_unique<draco::GeometryMetadata>();
    metadata->AddEntryDoubleArray(
        "translation", std::vector<double>(out.translation.begin(), out.translation.end()));
    metadata->AddEntryDouble("position_quantum", q);
    dm.AddMetadata(std::move(metadata));
  }

  draco::Encoder encoder;
  encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
  const int speed = 10 - options.compression_level;
  encoder.SetSpeedOptions(speed, speed);
  const float origin[3] = {0.0f, 0.0f, 0.0f};
  encoder.SetAttributeExplicitQuantization(draco::GeometryAttribute::POSITION, bits, 3, origin,
                                           range_for(bits));
  encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, options.normal_bits);
  draco::EncoderBuffer buffer;
  if (const draco::Status s = encoder.EncodeMeshToBuffer(dm, &buffer); !s.ok()) {
    return Error{"Draco could not encode the mesh: " + s.error_msg_string(), ""};
  }
  out.draco.assign(buffer.data(), buffer.data() + buffer.size());
  out.vertex_count = n;
  out.index_count = g.triangles.size();
  out.position_id = static_cast<int>(dm.attribute(position_att)->unique_id());
  out.normal_id = static_cast<int>(dm.attribute(normal_att)->unique_id());
  return out;
}

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int shift = 0; shift < 32; shift += 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

// GLB: 12-byte header, then a JSON and a BIN chunk, each padded to 4 bytes (JSON with spaces,
// BIN with zeros) so that every chunk starts aligned.
std::vector<std::uint8_t> glb_container(std::string json, const std::vector<std::uint8_t>& bin) {
  while (json.size() % 4 != 0) json.push_back(' ');
  const std::size_t bin_padded = (bin.size() + 3) / 4 * 4;
  std::vector<std::uint8_t> out;
  out.reserve(12 + 8 + json.size() + 8 + bin_padded);
  put_u32(out, 0x46546C67);  // "glTF"
  put_u32(out, 2);
  put_u32(out, static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin_padded));
  put_u32(out, static_cast<std::uint32_t>(json.size()));
  put_u32(out, 0x4E4F534A);  // "JSON"
  out.insert(out.end(), json.begin(), json.end());
  put_u32(out, static_cast<std::uint32_t>(bin_padded));
  put_u32(out, 0x004E4942);  // "BIN\0"
  out.insert(out.end(), bin.begin(), bin.end());
  out.resize(out.size() + (bin_padded - bin.size()), 0);
  return out;
}

}  // namespace

double position_quantum_for(double extent_metres, double elevation_range) {
  double span = 0.0;
  if (std::isfinite(extent_metres)) span = std::max(span, extent_metres);
  if (std::isfinite(elevation_range)) span = std::max(span, elevation_range);
  double q = 0x1p-7;
  while (span > q * 0x1p22 && q < kMaxQuantum) q *= 2.0;
  return q;
}

Result<std::vector<std::uint8_t>> encode_draco(const HeightTile& tile, const TileMesh& mesh,
                                               const DracoOptions& options) {
  Result<EncodedTile> encoded = encode_tile(tile, mesh, options, true);
  if (!encoded) return encoded.error();
  return std::move(encoded->draco);
}

Result<std::vector<std::uint8_t>> encode_glb(const HeightTile& tile, const TileMesh& mesh,
                                             const DracoOptions& options) {
  Result<EncodedTile> encoded = encode_tile(tile, mesh, options, false);
  if (!encoded) return encoded.error();
  const EncodedTile& e = *encoded;
  using Json = nlohmann::ordered_json;
  constexpr int kFloat = 5126, kUnsignedShort = 5123, kUnsignedInt = 5125, kTriangles = 4;
  const std::string name = std::string(scheme_name(tile.scheme)) + "/" +
                           std::to_string(tile.address.z) + "/" + std::to_string(tile.address.x) +
                           "/" + std::to_string(tile.address.y);
  Json doc;
  doc["asset"] = {
      {"version", "2.0"},
      {"generator", std::string("terrain_server (Draco ") + draco::kDracoVersion + ")"}};
  doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
  doc["extensionsRequired"] = {"KHR_draco_mesh_compression"};
  doc["scene"] = 0;
  doc["scenes"] = Json::array({{{"nodes", {0}}}});
  doc["nodes"] =
      Json::array({{{"name", name},
                    {"mesh", 0},
                    {"translation", {e.translation[0], e.translation[1], e.translation[2]}}}});
  doc["meshes"] = Json::array(
      {{{"name", name},
        {"primitives",
         Json::array({{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}},
                       {"indices", 2},
                       {"mode", kTriangles},
                       {"extensions",
                        {{"KHR_draco_mesh_compression",
                          {{"bufferView", 0},
                           {"attributes",
                            {{"POSITION", e.position_id}, {"NORMAL", e.normal_id}}}}}}}}})}}});
  // Accessors describe what Draco decodes; they have no bufferView of their own.
  doc["accessors"] =
      Json::array({{{"componentType", kFloat},
                    {"count", e.vertex_count},
                    {"type", "VEC3"},
                    {"min", {0.0, 0.0, 0.0}},
                    {"max",
                     {static_cast<double>(e.max[0]), static_cast<double>(e.max[1]),
                      static_cast<double>(e.max[2])}}},
                   {{"componentType", kFloat}, {"count", e.vertex_count}, {"type", "VEC3"}},
                   // 65535 is the primitive restart value of unsigned short indices.
                   {{"componentType", e.vertex_count < 65535 ? kUnsignedShort : kUnsignedInt},
                    {"count", e.index_count},
                    {"type", "SCALAR"}}});
  doc["bufferViews"] =
      Json::array({{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", e.draco.size()}}});
  doc["buffers"] = Json::array({{{"byteLength", e.draco.size()}}});
  return glb_container(doc.dump(), e.draco);
}

}  // namespace terrain
