// Offline tile packs: a zoom range and a bounding box of one scheme's tiles written to one file,
// MBTiles 1.3 (SQLite) or PMTiles v3, with the bytes a tile callback makes (the server's bytes:
// the `terrain export` and `planet export` commands pass ProductMaker / PlanetTiles). Exports
// resume after an interruption, refuse a file made with other parameters, run on several
// threads and write the same PMTiles bytes whatever the thread count (docs/packs.md).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/tile.hpp"
#include "terrain/tile_products.hpp"
#include "terrain/tile_source.hpp"

namespace terrain {

enum class PackFormat { mbtiles, pmtiles };

/// The pack format named by a path's extension (.mbtiles or .pmtiles); the error names "/output".
Result<PackFormat> pack_format_for_path(std::string_view path);

/// One zoom level's tiles of a pack (inclusive ranges, in the scheme's own numbering).
struct ZoomRange {
  int z = 0;
  TileRange range;
  std::uint64_t count() const;
};

/// What the tiles of a pack are chosen by. Bad values are refused by plan_zoom_ranges before
/// any work; errors name the option ("/zoom", "/bbox", "/max_tiles").
struct PackArea {
  TileScheme scheme = TileScheme::webmercator;  ///< webmercator or geographic
  int min_zoom = 0;
  int max_zoom = 0;
  int max_useful_zoom = 0;  ///< zooms above it are refused (the source's finest useful level)
  /// west, south, east, north in degrees; none: `default_range` at each zoom.
  std::optional<TileBounds> bbox;
  /// The tiles of a zoom when no bbox is given (a scene's extent); null: every tile.
  std::function<TileRange(int z)> default_range;
  std::uint64_t max_tiles = 1'000'000;  ///< a bound on the count, against typos
};

/// The largest latitude of Web Mercator's square world (degrees).
inline constexpr double kWebMercatorMaxLatitude = 85.0511287798066;

/// The tiles of each zoom of `area`, checked: zooms in order and within 0..max_useful_zoom, the
/// bbox inside the scheme's world with west < east and south < north, the count ≤ max_tiles.
Result<std::vector<ZoomRange>> plan_zoom_ranges(const PackArea& area);

/// The footprint of a tile range in degrees (west, south, east, north).
TileBounds range_bounds_degrees(TileScheme scheme, int z, const TileRange& range);

/// What to write: the tiles, what they are, and the metadata a reader needs.
struct PackPlan {
  TileScheme scheme = TileScheme::webmercator;
  TileFormat format = TileFormat::terrain_rgb;  ///< terrain_rgb, terrarium, color_png,
                                                ///< color_jpeg or quantized_mesh
  std::vector<ZoomRange> zooms;                 ///< ascending z
  TileBounds bounds;                            ///< degrees: the bbox, or the tiles' footprint
  std::string name;                             ///< the MBTiles / PMTiles "name"
  std::string description;
  std::string source_id;  ///< what the tiles are made from (scene hash, planet id)
  /// More metadata (MBTiles rows, keys of the PMTiles JSON), e.g. "layer_json" for meshes.
  nlohmann::json extra = nlohmann::json::object();

  std::uint64_t tile_count() const;
  /// What a resumed export must share with the one that started the file: source, format,
  /// scheme and tile ranges (stored in the pack as "terrain_export").
  nlohmann::json identity() const;
};

/// Makes the bytes of one tile (as served). One per thread: it need not be thread-safe.
using MakeTile = std::function<Result<std::vector<std::uint8_t>>(const TileAddress&)>;
/// Called once on each worker thread to make that thread's MakeTile.
using MakeTileFactory = std::function<MakeTile()>;

/// Where an export stands, for progress bars.
struct PackProgress {
  std::uint64_t done = 0;     ///< tiles in the pack (resumed ones included)
  std::uint64_t total = 0;    ///< tiles of the plan
  std::uint64_t resumed = 0;  ///< tiles found from an earlier run
  double seconds = 0.0;       ///< since this run started
};

struct PackOptions {
  int threads = 1;
  std::uint64_t commit_every = 256;  ///< tiles per transaction (a kill loses at most these)
  /// A transaction also commits once this long has passed since the last commit.
  std::chrono::milliseconds commit_interval{5000};
  /// Called on the calling thread at most about four times a second, and once at the end.
  std::function<void(const PackProgress&)> progress;
  /// Testing: stop as a kill would, after this many tiles of this run are committed (0: never).
  std::uint64_t stop_after = 0;
};

struct PackReport {
  std::uint64_t tiles = 0;            ///< tiles in the pack
  std::uint64_t made = 0;             ///< made by this run
  std::uint64_t resumed = 0;          ///< found from an earlier run
  std::uint64_t unique_contents = 0;  ///< PMTiles: distinct tile contents stored
  std::uint64_t bytes = 0;            ///< size of the file
  double seconds = 0.0;
};

/// Writes (or resumes) the pack at `path`, its format from the extension. Tiles already
/// committed by an earlier run with the same plan identity are kept; a file made otherwise is
/// refused, naming what differs. PMTiles are assembled from a scratch SQLite file
/// (`path` + ".partial") once every tile is made, sorted by tile id, so their bytes depend on
/// the plan and the tiles only. A tile error stops the export (committed tiles stay).
Result<PackReport> write_pack(const std::string& path, const PackPlan& plan,
                              const MakeTileFactory& factory, const PackOptions& options = {});

// ---- PMTiles v3 details, public for readers and tests ----

/// Where a tile of `scheme` is stored in a PMTiles archive: Web Mercator tiles at their own
/// z/x/y; geographic tiles (2^(z+1) × 2^z, TMS rows) at z+1/x/y, inside the square of z+1.
TileAddress pmtiles_address(TileScheme scheme, const TileAddress& address);

/// The tile id of z/x/y: the tiles of lower zooms, then the position along zoom z's Hilbert
/// curve. z ≤ 31 and x, y < 2^z.
std::uint64_t pmtiles_tile_id(int z, std::uint64_t x, std::uint64_t y);
/// The z/x/y of a tile id.
TileAddress pmtiles_tile_address(std::uint64_t tile_id);

struct PmtilesHeader {
  std::uint64_t root_offset = 0, root_length = 0;
  std::uint64_t metadata_offset = 0, metadata_length = 0;
  std::uint64_t leaves_offset = 0, leaves_length = 0;
  std::uint64_t data_offset = 0, data_length = 0;
  std::uint64_t addressed_tiles = 0, tile_entries = 0, tile_contents = 0;
  bool clustered = false;
  std::uint8_t internal_compression = 0;  ///< 1 none, 2 gzip
  std::uint8_t tile_compression = 0;
  std::uint8_t tile_type = 0;  ///< 0 unknown, 2 png, 3 jpeg
  int min_zoom = 0, max_zoom = 0, center_zoom = 0;
  double min_lon = 0, min_lat = 0, max_lon = 0, max_lat = 0, center_lon = 0, center_lat = 0;
};

/// A directory entry (run_length 0: a leaf directory).
struct PmtilesEntry {
  std::uint64_t tile_id = 0;
  std::uint64_t offset = 0;
  std::uint32_t length = 0;
  std::uint32_t run_length = 0;
};

/// The 127 header bytes, and back (the error names the field).
std::vector<std::uint8_t> encode_pmtiles_header(const PmtilesHeader& header);
Result<PmtilesHeader> decode_pmtiles_header(std::span<const std::uint8_t> bytes);
/// A directory's bytes before internal compression, and back.
std::vector<std::uint8_t> encode_pmtiles_directory(const std::vector<PmtilesEntry>& entries);
Result<std::vector<PmtilesEntry>> decode_pmtiles_directory(std::span<const std::uint8_t> bytes);

/// Reads a PMTiles v3 file (gzip or no internal compression): header, metadata and tiles.
class PmtilesReader {
 public:
  static Result<PmtilesReader> open(const std::string& path);

  const PmtilesHeader& header() const { return header_; }
  const nlohmann::json& metadata() const { return metadata_; }
  /// The root directory as stored (leaf entries included).
  const std::vector<PmtilesEntry>& root() const { return root_; }
  /// Every tile entry, leaves resolved, in tile id order.
  Result<std::vector<PmtilesEntry>> tile_entries() const;
  /// The stored bytes of the tile at PMTiles z/x/y, or nothing when the archive has none.
  Result<std::optional<std::vector<std::uint8_t>>> tile(int z, std::uint64_t x,
                                                        std::uint64_t y) const;

 private:
  Result<std::vector<std::uint8_t>> read(std::uint64_t offset, std::uint64_t length) const;
  Result<std::vector<PmtilesEntry>> directory(std::uint64_t offset, std::uint64_t length) const;
  std::string path_;
  PmtilesHeader header_;
  nlohmann::json metadata_;
  std::vector<PmtilesEntry> root_;
};

/// Reads tiles of an MBTiles file (for tests and tools): the stored bytes at z / column / TMS
/// row, or nothing; and the metadata rows.
Result<std::optional<std::vector<std::uint8_t>>> read_mbtiles_tile(const std::string& path, int z,
                                                                   std::int64_t column,
                                                                   std::int64_t tms_row);
Result<nlohmann::json> read_mbtiles_metadata(const std::string& path);

}  // namespace terrain
