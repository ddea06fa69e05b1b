// What the pack writers share (internal): a thin SQLite wrapper that reports errors as Results,
// and the export loop that makes the missing tiles of a plan on worker threads and hands them
// to a TileSink (the MBTiles database itself, or the PMTiles scratch database) in transactions.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "terrain/tile_pack.hpp"

namespace terrain::pack {

/// A prepared statement; reset before each use by the owner.
class Statement {
 public:
  Statement() = default;
  Statement(sqlite3* db, const std::string& sql);
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  Statement(Statement&& other) noexcept;
  Statement& operator=(Statement&& other) noexcept;
  ~Statement();

  bool ok() const { return statement_ != nullptr; }
  void bind(int index, std::int64_t value);
  void bind(int index, const std::string& text);
  void bind(int index, std::span<const std::uint8_t> blob);
  /// SQLITE_ROW, SQLITE_DONE or an error code.
  int step();
  void reset();
  std::int64_t column_int(int index) const;
  std::string column_text(int index) const;
  std::vector<std::uint8_t> column_blob(int index) const;

 private:
  sqlite3_stmt* statement_ = nullptr;
};

/// An open database.
class Database {
 public:
  /// Opens (create: or creates) the file; the error names "/output".
  static Result<Database> open(const std::string& path, bool create);
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;
  Database(Database&& other) noexcept;
  Database& operator=(Database&& other) noexcept;
  ~Database();

  Status exec(const std::string& sql);
  /// The statement, or an error naming SQLite's message.
  Result<Statement> prepare(const std::string& sql);
  std::string message() const;
  sqlite3* handle() const { return db_; }
  /// Whether a table of that name exists.
  bool has_table(const std::string& name);

 private:
  Database() = default;
  sqlite3* db_ = nullptr;
};

/// Where made tiles go.
class TileSink {
 public:
  virtual ~TileSink() = default;
  /// Addresses (scheme numbering) of the tiles an earlier run committed.
  virtual Result<std::vector<TileAddress>> stored() = 0;
  virtual Status begin() = 0;
  virtual Status put(const TileAddress& address, std::span<const std::uint8_t> bytes) = 0;
  virtual Status commit() = 0;
  /// Drops the open transaction, as a kill would (PackOptions::stop_after).
  virtual void abandon() = 0;
};

/// A sink whose tiles go to one SQLite table through a prepared insert, one transaction per
/// batch: the packs differ only in how they number and read back tiles.
class SqliteTileSink : public TileSink {
 public:
  SqliteTileSink(Database& db, TileScheme scheme, Statement insert)
      : db_(db), scheme_(scheme), insert_(std::move(insert)) {}
  Status begin() final { return db_.exec("BEGIN"); }
  Status commit() final { return db_.exec("COMMIT"); }
  void abandon() final { static_cast<void>(db_.exec("ROLLBACK")); }

 protected:
  Database& db_;
  TileScheme scheme_;
  Statement insert_;
};

/// Makes every tile of the plan that the sink does not hold and puts it there. Fills tiles,
/// made, resumed and seconds of the report.
Result<PackReport> run_export(TileSink& sink, const PackPlan& plan, const MakeTileFactory& factory,
                              const PackOptions& options);

/// "terrain-rgb", "terrarium", "color-png", "color-jpg" or "quantized-mesh".
std::string format_label(TileFormat format);
// The image format of a raster pack's tiles as MBTiles and PMTiles metadata name it: "png" or
// "jpg".
std::string image_format(TileFormat format);
/// Why `found` (the identity stored in a file) is not `wanted`, naming the first fields that
/// differ; empty when they are equal.
std::string identity_mismatch(const nlohmann::json& found, const nlohmann::json& wanted);

}  // namespace terrain::pack
