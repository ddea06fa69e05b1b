// MBTiles 1.3 packs: the SQLite schema of the spec (metadata and tiles tables), TMS rows, and
// the export's identity in a metadata row so that a rerun resumes or refuses.
#include <cmath>
#include <filesystem>

#include "pack_store.hpp"

namespace terrain {

namespace {

using pack::Database;
using pack::Statement;

// MBTiles rows count from the south (TMS); Web Mercator XYZ rows from the north. Geographic
// rows already count from the south.
std::int64_t tms_row(TileScheme scheme, const TileAddress& a) {
  return scheme == TileScheme::webmercator ? rows_at(scheme, a.z) - 1 - a.y : a.y;
}

std::string degrees(double v) {
  // Seven decimals (about 1 cm), as PMTiles stores them; no exponent notation.
  char text[64];
  std::snprintf(text, sizeof text, "%.7f", v);
  return text;
}

// The rows of the metadata table (MBTiles 1.3 §metadata, plus ours).
std::vector<std::pair<std::string, std::string>> metadata_rows(const PackPlan& plan,
                                                               bool complete) {
  const bool mesh = plan.format == TileFormat::quantized_mesh;
  const TileBounds& b = plan.bounds;
  const int min_zoom = plan.zooms.front().z, max_zoom = plan.zooms.back().z;
  std::vector<std::pair<std::string, std::string>> rows{
      {"name", plan.name},
      {"format", mesh ? "application/vnd.quantized-mesh" : pack::image_format(plan.format)},
      {"bounds",
       degrees(b.west) + "," + degrees(b.south) + "," + degrees(b.east) + "," + degrees(b.north)},
      {"center", degrees((b.west + b.east) / 2) + "," + degrees((b.south + b.north) / 2) + "," +
                     std::to_string(min_zoom)},
      {"minzoom", std::to_string(min_zoom)},
      {"maxzoom", std::to_string(max_zoom)},
      {"type", "baselayer"},
      {"version", "1"},
      {"description", plan.description},
      {"tile_scheme", std::string(scheme_name(plan.scheme))},
      {"crs", plan.scheme == TileScheme::webmercator ? "EPSG:3857" : "EPSG:4326"},
      {"encoding", pack::format_label(plan.format)},
      {"terrain_export", plan.identity().dump()},
      {"terrain_export_state", complete ? "complete" : "incomplete"},
  };
  if (mesh) rows.emplace_back("content_encoding", "gzip");
  for (const auto& [key, value] : plan.extra.items()) {
    rows.emplace_back(key, value.is_string() ? value.get<std::string>() : value.dump());
  }
  return rows;
}

Status write_metadata(Database& db, const PackPlan& plan, bool complete) {
  Result<Statement> insert =
      db.prepare("INSERT OR REPLACE INTO metadata (name, value) VALUES (?, ?)");
  if (!insert) return insert.error();
  if (Status s = db.exec("BEGIN"); !s) return s;
  for (const auto& [name, value] : metadata_rows(plan, complete)) {
    insert->reset();
    insert->bind(1, name);
    insert->bind(2, value);
    if (insert->step() != SQLITE_DONE) return Error{db.message(), "/output"};
  }
  return db.exec("COMMIT");
}

class MbtilesSink final : public pack::SqliteTileSink {
 public:
  using SqliteTileSink::SqliteTileSink;

  Result<std::vector<TileAddress>> stored() override {
    Result<Statement> select = db_.prepare("SELECT zoom_level, tile_column, tile_row FROM tiles");
    if (!select) return select.error();
    std::vector<TileAddress> out;
    while (select->step() == SQLITE_ROW) {
      TileAddress a{static_cast<int>(select->column_int(0)), select->column_int(1),
                    select->column_int(2)};
      a.y = tms_row(scheme_, a);  // the flip is its own inverse
      out.push_back(a);
    }
    return out;
  }
  Status put(const TileAddress& a, std::span<const std::uint8_t> bytes) override {
    insert_.reset();
    insert_.bind(1, std::int64_t{a.z});
    insert_.bind(2, a.x);
    insert_.bind(3, tms_row(scheme_, a));
    insert_.bind(4, bytes);
    if (insert_.step() != SQLITE_DONE) return Error{db_.message(), "/output"};
    return Ok{};
  }
};

}  // namespace

Result<PackReport> write_mbtiles(const std::string& path, const PackPlan& plan,
                                 const MakeTileFactory& factory, const PackOptions& options) {
  const bool existed = std::filesystem::exists(path);
  Result<Database> db = Database::open(path, true);
  if (!db) return db.error();
  if (existed) {
    // Only a pack of the same export is resumed; anything else is left untouched.
    Result<nlohmann::json> metadata = read_mbtiles_metadata(path);
    if (!metadata || !metadata->contains("terrain_export")) {
      return Error{path +
                       " exists and is not a pack made by an export: remove it or choose another "
                       "file",
                   "/output"};
    }
    const nlohmann::json found =
        nlohmann::json::parse((*metadata)["terrain_export"].get<std::string>(), nullptr, false);
    if (const std::string why = pack::identity_mismatch(found, plan.identity()); !why.empty()) {
      return Error{path + " was made by an export with other parameters (" + why +
                       "): remove it or choose another file",
                   "/output"};
    }
  } else {
    if (Status s = db->exec(
            "CREATE TABLE metadata (name TEXT, value TEXT);"
            "CREATE UNIQUE INDEX metadata_name ON metadata (name);"
            "CREATE TABLE tiles (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER,"
            " tile_data BLOB);"
            "CREATE UNIQUE INDEX tile_index ON tiles (zoom_level, tile_column, tile_row);");
        !s) {
      return s.error();
    }
    if (Status s = write_metadata(*db, plan, false); !s) return s.error();
  }
  static_cast<void>(db->exec("PRAGMA synchronous = NORMAL"));
  Result<Statement> insert = db->prepare(
      "INSERT OR REPLACE INTO tiles (zoom_level, tile_column, tile_row, tile_data) "
      "VALUES (?, ?, ?, ?)");
  if (!insert) return insert.error();
  MbtilesSink sink(*db, plan.scheme, std::move(insert).value());
  Result<PackReport> report = pack::run_export(sink, plan, factory, options);
  if (!report) return report;
  if (Status s = write_metadata(*db, plan, true); !s) return s.error();
  std::error_code ec;
  report->bytes = static_cast<std::uint64_t>(std::filesystem::file_size(path, ec));
  return report;
}

Result<std::optional<std::vector<std::uint8_t>>> read_mbtiles_tile(const std::string& path, int z,
                                                                   std::int64_t column,
                                                                   std::int64_t row) {
  Result<Database> db = Database::open(path, false);
  if (!db) return db.error();
  Result<Statement> select = db->prepare(
      "SELECT tile_data FROM tiles WHERE zoom_level = ? AND tile_column = ? AND tile_row = ?");
  if (!select) return select.error();
  select->bind(1, std::int64_t{z});
  select->bind(2, column);
  select->bind(3, row);
  if (select->step() != SQLITE_ROW) return std::optional<std::vector<std::uint8_t>>();
  return std::optional<std::vector<std::uint8_t>>(select->column_blob(0));
}

Result<nlohmann::json> read_mbtiles_metadata(const std::string& path) {
  Result<Database> db = Database::open(path, false);
  if (!db) return db.error();
  if (!db->has_table("metadata")) return Error{path + " has no metadata table", "/output"};
  Result<Statement> select = db->prepare("SELECT name, value FROM metadata");
  if (!select) return select.error();
  nlohmann::json out = nlohmann::json::object();
  while (select->step() == SQLITE_ROW) out[select->column_text(0)] = select->column_text(1);
  return out;
}

}  // namespace terrain
