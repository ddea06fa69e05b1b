// The embedded store: one SQLite database in WAL mode with synchronous=FULL, so an acknowledged
// version survives a crash or power loss. One connection behind a mutex keeps it simple and
// correct; tile traffic never touches the store once a version is resolved and cached.
#include <sqlite3.h>

#include <chrono>
#include <filesystem>
#include <mutex>

#include "server/store.hpp"
#include "terrain/scene.hpp"

namespace server {

std::string content_hash(const void* data, std::size_t size) {
  return "sha256:" + terrain::sha256_hex(std::string_view(static_cast<const char*>(data), size));
}

namespace {

using Kind = StoreError::Kind;

// Schema migrations, applied in order; the database records how many ran (user_version).
constexpr const char* kMigrations[] = {
    R"sql(
    CREATE TABLE scenes (
      id TEXT PRIMARY KEY,
      name TEXT NOT NULL,
      head INTEGER NOT NULL,
      created_ms INTEGER NOT NULL
    );
    CREATE TABLE versions (
      scene_id TEXT NOT NULL REFERENCES scenes(id),
      version INTEGER NOT NULL,
      hash TEXT NOT NULL,
      name TEXT NOT NULL,
      body TEXT NOT NULL,
      author TEXT NOT NULL,
      created_ms INTEGER NOT NULL,
      PRIMARY KEY (scene_id, version)
    );
    CREATE INDEX versions_by_hash ON versions(scene_id, hash);
    CREATE TABLE blobs (
      hash TEXT PRIMARY KEY,
      media_type TEXT NOT NULL,
      bytes BLOB NOT NULL
    );
    )sql",
    // 2: planet definitions, keyed by the content hash of their canonical JSON.
    R"sql(
    CREATE TABLE planets (
      id TEXT PRIMARY KEY,
      body TEXT NOT NULL,
      created_ms INTEGER NOT NULL
    );
    )sql",
    // 3: the JSON Patch of versions made by live edits (NULL for whole bodies).
    R"sql(
    ALTER TABLE versions ADD COLUMN ops TEXT;
    )sql",
    // 4: baked grids (erosion, drainage) by the content hash of what made them.
    R"sql(
    CREATE TABLE baked_grids (
      key TEXT PRIMARY KEY,
      size INTEGER NOT NULL,
      bytes BLOB NOT NULL,
      created_ms INTEGER NOT NULL
    );
    )sql",
};

// Drops the oldest baked grids (ties by key) beyond the bound, the newest kept first.
constexpr const char* kEvictBakedGrids =
    "DELETE FROM baked_grids WHERE key IN (SELECT key FROM (SELECT key, SUM(size) OVER "
    "(ORDER BY created_ms DESC, key DESC) AS running FROM baked_grids) AS newest "
    "WHERE running > ?)";

std::int64_t now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

class Statement {
 public:
  Statement(sqlite3* db, const char* sql) {
    rc_ = sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr);
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  bool ok() const { return rc_ == SQLITE_OK; }
  Statement& bind(int i, const std::string& text) {
    sqlite3_bind_text(stmt_, i, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
    return *this;
  }
  Statement& bind(int i, std::int64_t v) {
    sqlite3_bind_int64(stmt_, i, v);
    return *this;
  }
  Statement& bind_null(int i) {
    sqlite3_bind_null(stmt_, i);
    return *this;
  }
  Statement& bind_blob(int i, const std::vector<std::uint8_t>& bytes) {
    // A null pointer binds NULL, not an empty blob: an empty vector's data() may be one.
    static constexpr std::uint8_t kNone = 0;
    sqlite3_bind_blob(stmt_, i, bytes.empty() ? &kNone : bytes.data(),
                      static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
    return *this;
  }
  int step() { return sqlite3_step(stmt_); }
  std::string text(int column) const {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, column));
    return p == nullptr
               ? std::string()
               : std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(stmt_, column)));
  }
  std::int64_t integer(int column) const { return sqlite3_column_int64(stmt_, column); }
  std::vector<std::uint8_t> blob(int column) const {
    const auto* p = static_cast<const std::uint8_t*>(sqlite3_column_blob(stmt_, column));
    return p == nullptr ? std::vector<std::uint8_t>()
                        : std::vector<std::uint8_t>(p, p + sqlite3_column_bytes(stmt_, column));
  }

 private:
  sqlite3_stmt* stmt_ = nullptr;
  int rc_ = SQLITE_ERROR;
};

class SqliteStore final : public Store {
 public:
  explicit SqliteStore(sqlite3* db) : db_(db) {}
  ~SqliteStore() override { sqlite3_close(db_); }

  /// Checks an existing file before anything writes to it: a damaged store is refused rather
  /// than partly read and written on. quick_check walks every page's b-tree structure (cell
  /// layout, row order, page links, free list) in one pass without comparing indexes with their
  /// tables, so start-up stays fast (docs/server.md, "Damaged stores").
  StoreResult<bool> check_integrity(const std::string& path) {
    std::lock_guard lock(mutex_);
    auto damaged = [&](const std::string& what) {
      return StoreError{Kind::unavailable,
                        "'" + path + "' is damaged (" + what +
                            "): the server does not start on it; restore it from a backup, or "
                            "move it away to start a new store"};
    };
    Statement q(db_, "PRAGMA quick_check(8)");
    if (!q.ok()) return damaged(sqlite3_errmsg(db_));
    std::string problems;
    int rc = 0;
    while ((rc = q.step()) == SQLITE_ROW) {
      const std::string line = q.text(0);
      if (line == "ok") continue;
      problems += (problems.empty() ? "" : "; ") + line;
    }
    if (rc != SQLITE_DONE) {
      problems += (problems.empty() ? "" : "; ") + std::string(sqlite3_errmsg(db_));
    }
    if (!problems.empty()) return damaged(problems);
    return true;
  }

  StoreResult<bool> migrate() {
    std::lock_guard lock(mutex_);
    for (const char* pragma : {"PRAGMA journal_mode=WAL", "PRAGMA synchronous=FULL",
                               "PRAGMA foreign_keys=ON", "PRAGMA busy_timeout=5000"}) {
      if (!exec(pragma)) return failure("cannot set " + std::string(pragma));
    }
    Statement q(db_, "PRAGMA user_version");
    if (!q.ok() || q.step() != SQLITE_ROW) return failure("cannot read the schema version");
    const std::int64_t applied = q.integer(0);
    const auto total = static_cast<std::int64_t>(std::size(kMigrations));
    if (applied > total) {
      return StoreError{Kind::unavailable, "the database was written by a newer server (schema " +
                                               std::to_string(applied) + ")"};
    }
    for (std::int64_t m = applied; m < total; ++m) {
      if (!exec("BEGIN IMMEDIATE")) return failure("cannot begin a migration");
      if (!exec(kMigrations[m]) ||
          !exec(("PRAGMA user_version=" + std::to_string(m + 1)).c_str())) {
        exec("ROLLBACK");
        return failure("migration " + std::to_string(m + 1) + " failed");
      }
      if (!exec("COMMIT")) return failure("cannot commit migration");
    }
    return true;
  }

  StoreResult<std::vector<SceneSummary>> list_scenes() override {
    std::lock_guard lock(mutex_);
    Statement q(db_,
                "SELECT s.id, s.name, s.head, v.hash FROM scenes s JOIN versions v "
                "ON v.scene_id = s.id AND v.version = s.head ORDER BY s.id");
    if (!q.ok()) return failure("cannot list scenes");
    std::vector<SceneSummary> out;
    int rc = 0;
    while ((rc = q.step()) == SQLITE_ROW) {
      out.push_back({q.text(0), q.text(1), q.integer(2), q.text(3)});
    }
    if (rc != SQLITE_DONE) return failure("cannot list scenes");
    return out;
  }

  StoreResult<SceneVersion> create_scene(const std::string& id,
                                         const SceneVersion& first) override {
    std::lock_guard lock(mutex_);
    if (!exec("BEGIN IMMEDIATE")) return failure("cannot begin a transaction");
    Statement exists(db_, "SELECT 1 FROM scenes WHERE id = ?");
    exists.bind(1, id);
    const int found = exists.step();
    if (found == SQLITE_ROW) {
      exec("ROLLBACK");
      return StoreError{Kind::conflict, "scene '" + id + "' already exists"};
    }
    SceneVersion v = first;
    v.scene_id = id;
    v.version = 1;
    v.created_ms = now_ms();
    Statement insert(db_, "INSERT INTO scenes (id, name, head, created_ms) VALUES (?, ?, 1, ?)");
    insert.bind(1, id).bind(2, v.name).bind(3, v.created_ms);
    if (found != SQLITE_DONE || insert.step() != SQLITE_DONE || !insert_version(v) ||
        !exec("COMMIT")) {
      exec("ROLLBACK");
      return failure("cannot store scene '" + id + "'");
    }
    return v;
  }

  StoreResult<SceneVersion> add_version(const std::string& id, const SceneVersion& next,
                                        std::optional<std::int64_t> expected_head) override {
    std::lock_guard lock(mutex_);
    // BEGIN IMMEDIATE takes the write lock first, so the head read below cannot go stale.
    if (!exec("BEGIN IMMEDIATE")) return failure("cannot begin a transaction");
    Statement q(db_, "SELECT head FROM scenes WHERE id = ?");
    q.bind(1, id);
    const int rc = q.step();
    if (rc != SQLITE_ROW) {
      exec("ROLLBACK");
      if (rc == SQLITE_DONE) return StoreError{Kind::not_found, "no scene '" + id + "'"};
      return failure("cannot read scene '" + id + "'");
    }
    const std::int64_t head = q.integer(0);
    if (expected_head && *expected_head != head) {
      exec("ROLLBACK");
      return StoreError{Kind::conflict, "scene '" + id + "' is at version " + std::to_string(head) +
                                            ", not " + std::to_string(*expected_head)};
    }
    SceneVersion v = next;
    v.scene_id = id;
    v.version = head + 1;
    v.created_ms = now_ms();
    Statement update(db_, "UPDATE scenes SET head = ?, name = ? WHERE id = ?");
    update.bind(1, v.version).bind(2, v.name).bind(3, id);
    if (!insert_version(v) || update.step() != SQLITE_DONE || !exec("COMMIT")) {
      exec("ROLLBACK");
      return failure("cannot store a version of '" + id + "'");
    }
    return v;
  }

  StoreResult<SceneVersion> head(const std::string& id) override {
    std::lock_guard lock(mutex_);
    return select_version(
        "SELECT v.scene_id, v.version, v.hash, v.name, v.body, v.author, v.created_ms, v.ops "
        "FROM scenes s JOIN versions v ON v.scene_id = s.id AND v.version = s.head "
        "WHERE s.id = ?",
        id, std::nullopt, "no scene '" + id + "'");
  }

  StoreResult<SceneVersion> version(const std::string& id, std::int64_t number) override {
    std::lock_guard lock(mutex_);
    return select_version(
        "SELECT scene_id, version, hash, name, body, author, created_ms, ops FROM versions "
        "WHERE scene_id = ? AND version = ?",
        id, number, "no version " + std::to_string(number) + " of scene '" + id + "'");
  }

  StoreResult<SceneVersion> version_by_hash(const std::string& id,
                                            const std::string& hash) override {
    std::lock_guard lock(mutex_);
    Statement q(db_,
                "SELECT scene_id, version, hash, name, body, author, created_ms, ops FROM versions "
                "WHERE scene_id = ? AND hash = ? ORDER BY version DESC LIMIT 1");
    q.bind(1, id).bind(2, hash);
    return read_version(q, "no version of scene '" + id + "' has hash " + hash);
  }

  StoreResult<std::vector<SceneVersion>> versions(const std::string& id) override {
    std::lock_guard lock(mutex_);
    Statement exists(db_, "SELECT 1 FROM scenes WHERE id = ?");
    exists.bind(1, id);
    const int found = exists.step();
    if (found == SQLITE_DONE) return StoreError{Kind::not_found, "no scene '" + id + "'"};
    if (found != SQLITE_ROW) return failure("cannot read scene '" + id + "'");
    Statement q(db_,
                "SELECT scene_id, version, hash, name, author, created_ms FROM versions "
                "WHERE scene_id = ? ORDER BY version");
    q.bind(1, id);
    std::vector<SceneVersion> out;
    int rc = 0;
    while ((rc = q.step()) == SQLITE_ROW) {
      out.push_back(
          {q.text(0), q.integer(1), q.text(2), q.text(3), "", q.text(4), q.integer(5), ""});
    }
    if (rc != SQLITE_DONE) return failure("cannot list versions of '" + id + "'");
    return out;
  }

  StoreResult<std::vector<SceneVersion>> versions_after(const std::string& id, std::int64_t after,
                                                        std::int64_t limit) override {
    std::lock_guard lock(mutex_);
    Statement q(db_,
                "SELECT scene_id, version, hash, name, body, author, created_ms, ops FROM versions "
                "WHERE scene_id = ? AND version > ? ORDER BY version LIMIT ?");
    q.bind(1, id).bind(2, after).bind(3, limit);
    std::vector<SceneVersion> out;
    int rc = 0;
    while ((rc = q.step()) == SQLITE_ROW) out.push_back(row_version(q));
    if (rc != SQLITE_DONE) return failure("cannot list versions of '" + id + "'");
    return out;
  }

  StoreResult<bool> put_blob(const Blob& b) override {
    std::lock_guard lock(mutex_);
    Statement q(db_, "INSERT OR IGNORE INTO blobs (hash, media_type, bytes) VALUES (?, ?, ?)");
    q.bind(1, b.hash).bind(2, b.media_type).bind_blob(3, b.bytes);
    if (q.step() != SQLITE_DONE) return failure("cannot store blob " + b.hash);
    return true;
  }

  StoreResult<Blob> blob(const std::string& hash) override {
    std::lock_guard lock(mutex_);
    Statement q(db_, "SELECT hash, media_type, bytes FROM blobs WHERE hash = ?");
    q.bind(1, hash);
    const int rc = q.step();
    if (rc == SQLITE_DONE) return StoreError{Kind::not_found, "no blob " + hash};
    if (rc != SQLITE_ROW) return failure("cannot read blob " + hash);
    return Blob{q.text(0), q.text(1), q.blob(2)};
  }

  StoreResult<bool> put_baked_grid(const std::string& key, const std::vector<std::uint8_t>& bytes,
                                   std::int64_t max_total_bytes) override {
    const auto size = static_cast<std::int64_t>(bytes.size());
    if (size > max_total_bytes) return false;
    std::lock_guard lock(mutex_);
    Statement put(db_,
                  "INSERT OR IGNORE INTO baked_grids (key, size, bytes, created_ms) "
                  "VALUES (?, ?, ?, ?)");
    put.bind(1, key).bind(2, size).bind_blob(3, bytes).bind(4, now_ms());
    if (put.step() != SQLITE_DONE) return failure("cannot store baked grid " + key);
    Statement evict(db_, kEvictBakedGrids);
    evict.bind(1, max_total_bytes);
    if (evict.step() != SQLITE_DONE) return failure("cannot trim the baked grids");
    return true;
  }

  StoreResult<std::vector<std::uint8_t>> baked_grid(const std::string& key) override {
    std::lock_guard lock(mutex_);
    Statement q(db_, "SELECT bytes FROM baked_grids WHERE key = ?");
    q.bind(1, key);
    const int rc = q.step();
    if (rc == SQLITE_DONE) return StoreError{Kind::not_found, "no baked grid " + key};
    if (rc != SQLITE_ROW) return failure("cannot read baked grid " + key);
    return q.blob(0);
  }

  StoreResult<PlanetPut> put_planet(const StoredPlanet& planet) override {
    if (planet.id.empty() || planet.canonical_json.empty()) {
      return StoreError{Kind::conflict, "a planet needs an id and a body"};
    }
    std::lock_guard lock(mutex_);
    // One transaction: the look-up and the insert cannot interleave with another writer's.
    if (!exec("BEGIN IMMEDIATE")) return failure("cannot begin a transaction");
    Statement q(db_, "SELECT id, body, created_ms FROM planets WHERE id = ?");
    q.bind(1, planet.id);
    const int rc = q.step();
    if (rc == SQLITE_ROW) {
      StoredPlanet existing{q.text(0), q.text(1), q.integer(2)};
      exec("ROLLBACK");
      if (existing.canonical_json != planet.canonical_json) {
        return StoreError{Kind::conflict,
                          "planet " + planet.id + " is stored with another definition"};
      }
      return PlanetPut{std::move(existing), false};
    }
    StoredPlanet stored = planet;
    stored.created_ms = now_ms();
    Statement insert(db_, "INSERT INTO planets (id, body, created_ms) VALUES (?, ?, ?)");
    insert.bind(1, stored.id).bind(2, stored.canonical_json).bind(3, stored.created_ms);
    if (rc != SQLITE_DONE || insert.step() != SQLITE_DONE || !exec("COMMIT")) {
      exec("ROLLBACK");
      return failure("cannot store planet " + planet.id);
    }
    return PlanetPut{std::move(stored), true};
  }

  StoreResult<StoredPlanet> get_planet(const std::string& id) override {
    std::lock_guard lock(mutex_);
    Statement q(db_, "SELECT id, body, created_ms FROM planets WHERE id = ?");
    q.bind(1, id);
    const int rc = q.step();
    if (rc == SQLITE_DONE) return StoreError{Kind::not_found, "no planet " + id};
    if (rc != SQLITE_ROW) return failure("cannot read planet " + id);
    return StoredPlanet{q.text(0), q.text(1), q.integer(2)};
  }

  StoreResult<std::vector<StoredPlanet>> list_planets() override {
    std::lock_guard lock(mutex_);
    Statement q(db_, "SELECT id, body, created_ms FROM planets ORDER BY created_ms, id");
    if (!q.ok()) return failure("cannot list planets");
    std::vector<StoredPlanet> out;
    int rc = 0;
    while ((rc = q.step()) == SQLITE_ROW) out.push_back({q.text(0), q.text(1), q.integer(2)});
    if (rc != SQLITE_DONE) return failure("cannot list planets");
    return out;
  }

  StoreResult<bool> empty() override {
    std::lock_guard lock(mutex_);
    Statement q(db_, "SELECT COUNT(*) FROM scenes");
    if (q.step() != SQLITE_ROW) return failure("cannot count scenes");
    return q.integer(0) == 0;
  }

 private:
  bool exec(const char* sql) {
    return sqlite3_exec(db_, sql, nullptr, nullptr, nullptr) == SQLITE_OK;
  }

  StoreError failure(const std::string& what) const {
    return StoreError{Kind::unavailable, what + ": " + sqlite3_errmsg(db_)};
  }

  bool insert_version(const SceneVersion& v) {
    Statement q(
        db_,
        "INSERT INTO versions (scene_id, version, hash, name, body, author, created_ms, ops) "
        "VALUES (?, ?, ?, ?, ?, ?, ?, ?)");
    q.bind(1, v.scene_id).bind(2, v.version).bind(3, v.hash).bind(4, v.name);
    q.bind(5, v.canonical_json).bind(6, v.author).bind(7, v.created_ms);
    if (v.ops_json.empty()) {
      q.bind_null(8);
    } else {
      q.bind(8, v.ops_json);
    }
    return q.step() == SQLITE_DONE;
  }

  StoreResult<SceneVersion> read_version(Statement& q, const std::string& missing) const {
    const int rc = q.step();
    if (rc == SQLITE_DONE) return StoreError{Kind::not_found, missing};
    if (rc != SQLITE_ROW) return failure("cannot read a version");
    return row_version(q);
  }

  static SceneVersion row_version(Statement& q) {
    return SceneVersion{q.text(0), q.integer(1), q.text(2),    q.text(3),
                        q.text(4), q.text(5),    q.integer(6), q.text(7)};
  }

  StoreResult<SceneVersion> select_version(const char* sql, const std::string& id,
                                           std::optional<std::int64_t> number,
                                           const std::string& missing) {
    Statement q(db_, sql);
    q.bind(1, id);
    if (number) q.bind(2, *number);
    return read_version(q, missing);
  }

  std::mutex mutex_;
  sqlite3* db_;
};

}  // namespace

StoreResult<std::unique_ptr<Store>> open_sqlite_store(const std::string& data_dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(data_dir, ec);
  if (ec) {
    return StoreError{Kind::unavailable, "cannot create '" + data_dir + "': " + ec.message()};
  }
  const std::string path = (fs::path(data_dir) / "terrain.sqlite3").string();
  // Only a missing file is a new store. SQLite would take an empty file for a new database and
  // the server would seed it: an emptied store must not quietly become the built-in examples.
  const bool existing = fs::exists(path, ec);
  if (ec) return StoreError{Kind::unavailable, "cannot inspect '" + path + "': " + ec.message()};
  if (existing && fs::is_regular_file(path, ec) && fs::file_size(path, ec) == 0 && !ec) {
    return StoreError{Kind::unavailable,
                      "'" + path +
                          "' is empty (0 bytes), not a store: the server does not start on it; "
                          "restore it from a backup, or move it away to start a new store"};
  }
  sqlite3* db = nullptr;
  const int flags =
      SQLITE_OPEN_READWRITE | SQLITE_OPEN_FULLMUTEX | (existing ? 0 : SQLITE_OPEN_CREATE);
  const int rc = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
  if (rc != SQLITE_OK) {
    std::string message = db != nullptr ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return StoreError{Kind::unavailable, "cannot open '" + path + "': " + message};
  }
  auto store = std::make_unique<SqliteStore>(db);
  if (existing) {
    if (StoreResult<bool> intact = store->check_integrity(path); !intact) return intact.error();
  }
  StoreResult<bool> migrated = store->migrate();
  if (!migrated) return migrated.error();
  return std::unique_ptr<Store>(std::move(store));
}

}  // namespace server
