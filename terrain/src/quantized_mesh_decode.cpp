// quantized-mesh-1.0 decoder, written from the specification (github.com/CesiumGS/quantized-mesh)
// without the encoder's code, so that round trips test one against the other. Every read is
// bounds-checked; every count is checked against the bytes left before anything is allocated.
#include <algorithm>
#include <bit>
#include <cmath>
#include <string>
#include <utility>

#include "terrain/quantized_mesh.hpp"

namespace terrain {

namespace {

constexpr std::size_t kHeaderBytes = 88;
constexpr std::uint32_t kMaxCoordinate = 32767;

class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}

  std::size_t position() const { return position_; }
  std::size_t left() const { return bytes_.size() - position_; }
  bool has(std::size_t count) const { return count <= left(); }

  // Callers check has() first; these never read past the end regardless.
  std::uint64_t unsigned_le(int count) {
    std::uint64_t v = 0;
    for (int i = 0; i < count && position_ < bytes_.size(); ++i) {
      v |= std::uint64_t{bytes_[position_++]} << (8 * i);
    }
    return v;
  }
  std::uint8_t u8() { return static_cast<std::uint8_t>(unsigned_le(1)); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(unsigned_le(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(unsigned_le(4)); }
  float f32() { return std::bit_cast<float>(u32()); }
  double f64() { return std::bit_cast<double>(unsigned_le(8)); }
  void skip(std::size_t count) { position_ += std::min(count, left()); }
  std::span<const std::uint8_t> take(std::size_t count) {
    const std::size_t n = std::min(count, left());
    const auto piece = bytes_.subspan(position_, n);
    position_ += n;
    return piece;
  }

 private:
  std::span<const std::uint8_t> bytes_;
  std::size_t position_ = 0;
};

Error truncated(const std::string& what, std::size_t at) {
  return Error{"truncated quantized-mesh: " + what + " at byte " + std::to_string(at), "/" + what};
}

// A count of items of `size` bytes each, with that many bytes present.
Result<std::uint32_t> read_count(Reader& r, const std::string& what, std::size_t size) {
  if (!r.has(4)) return truncated(what, r.position());
  const std::uint32_t count = r.u32();
  if (count > r.left() / size) {
    return Error{what + " count " + std::to_string(count) + " needs more bytes than the " +
                     std::to_string(r.left()) + " left",
                 "/" + what};
  }
  return count;
}

Result<std::vector<std::uint16_t>> read_coordinates(Reader& r, std::uint32_t count,
                                                    const char* what) {
  std::vector<std::uint16_t> out(count);
  std::int64_t value = 0;
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::uint32_t code = r.u16();
    // Zig-zag: even codes are non-negative deltas, odd codes negative ones.
    value += (code & 1u) != 0 ? -static_cast<std::int64_t>((code + 1) / 2)
                              : static_cast<std::int64_t>(code / 2);
    if (value < 0 || value > kMaxCoordinate) {
      return Error{
          std::string(what) + " decodes to " + std::to_string(value) + ", outside 0..32767",
          std::string("/") + what + "/" + std::to_string(i)};
    }
    out[i] = static_cast<std::uint16_t>(value);
  }
  return out;
}

std::uint32_t read_index(Reader& r, bool wide) {
  return wide ? r.u32() : r.u16();
}

Result<std::vector<std::uint32_t>> read_edge(Reader& r, const char* what, bool wide,
                                             std::uint32_t vertex_count) {
  auto count = read_count(r, what, wide ? 4 : 2);
  if (!count) return count.error();
  std::vector<std::uint32_t> out(*count);
  for (std::uint32_t i = 0; i < *count; ++i) {
    out[i] = read_index(r, wide);
    if (out[i] >= vertex_count) {
      return Error{std::string(what) + " index " + std::to_string(out[i]) + " out of range",
                   std::string("/") + what + "/" + std::to_string(i)};
    }
  }
  return out;
}

bool finite(const std::array<double, 3>& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

}  // namespace

double QuantizedMesh::height_metres(std::size_t vertex) const {
  const double m = header.minimum_height, big_m = header.maximum_height;
  return m + ((big_m - m) * height[vertex]) / 32767.0;
}

Result<QuantizedMesh> decode_quantized_mesh(std::span<const std::uint8_t> bytes) {
  Reader r(bytes);
  QuantizedMesh mesh;
  QuantizedMeshHeader& h = mesh.header;
  if (!r.has(kHeaderBytes)) return truncated("header", r.position());
  for (double& c : h.center) c = r.f64();
  h.minimum_height = r.f32();
  h.maximum_height = r.f32();
  for (double& c : h.bounding_sphere_center) c = r.f64();
  h.bounding_sphere_radius = r.f64();
  for (double& c : h.horizon_occlusion_point) c = r.f64();
  if (!finite(h.center) || !finite(h.bounding_sphere_center) ||
      !finite(h.horizon_occlusion_point) || !std::isfinite(h.bounding_sphere_radius) ||
      h.bounding_sphere_radius < 0.0) {
    return Error{"header holds a non-finite value or a negative radius", "/header"};
  }
  if (!std::isfinite(h.minimum_height) || !std::isfinite(h.maximum_height) ||
      h.minimum_height > h.maximum_height) {
    return Error{"header heights must be finite with minimum ≤ maximum", "/header"};
  }

  auto vertex_count = read_count(r, "vertices", 6);
  if (!vertex_count) return vertex_count.error();
  const std::uint32_t vc = *vertex_count;
  for (auto [target, name] :
       {std::pair{&mesh.u, "u"}, std::pair{&mesh.v, "v"}, std::pair{&mesh.height, "height"}}) {
    auto values = read_coordinates(r, vc, name);
    if (!values) return values.error();
    *target = std::move(values).value();
  }

  // More than 64 Ki vertices: 32-bit indices, aligned to 4 bytes (16-bit ones to 2).
  const bool wide = vc > 65536;
  const std::size_t index_bytes = wide ? 4 : 2;
  const std::size_t padding = (index_bytes - r.position() % index_bytes) % index_bytes;
  if (!r.has(padding)) return truncated("indices", r.position());
  r.skip(padding);
  auto triangle_count = read_count(r, "triangles", 3 * index_bytes);
  if (!triangle_count) return triangle_count.error();
  mesh.indices.resize(std::size_t{*triangle_count} * 3);
  std::uint64_t highest = 0;
  for (std::size_t i = 0; i < mesh.indices.size(); ++i) {
    const std::uint32_t code = read_index(r, wide);
    if (code > highest || highest - code >= vc) {
      return Error{"triangle index code " + std::to_string(code) + " is out of range",
                   "/triangles/" + std::to_string(i)};
    }
    mesh.indices[i] = static_cast<std::uint32_t>(highest - code);
    if (code == 0) ++highest;
  }

  for (auto [target, name] : {std::pair{&mesh.west, "west"}, std::pair{&mesh.south, "south"},
                              std::pair{&mesh.east, "east"}, std::pair{&mesh.north, "north"}}) {
    auto list = read_edge(r, name, wide, vc);
    if (!list) return list.error();
    *target = std::move(list).value();
  }

  while (r.left() > 0) {
    const std::size_t at = r.position();
    if (!r.has(5)) return truncated("extension header", at);
    const std::uint8_t id = r.u8();
    const std::uint32_t length = r.u32();
    if (!r.has(length)) return truncated("extension " + std::to_string(id), at);
    const std::span<const std::uint8_t> data = r.take(length);
    const std::string pointer = "/extensions/" + std::to_string(id);
    const auto repeated = [&] {
      return Error{"extension " + std::to_string(id) + " appears twice", pointer};
    };
    switch (id) {
      case 1:
        if (mesh.normals) return repeated();
        if (length != 2ull * vc) {
          return Error{"normals extension has " + std::to_string(length) + " bytes for " +
                           std::to_string(vc) + " vertices",
                       pointer};
        }
        mesh.normals.emplace(data.begin(), data.end());
        break;
      case 2:
        if (mesh.water_mask) return repeated();
        if (length != 1 && length != 256u * 256u) {
          return Error{"water mask has " + std::to_string(length) + " bytes, not 1 or 65536",
                       pointer};
        }
        mesh.water_mask.emplace(data.begin(), data.end());
        break;
      case 4: {
        if (mesh.metadata) return repeated();
        std::uint32_t json_length = 0;
        if (length >= 4) {
          json_length = static_cast<std::uint32_t>(data[0]) | (std::uint32_t{data[1]} << 8) |
                        (std::uint32_t{data[2]} << 16) | (std::uint32_t{data[3]} << 24);
        }
        if (length < 4 || json_length != length - 4) {
          return Error{"metadata length disagrees with its extension length", pointer};
        }
        std::string json(reinterpret_cast<const char*>(data.data() + 4), json_length);
        if (!nlohmann::json::accept(json)) return Error{"metadata is not JSON", pointer};
        mesh.metadata = std::move(json);
        break;
      }
      default:
        mesh.unknown_extensions.push_back(id);
        break;
    }
  }
  return mesh;
}

}  // namespace terrain
