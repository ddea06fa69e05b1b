// The PostgreSQL store. Its semantics are sqlite_store.cpp's exactly (numbering, conflicts,
// orders); what differs is sharing: several server processes write through one database, so a
// version is one transaction holding its scene's row lock (SELECT … FOR UPDATE), and PostgreSQL
// going away is an expected event: calls fail with `unavailable` (503 + Retry-After) and later
// calls reconnect. No call waits without bound: connects, statements, lock waits and waits for a
// pooled connection all have timeouts, and TCP keepalives notice a peer that vanished.
#include "server/postgres_store.hpp"

#include <libpq-fe.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <utility>
#include <vector>

#include "server/log.hpp"

namespace server {
namespace {

using Kind = StoreError::Kind;
using Clock = std::chrono::steady_clock;

// Type OIDs of the parameters sent in binary (catalog/pg_type_d.h is a server header, not in
// libpq-dev).
constexpr Oid kByteaOid = 17;
constexpr Oid kInt8Oid = 20;
constexpr Oid kTextOid = 25;

// The advisory lock migrations run under. Advisory locks are per database, so any constant works.
constexpr std::int64_t kMigrationLock = 0x7465'7272'6169'6e31;  // "terrain1"

// Schema migrations, applied in order; schema_migrations records each one applied. They mirror
// the SQLite store's, so both report the same schema version.
constexpr const char* kMigrations[] = {
    R"sql(
    CREATE TABLE scenes (
      id TEXT PRIMARY KEY,
      name TEXT NOT NULL,
      head BIGINT NOT NULL,
      created_ms BIGINT NOT NULL
    );
    CREATE TABLE versions (
      scene_id TEXT NOT NULL REFERENCES scenes(id),
      version BIGINT NOT NULL,
      hash TEXT NOT NULL,
      name TEXT NOT NULL,
      body TEXT NOT NULL,
      author TEXT NOT NULL,
      created_ms BIGINT NOT NULL,
      PRIMARY KEY (scene_id, version)
    );
    CREATE INDEX versions_by_hash ON versions(scene_id, hash);
    CREATE TABLE blobs (
      hash TEXT PRIMARY KEY,
      media_type TEXT NOT NULL,
      bytes BYTEA NOT NULL
    );
    )sql",
    // 2: planet definitions, keyed by the content hash of their canonical JSON.
    R"sql(
    CREATE TABLE planets (
      id TEXT PRIMARY KEY,
      body TEXT NOT NULL,
      created_ms BIGINT NOT NULL
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
      size BIGINT NOT NULL,
      bytes BYTEA NOT NULL,
      created_ms BIGINT NOT NULL
    );
    )sql",
};

// Every column list that reads a whole version, in SceneVersion's order.
constexpr const char* kVersionColumns =
    "v.scene_id, v.version, v.hash, v.name, v.body, v.author, v.created_ms, v.ops";

std::int64_t now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// libpq's messages end in newlines and may span lines ("FATAL: …\nserver closed …"): one line.
std::string one_line(const char* message) {
  std::string s;
  for (const char* p = message; p != nullptr && *p != '\0'; ++p) {
    const bool space = *p == '\n' || *p == '\t' || *p == ' ';
    if (!space) {
      s.push_back(*p);
    } else if (!s.empty() && s.back() != ' ') {
      s.push_back(' ');
    }
  }
  if (!s.empty() && s.back() == ' ') s.pop_back();
  return s.empty() ? "unknown error" : s;
}

// One statement parameter. Everything is sent in binary: text may hold any bytes and nothing is
// ever quoted or escaped.
class Param {
 public:
  static Param text(const std::string& s) { return Param(s.data(), s.size(), kTextOid); }
  static Param bytes(const std::vector<std::uint8_t>& b) {
    return Param(reinterpret_cast<const char*>(b.data()), b.size(), kByteaOid);
  }
  static Param int8(std::int64_t v) {
    Param p(nullptr, 8, kInt8Oid);
    auto u = static_cast<std::uint64_t>(v);
    for (int i = 7; i >= 0; --i) {  // network byte order
      p.buffer_[static_cast<std::size_t>(i)] = static_cast<char>(u & 0xff);
      u >>= 8;
    }
    p.owned_ = true;
    return p;
  }
  static Param null(Oid type) {
    Param p(nullptr, 0, type);
    p.null_ = true;
    return p;
  }

  /// nullptr means SQL NULL to libpq, so empty values point at a static empty string.
  const char* data() const {
    if (null_) return nullptr;
    if (owned_) return buffer_.data();
    return data_ != nullptr ? data_ : "";
  }
  int length() const { return static_cast<int>(size_); }
  Oid type() const { return type_; }

 private:
  Param(const char* data, std::size_t size, Oid type) : data_(data), size_(size), type_(type) {}

  const char* data_;
  std::size_t size_;
  Oid type_;
  std::array<char, 8> buffer_{};
  bool owned_ = false;
  bool null_ = false;
};

// A statement's result; text format unless the statement asked for binary.
class Rows {
 public:
  explicit Rows(PGresult* result) : result_(result) {}
  ~Rows() { PQclear(result_); }
  Rows(Rows&& other) noexcept : result_(std::exchange(other.result_, nullptr)) {}
  Rows(const Rows&) = delete;
  Rows& operator=(const Rows&) = delete;
  Rows& operator=(Rows&&) = delete;

  bool ok() const {
    const ExecStatusType s = PQresultStatus(result_);
    return result_ != nullptr && (s == PGRES_COMMAND_OK || s == PGRES_TUPLES_OK);
  }
  int size() const { return PQntuples(result_); }
  bool null(int row, int column) const { return PQgetisnull(result_, row, column) != 0; }
  std::string text(int row, int column) const {
    return std::string(PQgetvalue(result_, row, column),
                       static_cast<std::size_t>(PQgetlength(result_, row, column)));
  }
  std::int64_t integer(int row, int column) const {
    const char* p = PQgetvalue(result_, row, column);
    std::int64_t v = 0;
    std::from_chars(p, p + PQgetlength(result_, row, column), v);
    return v;
  }
  std::vector<std::uint8_t> bytes(int row, int column) const {  // binary results only
    const auto* p = reinterpret_cast<const std::uint8_t*>(PQgetvalue(result_, row, column));
    return std::vector<std::uint8_t>(p, p + PQgetlength(result_, row, column));
  }
  std::string command() const { return PQcmdStatus(result_); }
  /// The server's message; nullptr results (a send that failed) take the connection's.
  const char* error(PGconn* pg) const {
    return result_ != nullptr ? PQresultErrorMessage(result_) : PQerrorMessage(pg);
  }

 private:
  PGresult* result_;
};

// One server connection, used by one thread at a time (the pool lends it).
class Connection {
 public:
  explicit Connection(PGconn* pg) : pg_(pg) {}
  ~Connection() { PQfinish(pg_); }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  /// One statement with parameters (extended protocol).
  Rows exec(const char* sql, const std::vector<Param>& params = {}, bool binary_result = false) {
    std::vector<Oid> types;
    std::vector<const char*> values;
    std::vector<int> lengths;
    std::vector<int> formats;
    for (const Param& p : params) {
      types.push_back(p.type());
      values.push_back(p.data());
      lengths.push_back(p.length());
      formats.push_back(1);
    }
    return Rows(PQexecParams(pg_, sql, static_cast<int>(params.size()), types.data(), values.data(),
                             lengths.data(), formats.data(), binary_result ? 1 : 0));
  }
  /// Several statements without parameters (simple protocol): migrations, session settings.
  Rows exec_script(const char* sql) { return Rows(PQexec(pg_, sql)); }

  /// The server closed the connection (restart, crash, network): it is of no further use.
  bool lost() const { return PQstatus(pg_) != CONNECTION_OK; }
  bool idle() const { return PQtransactionStatus(pg_) == PQTRANS_IDLE; }

  /// Marks that a write may have committed on this lease: a failure after it is not retried.
  void note_commit() { commit_sent_ = true; }
  bool commit_sent() const { return commit_sent_; }
  void new_lease() { commit_sent_ = false; }

  /// Server warnings go to the structured log instead of libpq's default, bare stderr.
  void log_notices() {
    PQsetNoticeProcessor(
        pg_,
        [](void*, const char* message) {
          log(LogLevel::warn, "postgres_notice", {{"message", one_line(message)}});
        },
        nullptr);
  }

  /// The connection's latest message (why a connect failed, say).
  std::string message() const { return one_line(PQerrorMessage(pg_)); }

  StoreError failure(const Rows& rows, const std::string& what) const {
    return StoreError{Kind::unavailable, what + ": " + one_line(rows.error(pg_))};
  }

 private:
  PGconn* pg_;
  bool commit_sent_ = false;
};

// A transaction on a leased connection, rolled back unless committed.
class Transaction {
 public:
  explicit Transaction(Connection& c) : c_(c) {}
  ~Transaction() {
    // A connection left inside a transaction (a failed ROLLBACK) is closed by the pool.
    if (open_ && !c_.lost()) c_.exec("ROLLBACK");
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

  StoreResult<bool> begin() {
    Rows r = c_.exec("BEGIN");
    if (!r.ok()) return c_.failure(r, "cannot begin a transaction");
    open_ = true;
    return true;
  }
  StoreResult<bool> commit() {
    c_.note_commit();
    open_ = false;
    Rows r = c_.exec("COMMIT");
    // COMMIT of a failed transaction "succeeds" with the tag ROLLBACK: that is a failure here.
    if (!r.ok() || r.command() != "COMMIT") return c_.failure(r, "cannot commit");
    return true;
  }

 private:
  Connection& c_;
  bool open_ = false;
};

class Pool;

// A connection lent by the pool, given back when the lease ends.
class Lease {
 public:
  Lease(Pool* pool, std::unique_ptr<Connection> c, bool reused)
      : pool_(pool), conn_(std::move(c)), reused_(reused) {}
  Lease(Lease&& other) noexcept = default;
  Lease(const Lease&) = delete;
  Lease& operator=(const Lease&) = delete;
  Lease& operator=(Lease&&) = delete;
  ~Lease();

  Connection& conn() { return *conn_; }
  /// True when the connection had served earlier calls (it may have gone stale since).
  bool reused() const { return reused_; }

 private:
  Pool* pool_;
  std::unique_ptr<Connection> conn_;
  bool reused_;
};

// At most pool_size connections, opened on demand; idle ones are kept for the next caller.
class Pool {
 public:
  explicit Pool(PostgresOptions options) : options_(std::move(options)) {}

  StoreResult<Lease> acquire() {
    std::unique_lock lock(mutex_);
    const bool free = freed_.wait_for(lock, std::chrono::milliseconds(options_.acquire_timeout_ms),
                                      [&] { return !idle_.empty() || open_ < options_.pool_size; });
    if (!free) {
      return StoreError{Kind::unavailable, "all " + std::to_string(options_.pool_size) +
                                               " PostgreSQL connections are busy"};
    }
    if (!idle_.empty()) {
      std::unique_ptr<Connection> c = std::move(idle_.back());
      idle_.pop_back();
      c->new_lease();
      return Lease(this, std::move(c), true);
    }
    // A server that refused a connection a moment ago is most likely still down, and each
    // attempt may take connect_timeout: fail at once for a short while.
    if (!last_failure_.empty() &&
        Clock::now() - failed_at_ < std::chrono::milliseconds(options_.reconnect_backoff_ms)) {
      return StoreError{Kind::unavailable, last_failure_};
    }
    ++open_;
    lock.unlock();
    StoreResult<std::unique_ptr<Connection>> c = connect();
    lock.lock();
    if (!c) {
      --open_;
      failed_at_ = Clock::now();
      last_failure_ = c.error().message;
      freed_.notify_one();
      return c.error();
    }
    last_failure_.clear();
    return Lease(this, std::move(c).value(), false);
  }

  void release(std::unique_ptr<Connection> c) {
    if (c->lost() || !c->idle()) {
      c.reset();  // closed outside the lock
      std::lock_guard lock(mutex_);
      --open_;
    } else {
      std::lock_guard lock(mutex_);
      idle_.push_back(std::move(c));
    }
    freed_.notify_one();
  }

  /// Closes every idle connection: once one was found dead (a server restart), the others,
  /// opened before it, are as dead.
  void drop_idle() {
    std::vector<std::unique_ptr<Connection>> dead;
    {
      std::lock_guard lock(mutex_);
      dead.swap(idle_);
      open_ -= static_cast<int>(dead.size());
    }
    freed_.notify_all();
  }

 private:
  StoreResult<std::unique_ptr<Connection>> connect() {
    const std::string timeout = std::to_string(options_.connect_timeout_s);
    // Entries before dbname are defaults the connection string may override; client_encoding
    // comes after it because every string the store handles is UTF-8.
    const char* keys[] = {"connect_timeout",  "keepalives",
                          "keepalives_idle",  "keepalives_interval",
                          "keepalives_count", "tcp_user_timeout",
                          "application_name", "dbname",
                          "client_encoding",  nullptr};
    const char* values[] = {
        timeout.c_str(),           "1",    "10",   "5", "3", "30000", "terrain-server",
        options_.conninfo.c_str(), "UTF8", nullptr};
    auto c = std::make_unique<Connection>(PQconnectdbParams(keys, values, 1));
    if (c->lost()) {
      return StoreError{Kind::unavailable, "cannot connect to PostgreSQL: " + c->message()};
    }
    c->log_notices();
    // Below warning, notices are chatter ("relation … already exists, skipping").
    const std::string settings =
        "SET client_min_messages = warning; SET statement_timeout = " +
        std::to_string(options_.statement_timeout_ms) +
        "; SET lock_timeout = " + std::to_string(options_.lock_timeout_ms) +
        "; SET idle_in_transaction_session_timeout = " +
        std::to_string(std::max(options_.statement_timeout_ms, 60'000));
    Rows r = c->exec_script(settings.c_str());
    if (!r.ok()) return c->failure(r, "cannot configure a PostgreSQL session");
    return c;
  }

  PostgresOptions options_;
  std::mutex mutex_;
  std::condition_variable freed_;
  std::vector<std::unique_ptr<Connection>> idle_;
  int open_ = 0;  ///< idle and lent
  Clock::time_point failed_at_{};
  std::string last_failure_;  ///< of the latest connect, "" once one succeeded
};

Lease::~Lease() {
  if (conn_) pool_->release(std::move(conn_));
}

SceneVersion row_version(const Rows& r, int row) {
  return SceneVersion{
      r.text(row, 0), r.integer(row, 1), r.text(row, 2),    r.text(row, 3),
      r.text(row, 4), r.text(row, 5),    r.integer(row, 6), r.null(row, 7) ? "" : r.text(row, 7)};
}

class PostgresStore final : public Store {
 public:
  explicit PostgresStore(const PostgresOptions& options) : pool_(options) {}

  StoreResult<bool> migrate() {
    StoreResult<Lease> lease = pool_.acquire();
    if (!lease) return lease.error();
    Connection& c = lease->conn();
    Transaction tx(c);
    if (StoreResult<bool> b = tx.begin(); !b) return b;
    // Replicas starting together wait here for the first one's migrations, then see them done.
    Rows locked = c.exec("SELECT pg_advisory_xact_lock($1)", {Param::int8(kMigrationLock)});
    if (!locked.ok()) return c.failure(locked, "cannot take the migration lock");
    Rows created = c.exec(
        "CREATE TABLE IF NOT EXISTS schema_migrations ("
        "version INTEGER PRIMARY KEY, applied_ms BIGINT NOT NULL)");
    if (!created.ok()) return c.failure(created, "cannot create schema_migrations");
    Rows q = c.exec("SELECT COALESCE(MAX(version), 0) FROM schema_migrations");
    if (!q.ok() || q.size() != 1) return c.failure(q, "cannot read the schema version");
    const std::int64_t applied = q.integer(0, 0);
    const auto total = static_cast<std::int64_t>(std::size(kMigrations));
    if (applied > total) {
      return StoreError{Kind::unavailable, "the database was written by a newer server (schema " +
                                               std::to_string(applied) + ")"};
    }
    for (std::int64_t m = applied; m < total; ++m) {
      Rows step = c.exec_script(kMigrations[m]);
      if (!step.ok()) return c.failure(step, "migration " + std::to_string(m + 1) + " failed");
      Rows noted = c.exec("INSERT INTO schema_migrations (version, applied_ms) VALUES ($1, $2)",
                          {Param::int8(m + 1), Param::int8(now_ms())});
      if (!noted.ok()) return c.failure(noted, "cannot record migration " + std::to_string(m + 1));
    }
    return tx.commit();
  }

  StoreResult<std::vector<SceneSummary>> list_scenes() override {
    return run([](Connection& c) -> StoreResult<std::vector<SceneSummary>> {
      // COLLATE "C": bytewise, as SQLite orders, whatever the database's locale.
      Rows r = c.exec(
          "SELECT s.id, s.name, s.head, v.hash FROM scenes s JOIN versions v "
          "ON v.scene_id = s.id AND v.version = s.head ORDER BY s.id COLLATE \"C\"");
      if (!r.ok()) return c.failure(r, "cannot list scenes");
      std::vector<SceneSummary> out;
      for (int i = 0; i < r.size(); ++i) {
        out.push_back({r.text(i, 0), r.text(i, 1), r.integer(i, 2), r.text(i, 3)});
      }
      return out;
    });
  }

  StoreResult<SceneVersion> create_scene(const std::string& id,
                                         const SceneVersion& first) override {
    return run([&](Connection& c) -> StoreResult<SceneVersion> {
      Transaction tx(c);
      if (StoreResult<bool> b = tx.begin(); !b) return b.error();
      SceneVersion v = first;
      v.scene_id = id;
      v.version = 1;
      v.created_ms = now_ms();
      // A concurrent creator of the same id makes this wait for its outcome, then do nothing.
      Rows inserted = c.exec(
          "INSERT INTO scenes (id, name, head, created_ms) VALUES ($1, $2, 1, $3) "
          "ON CONFLICT (id) DO NOTHING RETURNING id",
          {Param::text(id), Param::text(v.name), Param::int8(v.created_ms)});
      if (!inserted.ok()) return c.failure(inserted, "cannot store scene '" + id + "'");
      if (inserted.size() == 0)
        return StoreError{Kind::conflict, "scene '" + id + "' already exists"};
      if (StoreResult<bool> b = insert_version(c, v); !b) return b.error();
      if (StoreResult<bool> b = tx.commit(); !b) return b.error();
      return v;
    });
  }

  StoreResult<SceneVersion> add_version(const std::string& id, const SceneVersion& next,
                                        std::optional<std::int64_t> expected_head) override {
    return run([&](Connection& c) -> StoreResult<SceneVersion> {
      Transaction tx(c);
      if (StoreResult<bool> b = tx.begin(); !b) return b.error();
      // The row lock serialises writers of this scene across every server process: a second
      // writer waits here and then reads the head the first one committed.
      Rows q = c.exec("SELECT head FROM scenes WHERE id = $1 FOR UPDATE", {Param::text(id)});
      if (!q.ok()) return c.failure(q, "cannot read scene '" + id + "'");
      if (q.size() == 0) return StoreError{Kind::not_found, "no scene '" + id + "'"};
      const std::int64_t head = q.integer(0, 0);
      if (expected_head && *expected_head != head) {
        return StoreError{Kind::conflict, "scene '" + id + "' is at version " +
                                              std::to_string(head) + ", not " +
                                              std::to_string(*expected_head)};
      }
      SceneVersion v = next;
      v.scene_id = id;
      v.version = head + 1;
      v.created_ms = now_ms();
      if (StoreResult<bool> b = insert_version(c, v); !b) return b.error();
      Rows update = c.exec("UPDATE scenes SET head = $1, name = $2 WHERE id = $3",
                           {Param::int8(v.version), Param::text(v.name), Param::text(id)});
      if (!update.ok()) return c.failure(update, "cannot store a version of '" + id + "'");
      if (StoreResult<bool> b = tx.commit(); !b) return b.error();
      return v;
    });
  }

  StoreResult<SceneVersion> head(const std::string& id) override {
    return one_version(std::string("SELECT ") + kVersionColumns +
                           " FROM scenes s JOIN versions v ON v.scene_id = s.id AND v.version = "
                           "s.head WHERE s.id = $1",
                       {Param::text(id)}, "no scene '" + id + "'");
  }

  StoreResult<SceneVersion> version(const std::string& id, std::int64_t number) override {
    return one_version(std::string("SELECT ") + kVersionColumns +
                           " FROM versions v WHERE v.scene_id = $1 AND v.version = $2",
                       {Param::text(id), Param::int8(number)},
                       "no version " + std::to_string(number) + " of scene '" + id + "'");
  }

  StoreResult<SceneVersion> version_by_hash(const std::string& id,
                                            const std::string& hash) override {
    return one_version(std::string("SELECT ") + kVersionColumns +
                           " FROM versions v WHERE v.scene_id = $1 AND v.hash = $2 "
                           "ORDER BY v.version DESC LIMIT 1",
                       {Param::text(id), Param::text(hash)},
                       "no version of scene '" + id + "' has hash " + hash);
  }

  StoreResult<std::vector<SceneVersion>> versions(const std::string& id) override {
    return run([&](Connection& c) -> StoreResult<std::vector<SceneVersion>> {
      // Every scene has a version, so no rows means no scene.
      Rows r = c.exec(
          "SELECT v.scene_id, v.version, v.hash, v.name, v.author, v.created_ms "
          "FROM scenes s JOIN versions v ON v.scene_id = s.id WHERE s.id = $1 ORDER BY v.version",
          {Param::text(id)});
      if (!r.ok()) return c.failure(r, "cannot list versions of '" + id + "'");
      if (r.size() == 0) return StoreError{Kind::not_found, "no scene '" + id + "'"};
      std::vector<SceneVersion> out;
      for (int i = 0; i < r.size(); ++i) {
        out.push_back({r.text(i, 0), r.integer(i, 1), r.text(i, 2), r.text(i, 3), "", r.text(i, 4),
                       r.integer(i, 5), ""});
      }
      return out;
    });
  }

  StoreResult<std::vector<SceneVersion>> versions_after(const std::string& id, std::int64_t after,
                                                        std::int64_t limit) override {
    return run([&](Connection& c) -> StoreResult<std::vector<SceneVersion>> {
      // SQLite reads a negative LIMIT as none; PostgreSQL's LIMIT NULL is that.
      const std::string sql = std::string("SELECT ") + kVersionColumns +
                              " FROM versions v WHERE v.scene_id = $1 AND v.version > $2 "
                              "ORDER BY v.version LIMIT $3";
      Rows r = c.exec(sql.c_str(), {Param::text(id), Param::int8(after),
                                    limit < 0 ? Param::null(kInt8Oid) : Param::int8(limit)});
      if (!r.ok()) return c.failure(r, "cannot list versions of '" + id + "'");
      std::vector<SceneVersion> out;
      for (int i = 0; i < r.size(); ++i) out.push_back(row_version(r, i));
      return out;
    });
  }

  StoreResult<bool> put_blob(const Blob& b) override {
    // Idempotent, so retried like a read even when the first attempt may have committed.
    return run([&](Connection& c) -> StoreResult<bool> {
      Rows r = c.exec(
          "INSERT INTO blobs (hash, media_type, bytes) VALUES ($1, $2, $3) "
          "ON CONFLICT (hash) DO NOTHING",
          {Param::text(b.hash), Param::text(b.media_type), Param::bytes(b.bytes)});
      if (!r.ok()) return c.failure(r, "cannot store blob " + b.hash);
      return true;
    });
  }

  StoreResult<Blob> blob(const std::string& hash) override {
    return run([&](Connection& c) -> StoreResult<Blob> {
      Rows r = c.exec("SELECT hash, media_type, bytes FROM blobs WHERE hash = $1",
                      {Param::text(hash)}, true);
      if (!r.ok()) return c.failure(r, "cannot read blob " + hash);
      if (r.size() == 0) return StoreError{Kind::not_found, "no blob " + hash};
      return Blob{r.text(0, 0), r.text(0, 1), r.bytes(0, 2)};
    });
  }

  StoreResult<bool> put_baked_grid(const std::string& key, const std::vector<std::uint8_t>& bytes,
                                   std::int64_t max_total_bytes) override {
    const auto size = static_cast<std::int64_t>(bytes.size());
    if (size > max_total_bytes) return false;
    // Idempotent (and the trim with it), so retried like a read.
    return run([&](Connection& c) -> StoreResult<bool> {
      Rows put = c.exec(
          "INSERT INTO baked_grids (key, size, bytes, created_ms) VALUES ($1, $2, $3, $4) "
          "ON CONFLICT (key) DO NOTHING",
          {Param::text(key), Param::int8(size), Param::bytes(bytes), Param::int8(now_ms())});
      if (!put.ok()) return c.failure(put, "cannot store baked grid " + key);
      // The newest kept first; the oldest (ties by key) beyond the bound dropped.
      Rows evict = c.exec(
          "DELETE FROM baked_grids WHERE key IN (SELECT key FROM (SELECT key, SUM(size) OVER "
          "(ORDER BY created_ms DESC, key DESC) AS running FROM baked_grids) AS newest "
          "WHERE running > $1)",
          {Param::int8(max_total_bytes)});
      if (!evict.ok()) return c.failure(evict, "cannot trim the baked grids");
      return true;
    });
  }

  StoreResult<std::vector<std::uint8_t>> baked_grid(const std::string& key) override {
    return run([&](Connection& c) -> StoreResult<std::vector<std::uint8_t>> {
      Rows r = c.exec("SELECT bytes FROM baked_grids WHERE key = $1", {Param::text(key)}, true);
      if (!r.ok()) return c.failure(r, "cannot read baked grid " + key);
      if (r.size() == 0) return StoreError{Kind::not_found, "no baked grid " + key};
      return r.bytes(0, 0);
    });
  }

  StoreResult<PlanetPut> put_planet(const StoredPlanet& planet) override {
    if (planet.id.empty() || planet.canonical_json.empty()) {
      return StoreError{Kind::conflict, "a planet needs an id and a body"};
    }
    return run([&](Connection& c) -> StoreResult<PlanetPut> {
      StoredPlanet stored = planet;
      stored.created_ms = now_ms();
      // One statement decides who stores it: a concurrent insert of the same id makes this one
      // wait for its outcome and then do nothing. Idempotent, so retried like a read.
      Rows inserted = c.exec(
          "INSERT INTO planets (id, body, created_ms) VALUES ($1, $2, $3) "
          "ON CONFLICT (id) DO NOTHING RETURNING id",
          {Param::text(stored.id), Param::text(stored.canonical_json),
           Param::int8(stored.created_ms)});
      if (!inserted.ok()) return c.failure(inserted, "cannot store planet " + planet.id);
      if (inserted.size() == 1) return PlanetPut{std::move(stored), true};
      StoreResult<StoredPlanet> existing = read_planet(c, planet.id);
      if (!existing) return existing.error();
      if (existing->canonical_json != planet.canonical_json) {
        return StoreError{Kind::conflict,
                          "planet " + planet.id + " is stored with another definition"};
      }
      return PlanetPut{std::move(existing).value(), false};
    });
  }

  StoreResult<StoredPlanet> get_planet(const std::string& id) override {
    return run([&](Connection& c) { return read_planet(c, id); });
  }

  StoreResult<std::vector<StoredPlanet>> list_planets() override {
    return run([](Connection& c) -> StoreResult<std::vector<StoredPlanet>> {
      Rows r =
          c.exec("SELECT id, body, created_ms FROM planets ORDER BY created_ms, id COLLATE \"C\"");
      if (!r.ok()) return c.failure(r, "cannot list planets");
      std::vector<StoredPlanet> out;
      for (int i = 0; i < r.size(); ++i) {
        out.push_back({r.text(i, 0), r.text(i, 1), r.integer(i, 2)});
      }
      return out;
    });
  }

  StoreResult<bool> empty() override {
    return run([](Connection& c) -> StoreResult<bool> {
      Rows r = c.exec("SELECT EXISTS (SELECT 1 FROM scenes)");
      if (!r.ok() || r.size() != 1) return c.failure(r, "cannot count scenes");
      return r.text(0, 0) == "f";
    });
  }

 private:
  // Runs one call on a pooled connection. When the connection turns out to be dead and it had
  // served earlier calls (the server restarted since), the call runs once more on a fresh one,
  // unless a write may already have committed: then the caller gets `unavailable` and decides.
  // A call that fails on a fresh connection fails: the server is down, and callers retry later.
  template <class Op>
  auto run(Op&& op) -> decltype(op(std::declval<Connection&>())) {
    for (int attempt = 0;; ++attempt) {
      StoreResult<Lease> lease = pool_.acquire();
      if (!lease) return lease.error();
      auto result = op(lease->conn());
      if (result.ok() || !lease->conn().lost()) return result;
      pool_.drop_idle();
      if (attempt > 0 || !lease->reused() || lease->conn().commit_sent()) return result;
    }
  }

  static StoreResult<bool> insert_version(Connection& c, const SceneVersion& v) {
    Rows r = c.exec(
        "INSERT INTO versions (scene_id, version, hash, name, body, author, created_ms, ops) "
        "VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
        {Param::text(v.scene_id), Param::int8(v.version), Param::text(v.hash), Param::text(v.name),
         Param::text(v.canonical_json), Param::text(v.author), Param::int8(v.created_ms),
         v.ops_json.empty() ? Param::null(kTextOid) : Param::text(v.ops_json)});
    if (!r.ok()) return c.failure(r, "cannot store a version of '" + v.scene_id + "'");
    return true;
  }

  static StoreResult<StoredPlanet> read_planet(Connection& c, const std::string& id) {
    Rows r = c.exec("SELECT id, body, created_ms FROM planets WHERE id = $1", {Param::text(id)});
    if (!r.ok()) return c.failure(r, "cannot read planet " + id);
    if (r.size() == 0) return StoreError{Kind::not_found, "no planet " + id};
    return StoredPlanet{r.text(0, 0), r.text(0, 1), r.integer(0, 2)};
  }

  StoreResult<SceneVersion> one_version(const std::string& sql, const std::vector<Param>& params,
                                        const std::string& missing) {
    return run([&](Connection& c) -> StoreResult<SceneVersion> {
      Rows r = c.exec(sql.c_str(), params);
      if (!r.ok()) return c.failure(r, "cannot read a version");
      if (r.size() == 0) return StoreError{Kind::not_found, missing};
      return row_version(r, 0);
    });
  }

  Pool pool_;
};

}  // namespace

StoreResult<std::unique_ptr<Store>> open_postgres_store(const PostgresOptions& options) {
  // A malformed string is a configuration error: say so rather than "cannot connect".
  char* parse_error = nullptr;
  PQconninfoOption* parsed = PQconninfoParse(options.conninfo.c_str(), &parse_error);
  if (parsed == nullptr) {
    std::string why = parse_error != nullptr ? one_line(parse_error) : "out of memory";
    PQfreemem(parse_error);
    return StoreError{Kind::unavailable, "store.postgres_url: " + why};
  }
  PQconninfoFree(parsed);
  if (options.pool_size < 1) {
    return StoreError{Kind::unavailable, "the PostgreSQL pool needs at least one connection"};
  }
  auto store = std::make_unique<PostgresStore>(options);
  StoreResult<bool> migrated = store->migrate();
  if (!migrated) return migrated.error();
  return std::unique_ptr<Store>(std::move(store));
}

}  // namespace server
