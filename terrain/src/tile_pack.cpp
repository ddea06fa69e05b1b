// Pack plans (zoom ranges from a bbox, checked before any work), the export loop shared by the
// MBTiles and PMTiles writers, and the SQLite wrapper they both use.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <numbers>
#include <thread>
#include <unordered_set>

#include "pack_store.hpp"

namespace terrain {

namespace {

constexpr double kPi = std::numbers::pi;

// Fraction of the world's height from its north edge at latitude `lat` (Web Mercator).
double mercator_fraction_from_north(double lat) {
  const double phi = lat * kPi / 180.0;
  return (1.0 - std::asinh(std::tan(phi)) / kPi) / 2.0;
}

double mercator_latitude(double fraction_from_north) {
  return std::atan(std::sinh(kPi * (1.0 - 2.0 * fraction_from_north))) * 180.0 / kPi;
}

std::string number_text(double v) {
  std::string s = nlohmann::json(v).dump();
  return s;
}

}  // namespace

std::uint64_t ZoomRange::count() const {
  if (range.max_x < range.min_x || range.max_y < range.min_y) return 0;
  return static_cast<std::uint64_t>(range.max_x - range.min_x + 1) *
         static_cast<std::uint64_t>(range.max_y - range.min_y + 1);
}

Result<PackFormat> pack_format_for_path(std::string_view path) {
  if (path.ends_with(".mbtiles")) return PackFormat::mbtiles;
  if (path.ends_with(".pmtiles")) return PackFormat::pmtiles;
  return Error{"the output must end in .mbtiles or .pmtiles", "/output"};
}

Result<std::vector<ZoomRange>> plan_zoom_ranges(const PackArea& area) {
  if (area.scheme != TileScheme::webmercator && area.scheme != TileScheme::geographic) {
    return Error{"packs hold webmercator or geographic tiles", "/scheme"};
  }
  if (area.min_zoom < 0 || area.max_zoom < 0) {
    return Error{"zoom levels start at 0", "/zoom"};
  }
  if (area.min_zoom > area.max_zoom) {
    return Error{"the first zoom (" + std::to_string(area.min_zoom) + ") is above the last (" +
                     std::to_string(area.max_zoom) + ")",
                 "/zoom"};
  }
  const int deepest = std::min(area.max_useful_zoom, max_zoom(area.scheme));
  if (area.max_zoom > deepest) {
    return Error{"zoom " + std::to_string(area.max_zoom) + " is beyond the deepest useful zoom, " +
                     std::to_string(deepest),
                 "/zoom"};
  }
  if (area.bbox) {
    const TileBounds& b = *area.bbox;
    const double lat_limit =
        area.scheme == TileScheme::webmercator ? kWebMercatorMaxLatitude : 90.0;
    for (double v : {b.west, b.south, b.east, b.north}) {
      if (!std::isfinite(v)) return Error{"the bbox needs finite numbers", "/bbox"};
    }
    if (b.west < -180.0 || b.east > 180.0) {
      return Error{"longitudes must lie in [-180, 180]", "/bbox"};
    }
    if (b.south < -lat_limit || b.north > lat_limit) {
      return Error{"latitudes must lie in [-" + number_text(lat_limit) + ", " +
                       number_text(lat_limit) + "] for the " +
                       std::string(scheme_name(area.scheme)) + " scheme",
                   "/bbox"};
    }
    if (!(b.west < b.east)) return Error{"west must be less than east", "/bbox"};
    if (!(b.south < b.north)) return Error{"south must be less than north", "/bbox"};
  }
  std::vector<ZoomRange> zooms;
  std::uint64_t total = 0;
  for (int z = area.min_zoom; z <= area.max_zoom; ++z) {
    const double columns = static_cast<double>(columns_at(area.scheme, z));
    const double rows = static_cast<double>(rows_at(area.scheme, z));
    TileRange range{0, 0, columns_at(area.scheme, z) - 1, rows_at(area.scheme, z) - 1};
    if (area.bbox) {
      const TileBounds& b = *area.bbox;
      const double fx0 = (b.west + 180.0) / 360.0 * columns;
      const double fx1 = (b.east + 180.0) / 360.0 * columns;
      // Row fractions in the scheme's own numbering: from the north (XYZ) or the south (TMS).
      double fy0 = 0, fy1 = 0;
      if (area.scheme == TileScheme::webmercator) {
        fy0 = mercator_fraction_from_north(b.north) * rows;
        fy1 = mercator_fraction_from_north(b.south) * rows;
      } else {
        fy0 = (b.south + 90.0) / 180.0 * rows;
        fy1 = (b.north + 90.0) / 180.0 * rows;
      }
      auto first = [](double f, double n) {
        return static_cast<std::int64_t>(std::clamp(std::floor(f), 0.0, n - 1));
      };
      auto last = [](double f, double n) {
        return static_cast<std::int64_t>(std::clamp(std::ceil(f) - 1.0, 0.0, n - 1));
      };
      range = {first(fx0, columns), first(fy0, rows), last(fx1, columns), last(fy1, rows)};
      range.max_x = std::max(range.max_x, range.min_x);
      range.max_y = std::max(range.max_y, range.min_y);
    } else if (area.default_range) {
      range = area.default_range(z);
    }
    const ZoomRange zoom{z, range};
    total += zoom.count();
    if (total > area.max_tiles) {
      return Error{"the export would hold more than " + std::to_string(area.max_tiles) +
                       " tiles (at least " + std::to_string(total) + " up to zoom " +
                       std::to_string(z) + "): narrow --zoom or --bbox, or raise --max-tiles",
                   "/max_tiles"};
    }
    if (zoom.count() > 0) zooms.push_back(zoom);
  }
  if (total == 0) return Error{"the area holds no tiles", "/bbox"};
  return zooms;
}

TileBounds range_bounds_degrees(TileScheme scheme, int z, const TileRange& range) {
  const double columns = static_cast<double>(columns_at(scheme, z));
  const double rows = static_cast<double>(rows_at(scheme, z));
  TileBounds b;
  b.west = -180.0 + 360.0 * static_cast<double>(range.min_x) / columns;
  b.east = -180.0 + 360.0 * static_cast<double>(range.max_x + 1) / columns;
  if (scheme == TileScheme::webmercator) {
    b.north = mercator_latitude(static_cast<double>(range.min_y) / rows);
    b.south = mercator_latitude(static_cast<double>(range.max_y + 1) / rows);
  } else {
    b.south = -90.0 + 180.0 * static_cast<double>(range.min_y) / rows;
    b.north = -90.0 + 180.0 * static_cast<double>(range.max_y + 1) / rows;
  }
  return b;
}

std::uint64_t PackPlan::tile_count() const {
  std::uint64_t n = 0;
  for (const ZoomRange& zoom : zooms) n += zoom.count();
  return n;
}

nlohmann::json PackPlan::identity() const {
  nlohmann::json ranges = nlohmann::json::array();
  for (const ZoomRange& zoom : zooms) {
    ranges.push_back(
        {zoom.z, zoom.range.min_x, zoom.range.min_y, zoom.range.max_x, zoom.range.max_y});
  }
  return {{"source", source_id},
          {"format", pack::format_label(format)},
          {"scheme", std::string(scheme_name(scheme))},
          {"ranges", ranges},
          {"version", 1}};
}

Result<PackReport> write_mbtiles(const std::string& path, const PackPlan& plan,
                                 const MakeTileFactory& factory, const PackOptions& options);
Result<PackReport> write_pmtiles(const std::string& path, const PackPlan& plan,
                                 const MakeTileFactory& factory, const PackOptions& options);

Result<PackReport> write_pack(const std::string& path, const PackPlan& plan,
                              const MakeTileFactory& factory, const PackOptions& options) {
  Result<PackFormat> format = pack_format_for_path(path);
  if (!format) return format.error();
  if (plan.format != TileFormat::terrain_rgb && plan.format != TileFormat::terrarium &&
      plan.format != TileFormat::quantized_mesh && !is_color(plan.format)) {
    return Error{"packs hold terrain-rgb, terrarium, colour (PNG or JPEG) or quantized-mesh tiles",
                 "/format"};
  }
  if (plan.tile_count() == 0) return Error{"the plan holds no tiles", "/zoom"};
  return *format == PackFormat::mbtiles ? write_mbtiles(path, plan, factory, options)
                                        : write_pmtiles(path, plan, factory, options);
}

namespace pack {

std::string format_label(TileFormat format) {
  const TileFormatInfo& info = format_info(format);
  if (info.encoding.empty()) return "quantized-mesh";
  // Colour comes as PNG or JPEG: a pack of one is not resumed as the other.
  if (is_color(format)) return std::string(info.encoding) + "-" + std::string(info.extension);
  return std::string(info.encoding);
}

std::string image_format(TileFormat format) {
  return std::string(format_info(format).extension);
}

std::string identity_mismatch(const nlohmann::json& found, const nlohmann::json& wanted) {
  if (found == wanted) return "";
  std::string out;
  for (const auto& [key, value] : wanted.items()) {
    if (!found.is_object() || !found.contains(key) || found[key] != value) {
      if (!out.empty()) out += ", ";
      const std::string was = found.is_object() && found.contains(key) ? found[key].dump() : "none";
      out += key + " " + was + " (now " + value.dump() + ")";
    }
  }
  return out.empty() ? "its export parameters differ" : out;
}

// ---- SQLite ----

Statement::Statement(sqlite3* db, const std::string& sql) {
  if (sqlite3_prepare_v2(db, sql.c_str(), -1, &statement_, nullptr) != SQLITE_OK) {
    sqlite3_finalize(statement_);
    statement_ = nullptr;
  }
}
Statement::Statement(Statement&& other) noexcept : statement_(other.statement_) {
  other.statement_ = nullptr;
}
Statement& Statement::operator=(Statement&& other) noexcept {
  std::swap(statement_, other.statement_);
  return *this;
}
Statement::~Statement() {
  sqlite3_finalize(statement_);
}
void Statement::bind(int index, std::int64_t value) {
  sqlite3_bind_int64(statement_, index, value);
}
void Statement::bind(int index, const std::string& text) {
  sqlite3_bind_text(statement_, index, text.data(), static_cast<int>(text.size()),
                    SQLITE_TRANSIENT);
}
void Statement::bind(int index, std::span<const std::uint8_t> blob) {
  sqlite3_bind_blob(statement_, index, blob.data(), static_cast<int>(blob.size()),
                    SQLITE_TRANSIENT);
}
int Statement::step() {
  return sqlite3_step(statement_);
}
void Statement::reset() {
  sqlite3_reset(statement_);
  sqlite3_clear_bindings(statement_);
}
std::int64_t Statement::column_int(int index) const {
  return sqlite3_column_int64(statement_, index);
}
std::string Statement::column_text(int index) const {
  const unsigned char* text = sqlite3_column_text(statement_, index);
  return text == nullptr
             ? std::string()
             : std::string(reinterpret_cast<const char*>(text),
                           static_cast<std::size_t>(sqlite3_column_bytes(statement_, index)));
}
std::vector<std::uint8_t> Statement::column_blob(int index) const {
  const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(statement_, index));
  const auto size = static_cast<std::size_t>(sqlite3_column_bytes(statement_, index));
  return data == nullptr ? std::vector<std::uint8_t>()
                         : std::vector<std::uint8_t>(data, data + size);
}

Result<Database> Database::open(const std::string& path, bool create) {
  Database database;
  const int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0);
  if (sqlite3_open_v2(path.c_str(), &database.db_, flags, nullptr) != SQLITE_OK) {
    std::string message = database.db_ != nullptr ? sqlite3_errmsg(database.db_) : "out of memory";
    return Error{"cannot open " + path + ": " + message, "/output"};
  }
  sqlite3_busy_timeout(database.db_, 5000);
  // A file that is not a database fails here, before anything is written to it.
  if (Status read = database.exec("SELECT count(*) FROM sqlite_master"); !read) {
    return Error{path + " is not an SQLite database: " + read.error().message, "/output"};
  }
  return database;
}
Database::Database(Database&& other) noexcept : db_(other.db_) {
  other.db_ = nullptr;
}
Database& Database::operator=(Database&& other) noexcept {
  std::swap(db_, other.db_);
  return *this;
}
Database::~Database() {
  sqlite3_close(db_);
}
Status Database::exec(const std::string& sql) {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
    std::string message = error != nullptr ? error : sqlite3_errmsg(db_);
    sqlite3_free(error);
    return Error{message, "/output"};
  }
  return Ok{};
}
Result<Statement> Database::prepare(const std::string& sql) {
  Statement statement(db_, sql);
  if (!statement.ok()) return Error{message(), "/output"};
  return statement;
}
std::string Database::message() const {
  return sqlite3_errmsg(db_);
}
bool Database::has_table(const std::string& name) {
  Statement s(db_, "SELECT 1 FROM sqlite_master WHERE type IN ('table','view') AND name = ?");
  s.bind(1, name);
  return s.step() == SQLITE_ROW;
}

// ---- the export loop ----

namespace {

std::uint64_t address_key(const TileAddress& a) {
  return (static_cast<std::uint64_t>(a.z) << 58) | (static_cast<std::uint64_t>(a.x) << 29) |
         static_cast<std::uint64_t>(a.y);
}

struct MadeTile {
  TileAddress address;
  std::vector<std::uint8_t> bytes;
};

// Made tiles on their way from the workers to the writer; bounded so that workers wait for a
// slow disk instead of piling tiles up in memory.
struct Queue {
  std::mutex mutex;
  std::condition_variable changed;
  std::deque<MadeTile> tiles;
  std::size_t capacity = 64;
  std::size_t workers_left = 0;
  bool stop = false;
  std::optional<Error> error;
};

}  // namespace

Result<PackReport> run_export(TileSink& sink, const PackPlan& plan, const MakeTileFactory& factory,
                              const PackOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  auto seconds = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  Result<std::vector<TileAddress>> stored = sink.stored();
  if (!stored) return stored.error();
  std::unordered_set<std::uint64_t> have;
  have.reserve(stored->size());
  for (const TileAddress& a : *stored) have.insert(address_key(a));
  std::vector<TileAddress> pending;
  PackReport report;
  report.tiles = plan.tile_count();
  for (const ZoomRange& zoom : plan.zooms) {
    for (std::int64_t y = zoom.range.min_y; y <= zoom.range.max_y; ++y) {
      for (std::int64_t x = zoom.range.min_x; x <= zoom.range.max_x; ++x) {
        const TileAddress a{zoom.z, x, y};
        if (have.contains(address_key(a))) {
          ++report.resumed;
        } else {
          pending.push_back(a);
        }
      }
    }
  }
  PackProgress progress{report.resumed, report.tiles, report.resumed, 0.0};
  auto last_report = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  auto tell = [&](bool force) {
    if (!options.progress) return;
    const auto now = std::chrono::steady_clock::now();
    if (!force && now - last_report < std::chrono::milliseconds(250)) return;
    last_report = now;
    progress.seconds = seconds();
    options.progress(progress);
  };
  tell(true);
  if (pending.empty()) {
    report.seconds = seconds();
    return report;
  }

  const int threads = std::clamp(options.threads, 1, 256);
  Queue queue;
  queue.capacity = static_cast<std::size_t>(threads) * 16;
  queue.workers_left = static_cast<std::size_t>(threads);
  std::atomic<std::size_t> next{0};
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&] {
      MakeTile make = factory();
      for (;;) {
        const std::size_t i = next.fetch_add(1);
        if (i >= pending.size()) break;
        {
          std::lock_guard lock(queue.mutex);
          if (queue.stop) break;
        }
        Result<std::vector<std::uint8_t>> bytes = make(pending[i]);
        std::unique_lock lock(queue.mutex);
        if (!bytes) {
          const TileAddress& a = pending[i];
          if (!queue.error) {
            queue.error = Error{"tile " + std::to_string(a.z) + "/" + std::to_string(a.x) + "/" +
                                    std::to_string(a.y) + ": " + bytes.error().message,
                                bytes.error().pointer};
          }
          queue.stop = true;
          queue.changed.notify_all();
          break;
        }
        queue.changed.wait(lock, [&] { return queue.stop || queue.tiles.size() < queue.capacity; });
        if (queue.stop) break;
        queue.tiles.push_back({pending[i], std::move(bytes).value()});
        queue.changed.notify_all();
      }
      std::lock_guard lock(queue.mutex);
      --queue.workers_left;
      queue.changed.notify_all();
    });
  }
  auto finish = [&](std::optional<Error> error) -> Result<PackReport> {
    {
      std::lock_guard lock(queue.mutex);
      queue.stop = true;
      queue.changed.notify_all();
    }
    for (std::thread& w : workers) w.join();
    if (!error) {
      std::lock_guard lock(queue.mutex);
      error = queue.error;
    }
    if (error) return *error;
    report.seconds = seconds();
    return report;
  };

  std::uint64_t in_transaction = 0;
  auto last_commit = std::chrono::steady_clock::now();
  if (Status s = sink.begin(); !s) return finish(s.error());
  for (;;) {
    std::deque<MadeTile> batch;
    bool done = false;
    {
      std::unique_lock lock(queue.mutex);
      queue.changed.wait_for(lock, std::chrono::milliseconds(250), [&] {
        return !queue.tiles.empty() || queue.workers_left == 0 || queue.error.has_value();
      });
      batch.swap(queue.tiles);
      done = queue.workers_left == 0 || queue.error.has_value();
      queue.changed.notify_all();
    }
    for (MadeTile& tile : batch) {
      if (Status s = sink.put(tile.address, tile.bytes); !s) return finish(s.error());
      ++in_transaction;
      ++report.made;
      ++progress.done;
      const bool due = in_transaction >= std::max<std::uint64_t>(options.commit_every, 1) ||
                       std::chrono::steady_clock::now() - last_commit > options.commit_interval;
      if (due) {
        if (Status s = sink.commit(); !s) return finish(s.error());
        in_transaction = 0;
      }
      // Checked per tile, not per batch: a batch may hold tiles past the stop.
      if (options.stop_after > 0 && report.made >= options.stop_after) {
        if (in_transaction > 0) sink.abandon();
        return finish(Error{"stopped after " + std::to_string(report.made) + " tiles" +
                                (in_transaction > 0 ? ", the last ones uncommitted" : "") +
                                " (PackOptions::stop_after)",
                            ""});
      }
      if (due) {
        if (Status s = sink.begin(); !s) return finish(s.error());
        last_commit = std::chrono::steady_clock::now();
      }
    }
    tell(false);
    if (done && batch.empty()) break;
  }
  // Whatever was made before a tile failed is kept for the next run.
  if (Status s = sink.commit(); !s) return finish(s.error());
  Result<PackReport> result = finish(std::nullopt);
  if (result) tell(true);
  return result;
}

}  // namespace pack
}  // namespace terrain
