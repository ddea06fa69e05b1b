// PMTiles v3 (github.com/protomaps/PMTiles, spec/v3/spec.md), written from the specification:
// Hilbert tile ids, the 127-byte header, varint directories with run lengths and leaves, and
// the assembly of a pack from its scratch database once every tile is made.
#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <unordered_map>

#include "pack_store.hpp"
#include "terrain/gzip.hpp"

namespace terrain {

namespace {

constexpr std::size_t kHeaderBytes = 127;
// The header and the root directory must lie in the first 16 KiB (latency-optimised clients
// fetch that much first).
constexpr std::size_t kRootLimit = 16384;
constexpr std::uint8_t kCompressionNone = 1;
constexpr std::uint8_t kCompressionGzip = 2;
constexpr std::uint8_t kTileTypeUnknown = 0;
constexpr std::uint8_t kTileTypePng = 2;
constexpr std::uint8_t kTileTypeJpeg = 3;
constexpr std::size_t kMaxDirectoryBytes = std::size_t{256} << 20;

std::uint64_t tiles_below(int z) {
  return ((std::uint64_t{1} << (2 * z)) - 1) / 3;
}

// Turns the quadrant so that the curve's sub-squares connect (Hilbert's construction).
void rotate(std::uint64_t n, std::uint64_t& x, std::uint64_t& y, std::uint64_t rx,
            std::uint64_t ry) {
  if (ry == 0) {
    if (rx == 1) {
      x = n - 1 - x;
      y = n - 1 - y;
    }
    std::swap(x, y);
  }
}

void put_u64(std::vector<std::uint8_t>& out, std::size_t at, std::uint64_t v) {
  for (int i = 0; i < 8; ++i)
    out[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_i32(std::vector<std::uint8_t>& out, std::size_t at, std::int32_t v) {
  const auto u = static_cast<std::uint32_t>(v);
  for (int i = 0; i < 4; ++i)
    out[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(u >> (8 * i));
}
std::uint64_t get_u64(std::span<const std::uint8_t> in, std::size_t at) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | in[at + static_cast<std::size_t>(i)];
  return v;
}
std::int32_t get_i32(std::span<const std::uint8_t> in, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | in[at + static_cast<std::size_t>(i)];
  return static_cast<std::int32_t>(v);
}
std::int32_t e7(double degrees) {
  return static_cast<std::int32_t>(std::lround(degrees * 1e7));
}

void put_varint(std::vector<std::uint8_t>& out, std::uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<std::uint8_t>(v | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<std::uint8_t>(v));
}

struct VarintReader {
  std::span<const std::uint8_t> in;
  std::size_t at = 0;
  bool failed = false;
  std::uint64_t next() {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      if (at >= in.size()) break;
      const std::uint8_t b = in[at++];
      v |= static_cast<std::uint64_t>(b & 0x7f) << shift;
      if ((b & 0x80) == 0) return v;
    }
    failed = true;
    return 0;
  }
};

Result<std::vector<std::uint8_t>> compress(std::span<const std::uint8_t> bytes) {
  return gzip_compress(bytes, 9);
}

// The root directory and the leaves: everything in the root when it fits, else leaves of
// 4096 entries (doubled until the root of their first ids fits).
struct Directories {
  std::vector<std::uint8_t> root;
  std::vector<std::uint8_t> leaves;
};
Result<Directories> build_directories(const std::vector<PmtilesEntry>& entries) {
  Directories out;
  Result<std::vector<std::uint8_t>> root = compress(encode_pmtiles_directory(entries));
  if (!root) return root.error();
  if (kHeaderBytes + root->size() <= kRootLimit) {
    out.root = std::move(root).value();
    return out;
  }
  for (std::size_t leaf_size = 4096;; leaf_size *= 2) {
    out.leaves.clear();
    std::vector<PmtilesEntry> root_entries;
    for (std::size_t first = 0; first < entries.size(); first += leaf_size) {
      const std::size_t end = std::min(entries.size(), first + leaf_size);
      const std::vector<PmtilesEntry> chunk(entries.begin() + static_cast<std::ptrdiff_t>(first),
                                            entries.begin() + static_cast<std::ptrdiff_t>(end));
      Result<std::vector<std::uint8_t>> leaf = compress(encode_pmtiles_directory(chunk));
      if (!leaf) return leaf.error();
      root_entries.push_back(
          {chunk.front().tile_id, out.leaves.size(), static_cast<std::uint32_t>(leaf->size()), 0});
      out.leaves.insert(out.leaves.end(), leaf->begin(), leaf->end());
    }
    root = compress(encode_pmtiles_directory(root_entries));
    if (!root) return root.error();
    if (kHeaderBytes + root->size() <= kRootLimit) {
      out.root = std::move(root).value();
      return out;
    }
  }
}

std::string sha256(std::span<const std::uint8_t> bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr);
  return std::string(reinterpret_cast<const char*>(digest), length);
}

using pack::Database;
using pack::Statement;

TileAddress scheme_address(TileScheme scheme, const TileAddress& stored) {
  if (scheme == TileScheme::geographic) return {stored.z - 1, stored.x, stored.y};
  return stored;
}

// The scratch database: tiles by PMTiles id, and the export's identity.
class ScratchSink final : public pack::SqliteTileSink {
 public:
  using SqliteTileSink::SqliteTileSink;
  Result<std::vector<TileAddress>> stored() override {
    Result<Statement> select = db_.prepare("SELECT tile_id FROM tiles");
    if (!select) return select.error();
    std::vector<TileAddress> out;
    while (select->step() == SQLITE_ROW) {
      const auto id = static_cast<std::uint64_t>(select->column_int(0));
      out.push_back(scheme_address(scheme_, pmtiles_tile_address(id)));
    }
    return out;
  }
  Status put(const TileAddress& a, std::span<const std::uint8_t> bytes) override {
    const TileAddress p = pmtiles_address(scheme_, a);
    insert_.reset();
    insert_.bind(1, static_cast<std::int64_t>(pmtiles_tile_id(p.z, static_cast<std::uint64_t>(p.x),
                                                              static_cast<std::uint64_t>(p.y))));
    insert_.bind(2, bytes);
    if (insert_.step() != SQLITE_DONE) return Error{db_.message(), "/output"};
    return Ok{};
  }
};

nlohmann::json pack_metadata(const PackPlan& plan) {
  const bool geographic = plan.scheme == TileScheme::geographic;
  nlohmann::json m{
      {"name", plan.name},
      {"description", plan.description},
      {"type", "baselayer"},
      {"version", "1"},
      {"format", plan.format == TileFormat::quantized_mesh ? "quantized-mesh-1.0"
                                                           : pack::image_format(plan.format)},
      {"encoding", pack::format_label(plan.format)},
      {"tile_scheme", std::string(scheme_name(plan.scheme))},
      {"crs", geographic ? "EPSG:4326" : "EPSG:3857"},
      {"minzoom", plan.zooms.front().z},
      {"maxzoom", plan.zooms.back().z},
      {"bounds", {plan.bounds.west, plan.bounds.south, plan.bounds.east, plan.bounds.north}},
      {"terrain_export", plan.identity()},
  };
  if (geographic) {
    m["tile_address"] =
        "geographic tile z/x/y (EPSG:4326, TMS: 2^(z+1) columns, 2^z rows, row 0 south) is stored "
        "at PMTiles z+1/x/y";
  }
  for (const auto& [key, value] : plan.extra.items()) m[key] = value;
  return m;
}

bool write_all(std::FILE* file, std::span<const std::uint8_t> bytes) {
  return std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
}

// Writes the final file from the scratch database: tiles in tile id order, identical contents
// stored once, runs of equal consecutive tiles as one entry.
Result<PmtilesHeader> assemble(const std::string& path, Database& scratch, const PackPlan& plan) {
  const std::string data_path = path + ".data";
  const std::string final_tmp = path + ".tmp";
  std::FILE* data = std::fopen(data_path.c_str(), "wb");
  if (data == nullptr) return Error{"cannot write " + data_path, "/output"};
  std::vector<PmtilesEntry> entries;
  std::unordered_map<std::string, std::pair<std::uint64_t, std::uint32_t>> contents;
  std::uint64_t data_length = 0, addressed = 0;
  {
    Result<Statement> select = scratch.prepare("SELECT tile_id, data FROM tiles ORDER BY tile_id");
    if (!select) {
      std::fclose(data);
      return select.error();
    }
    while (select->step() == SQLITE_ROW) {
      const auto id = static_cast<std::uint64_t>(select->column_int(0));
      const std::vector<std::uint8_t> bytes = select->column_blob(1);
      if (bytes.empty()) {
        std::fclose(data);
        return Error{"tile id " + std::to_string(id) + " is empty (PMTiles needs length > 0)",
                     "/output"};
      }
      auto [it, added] = contents.try_emplace(sha256(bytes), data_length,
                                              static_cast<std::uint32_t>(bytes.size()));
      if (added) {
        if (!write_all(data, bytes)) {
          std::fclose(data);
          return Error{"cannot write " + data_path, "/output"};
        }
        data_length += bytes.size();
      }
      const auto [offset, length] = it->second;
      ++addressed;
      if (!entries.empty()) {
        PmtilesEntry& last = entries.back();
        if (last.tile_id + last.run_length == id && last.offset == offset &&
            last.length == length) {
          ++last.run_length;
          continue;
        }
      }
      entries.push_back({id, offset, length, 1});
    }
  }
  if (std::fclose(data) != 0) return Error{"cannot write " + data_path, "/output"};

  Result<Directories> directories = build_directories(entries);
  if (!directories) return directories.error();
  Result<std::vector<std::uint8_t>> metadata = gzip_compress(pack_metadata(plan).dump(), 9);
  if (!metadata) return metadata.error();

  const bool geographic = plan.scheme == TileScheme::geographic;
  PmtilesHeader h;
  h.root_offset = kHeaderBytes;
  h.root_length = directories->root.size();
  h.metadata_offset = h.root_offset + h.root_length;
  h.metadata_length = metadata->size();
  h.leaves_offset = h.metadata_offset + h.metadata_length;
  h.leaves_length = directories->leaves.size();
  h.data_offset = h.leaves_offset + h.leaves_length;
  h.data_length = data_length;
  h.addressed_tiles = addressed;
  h.tile_entries = entries.size();
  h.tile_contents = contents.size();
  h.clustered = true;
  h.internal_compression = kCompressionGzip;
  h.tile_compression =
      plan.format == TileFormat::quantized_mesh ? kCompressionGzip : kCompressionNone;
  h.tile_type = plan.format == TileFormat::quantized_mesh ? kTileTypeUnknown
                : plan.format == TileFormat::color_jpeg   ? kTileTypeJpeg
                                                          : kTileTypePng;
  h.min_zoom = plan.zooms.front().z + (geographic ? 1 : 0);
  h.max_zoom = plan.zooms.back().z + (geographic ? 1 : 0);
  h.min_lon = plan.bounds.west;
  h.min_lat = plan.bounds.south;
  h.max_lon = plan.bounds.east;
  h.max_lat = plan.bounds.north;
  h.center_zoom = h.min_zoom;
  h.center_lon = (plan.bounds.west + plan.bounds.east) / 2;
  h.center_lat = (plan.bounds.south + plan.bounds.north) / 2;

  std::FILE* out = std::fopen(final_tmp.c_str(), "wb");
  if (out == nullptr) return Error{"cannot write " + final_tmp, "/output"};
  bool ok = write_all(out, encode_pmtiles_header(h)) && write_all(out, directories->root) &&
            write_all(out, *metadata) && write_all(out, directories->leaves);
  if (std::FILE* in = ok ? std::fopen(data_path.c_str(), "rb") : nullptr; in != nullptr) {
    std::vector<std::uint8_t> buffer(std::size_t{1} << 20);
    for (std::size_t n; ok && (n = std::fread(buffer.data(), 1, buffer.size(), in)) > 0;) {
      ok = write_all(out, std::span(buffer).first(n));
    }
    std::fclose(in);
  } else {
    ok = false;
  }
  if (std::fclose(out) != 0 || !ok) return Error{"cannot write " + final_tmp, "/output"};
  std::error_code ec;
  std::filesystem::rename(final_tmp, path, ec);
  if (ec)
    return Error{"cannot rename " + final_tmp + " to " + path + ": " + ec.message(), "/output"};
  std::filesystem::remove(data_path, ec);
  return h;
}

}  // namespace

TileAddress pmtiles_address(TileScheme scheme, const TileAddress& address) {
  if (scheme == TileScheme::geographic) return {address.z + 1, address.x, address.y};
  return address;
}

std::uint64_t pmtiles_tile_id(int z, std::uint64_t x, std::uint64_t y) {
  const std::uint64_t n = std::uint64_t{1} << z;
  std::uint64_t d = 0;
  for (std::uint64_t s = n / 2; s > 0; s /= 2) {
    const std::uint64_t rx = (x & s) > 0 ? 1 : 0;
    const std::uint64_t ry = (y & s) > 0 ? 1 : 0;
    d += s * s * ((3 * rx) ^ ry);
    rotate(n, x, y, rx, ry);
  }
  return tiles_below(z) + d;
}

TileAddress pmtiles_tile_address(std::uint64_t tile_id) {
  int z = 0;
  while (z < 31 && tiles_below(z + 1) <= tile_id) ++z;
  std::uint64_t t = tile_id - tiles_below(z);
  const std::uint64_t n = std::uint64_t{1} << z;
  std::uint64_t x = 0, y = 0;
  for (std::uint64_t s = 1; s < n; s *= 2) {
    const std::uint64_t rx = 1 & (t / 2);
    const std::uint64_t ry = 1 & (t ^ rx);
    rotate(s, x, y, rx, ry);
    x += s * rx;
    y += s * ry;
    t /= 4;
  }
  return {z, static_cast<std::int64_t>(x), static_cast<std::int64_t>(y)};
}

std::vector<std::uint8_t> encode_pmtiles_header(const PmtilesHeader& h) {
  std::vector<std::uint8_t> out(kHeaderBytes, 0);
  const char magic[] = "PMTiles";
  std::copy(magic, magic + 7, out.begin());
  out[7] = 3;
  const std::uint64_t fields[] = {h.root_offset,     h.root_length,   h.metadata_offset,
                                  h.metadata_length, h.leaves_offset, h.leaves_length,
                                  h.data_offset,     h.data_length,   h.addressed_tiles,
                                  h.tile_entries,    h.tile_contents};
  for (std::size_t i = 0; i < std::size(fields); ++i) put_u64(out, 8 + 8 * i, fields[i]);
  out[96] = h.clustered ? 1 : 0;
  out[97] = h.internal_compression;
  out[98] = h.tile_compression;
  out[99] = h.tile_type;
  out[100] = static_cast<std::uint8_t>(h.min_zoom);
  out[101] = static_cast<std::uint8_t>(h.max_zoom);
  put_i32(out, 102, e7(h.min_lon));
  put_i32(out, 106, e7(h.min_lat));
  put_i32(out, 110, e7(h.max_lon));
  put_i32(out, 114, e7(h.max_lat));
  out[118] = static_cast<std::uint8_t>(h.center_zoom);
  put_i32(out, 119, e7(h.center_lon));
  put_i32(out, 123, e7(h.center_lat));
  return out;
}

Result<PmtilesHeader> decode_pmtiles_header(std::span<const std::uint8_t> in) {
  if (in.size() < kHeaderBytes || !std::equal(in.begin(), in.begin() + 7, "PMTiles")) {
    return Error{"not a PMTiles archive (no \"PMTiles\" magic)", "/magic"};
  }
  if (in[7] != 3) return Error{"PMTiles version " + std::to_string(in[7]) + ", not 3", "/version"};
  PmtilesHeader h;
  std::uint64_t* fields[] = {&h.root_offset,     &h.root_length,   &h.metadata_offset,
                             &h.metadata_length, &h.leaves_offset, &h.leaves_length,
                             &h.data_offset,     &h.data_length,   &h.addressed_tiles,
                             &h.tile_entries,    &h.tile_contents};
  for (std::size_t i = 0; i < std::size(fields); ++i) *fields[i] = get_u64(in, 8 + 8 * i);
  h.clustered = in[96] == 1;
  h.internal_compression = in[97];
  h.tile_compression = in[98];
  h.tile_type = in[99];
  h.min_zoom = in[100];
  h.max_zoom = in[101];
  h.min_lon = get_i32(in, 102) / 1e7;
  h.min_lat = get_i32(in, 106) / 1e7;
  h.max_lon = get_i32(in, 110) / 1e7;
  h.max_lat = get_i32(in, 114) / 1e7;
  h.center_zoom = in[118];
  h.center_lon = get_i32(in, 119) / 1e7;
  h.center_lat = get_i32(in, 123) / 1e7;
  return h;
}

std::vector<std::uint8_t> encode_pmtiles_directory(const std::vector<PmtilesEntry>& entries) {
  std::vector<std::uint8_t> out;
  put_varint(out, entries.size());
  std::uint64_t last_id = 0;
  for (const PmtilesEntry& e : entries) {
    put_varint(out, e.tile_id - last_id);
    last_id = e.tile_id;
  }
  for (const PmtilesEntry& e : entries) put_varint(out, e.run_length);
  for (const PmtilesEntry& e : entries) put_varint(out, e.length);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    // 0: right after the previous entry's bytes; else the offset plus one.
    const bool follows =
        i > 0 && entries[i].offset == entries[i - 1].offset + entries[i - 1].length;
    put_varint(out, follows ? 0 : entries[i].offset + 1);
  }
  return out;
}

Result<std::vector<PmtilesEntry>> decode_pmtiles_directory(std::span<const std::uint8_t> bytes) {
  VarintReader r{bytes};
  const std::uint64_t n = r.next();
  if (r.failed || n == 0 || n > bytes.size()) {
    return Error{"bad directory entry count", "/directory"};
  }
  std::vector<PmtilesEntry> entries(n);
  std::uint64_t id = 0;
  for (PmtilesEntry& e : entries) e.tile_id = id += r.next();
  for (PmtilesEntry& e : entries) e.run_length = static_cast<std::uint32_t>(r.next());
  for (PmtilesEntry& e : entries) e.length = static_cast<std::uint32_t>(r.next());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const std::uint64_t v = r.next();
    if (v == 0 && i == 0) return Error{"the first entry's offset is relative", "/directory"};
    entries[i].offset = v == 0 ? entries[i - 1].offset + entries[i - 1].length : v - 1;
  }
  if (r.failed || r.at != bytes.size())
    return Error{"truncated or overlong directory", "/directory"};
  return entries;
}

Result<PmtilesReader> PmtilesReader::open(const std::string& path) {
  PmtilesReader reader;
  reader.path_ = path;
  Result<std::vector<std::uint8_t>> head = reader.read(0, kHeaderBytes);
  if (!head) return head.error();
  Result<PmtilesHeader> header = decode_pmtiles_header(*head);
  if (!header) return header.error();
  reader.header_ = *header;
  if (header->internal_compression != kCompressionNone &&
      header->internal_compression != kCompressionGzip) {
    return Error{"internal compression " + std::to_string(header->internal_compression) +
                     " is not read (none or gzip)",
                 "/internal_compression"};
  }
  Result<std::vector<PmtilesEntry>> root =
      reader.directory(header->root_offset, header->root_length);
  if (!root) return root.error();
  reader.root_ = std::move(root).value();
  Result<std::vector<std::uint8_t>> metadata =
      reader.read(header->metadata_offset, header->metadata_length);
  if (!metadata) return metadata.error();
  if (header->internal_compression == kCompressionGzip) {
    metadata = gzip_decompress(*metadata, kMaxDirectoryBytes);
    if (!metadata) return metadata.error();
  }
  reader.metadata_ = nlohmann::json::parse(metadata->begin(), metadata->end(), nullptr, false);
  if (reader.metadata_.is_discarded()) return Error{"the metadata is not JSON", "/metadata"};
  return reader;
}

Result<std::vector<std::uint8_t>> PmtilesReader::read(std::uint64_t offset,
                                                      std::uint64_t length) const {
  if (length > kMaxDirectoryBytes) return Error{"section too large", "/length"};
  std::FILE* file = std::fopen(path_.c_str(), "rb");
  if (file == nullptr) return Error{"cannot open " + path_, "/output"};
  std::vector<std::uint8_t> out(length);
  const bool ok = fseeko(file, static_cast<off_t>(offset), SEEK_SET) == 0 &&
                  std::fread(out.data(), 1, out.size(), file) == out.size();
  std::fclose(file);
  if (!ok)
    return Error{"cannot read " + std::to_string(length) + " bytes at " + std::to_string(offset) +
                     " of " + path_,
                 "/length"};
  return out;
}

Result<std::vector<PmtilesEntry>> PmtilesReader::directory(std::uint64_t offset,
                                                           std::uint64_t length) const {
  Result<std::vector<std::uint8_t>> bytes = read(offset, length);
  if (!bytes) return bytes.error();
  if (header_.internal_compression == kCompressionGzip) {
    bytes = gzip_decompress(*bytes, kMaxDirectoryBytes);
    if (!bytes) return bytes.error();
  }
  return decode_pmtiles_directory(*bytes);
}

Result<std::vector<PmtilesEntry>> PmtilesReader::tile_entries() const {
  std::vector<PmtilesEntry> out;
  for (const PmtilesEntry& e : root_) {
    if (e.run_length > 0) {
      out.push_back(e);
      continue;
    }
    Result<std::vector<PmtilesEntry>> leaf = directory(header_.leaves_offset + e.offset, e.length);
    if (!leaf) return leaf.error();
    for (const PmtilesEntry& l : *leaf) {
      if (l.run_length == 0) return Error{"leaves below leaves are not read", "/directory"};
      out.push_back(l);
    }
  }
  return out;
}

Result<std::optional<std::vector<std::uint8_t>>> PmtilesReader::tile(int z, std::uint64_t x,
                                                                     std::uint64_t y) const {
  using Found = std::optional<std::vector<std::uint8_t>>;
  if (z < 0 || z > 31 || x >> z != 0 || y >> z != 0) return Found();
  const std::uint64_t id = pmtiles_tile_id(z, x, y);
  std::vector<PmtilesEntry> entries = root_;
  for (int depth = 0; depth < 4; ++depth) {
    auto it =
        std::upper_bound(entries.begin(), entries.end(), id,
                         [](std::uint64_t v, const PmtilesEntry& e) { return v < e.tile_id; });
    if (it == entries.begin()) return Found();
    const PmtilesEntry e = *std::prev(it);
    if (e.run_length > 0) {
      if (id >= e.tile_id + e.run_length) return Found();
      Result<std::vector<std::uint8_t>> bytes = read(header_.data_offset + e.offset, e.length);
      if (!bytes) return bytes.error();
      return Found(std::move(bytes).value());
    }
    Result<std::vector<PmtilesEntry>> leaf = directory(header_.leaves_offset + e.offset, e.length);
    if (!leaf) return leaf.error();
    entries = std::move(leaf).value();
  }
  return Error{"directories nest too deep", "/directory"};
}

Result<PackReport> write_pmtiles(const std::string& path, const PackPlan& plan,
                                 const MakeTileFactory& factory, const PackOptions& options) {
  const std::string scratch_path = path + ".partial";
  const bool resuming = std::filesystem::exists(scratch_path);
  const std::string wanted = plan.identity().dump();
  if (std::filesystem::exists(path)) {
    Result<PmtilesReader> existing = PmtilesReader::open(path);
    if (!existing || !existing->metadata().contains("terrain_export")) {
      return Error{path +
                       " exists and is not a pack made by an export: remove it or choose another "
                       "file",
                   "/output"};
    }
    const nlohmann::json& found = existing->metadata()["terrain_export"];
    if (const std::string why = pack::identity_mismatch(found, plan.identity()); !why.empty()) {
      return Error{path + " was made by an export with other parameters (" + why +
                       "): remove it or choose another file",
                   "/output"};
    }
    if (!resuming) {  // finished before: nothing to do
      PackReport report;
      report.tiles = report.resumed = existing->header().addressed_tiles;
      report.unique_contents = existing->header().tile_contents;
      std::error_code ec;
      report.bytes = static_cast<std::uint64_t>(std::filesystem::file_size(path, ec));
      if (options.progress) options.progress({report.tiles, report.tiles, report.tiles, 0.0});
      return report;
    }
  }
  Result<Database> db = Database::open(scratch_path, true);
  if (!db) return db.error();
  if (resuming) {
    Result<Statement> select = db->prepare("SELECT value FROM meta WHERE name = 'terrain_export'");
    if (!select) return Error{scratch_path + " is not an export's scratch file", "/output"};
    const std::string found = select->step() == SQLITE_ROW ? select->column_text(0) : "";
    const std::string why =
        pack::identity_mismatch(nlohmann::json::parse(found, nullptr, false), plan.identity());
    if (!why.empty()) {
      return Error{scratch_path + " holds an interrupted export with other parameters (" + why +
                       "): remove it or choose another file",
                   "/output"};
    }
  } else {
    if (Status s = db->exec("CREATE TABLE meta (name TEXT PRIMARY KEY, value TEXT);"
                            "CREATE TABLE tiles (tile_id INTEGER PRIMARY KEY, data BLOB);");
        !s) {
      return s.error();
    }
    Result<Statement> insert = db->prepare("INSERT INTO meta VALUES ('terrain_export', ?)");
    if (!insert) return insert.error();
    insert->bind(1, wanted);
    if (insert->step() != SQLITE_DONE) return Error{db->message(), "/output"};
  }
  static_cast<void>(db->exec("PRAGMA synchronous = NORMAL"));
  Result<Statement> insert = db->prepare("INSERT OR REPLACE INTO tiles VALUES (?, ?)");
  if (!insert) return insert.error();
  ScratchSink sink(*db, plan.scheme, std::move(insert).value());
  Result<PackReport> report = pack::run_export(sink, plan, factory, options);
  if (!report) return report;
  Result<PmtilesHeader> header = assemble(path, *db, plan);
  if (!header) return header.error();
  report->bytes = header->data_offset + header->data_length;
  report->unique_contents = header->tile_contents;
  db = Error{"closed", ""};  // close the scratch database before removing it
  std::error_code ec;
  std::filesystem::remove(scratch_path, ec);
  std::filesystem::remove(scratch_path + "-journal", ec);
  return report;
}

}  // namespace terrain
