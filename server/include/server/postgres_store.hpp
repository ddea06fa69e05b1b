// The PostgreSQL store: the same Store contract as SQLite, shared by every replica of a cluster.
// A version is one transaction that locks its scene's row, so writers in several processes get
// distinct consecutive versions; the schema migrates under an advisory lock at open.
#pragma once

#include <memory>
#include <string>

#include "server/store.hpp"

namespace server {

/// How the PostgreSQL store connects, how many connections it keeps and how long it waits.
struct PostgresOptions {
  std::string conninfo;       ///< libpq connection string or URI (postgresql://user@host:port/db)
  int pool_size = 8;          ///< connections open at most; callers beyond wait for one
  int connect_timeout_s = 5;  ///< libpq connect_timeout (a URI parameter overrides it)
  int statement_timeout_ms = 15'000;  ///< server-side bound on one statement
  int lock_timeout_ms = 10'000;       ///< bound on waiting for a scene's row lock
  int acquire_timeout_ms = 15'000;    ///< wait for a free pooled connection before unavailable
  int reconnect_backoff_ms = 250;     ///< after a failed connect, fail at once for this long
};

/// Connects, applies pending schema migrations (one transaction under an advisory lock, so
/// replicas starting together migrate once) and returns the store; unavailable when PostgreSQL
/// cannot be reached or the connection string is malformed.
StoreResult<std::unique_ptr<Store>> open_postgres_store(const PostgresOptions& options);

}  // namespace server
