// The choice of store backend, in one place for main() and the tests.
#include "server/store.hpp"

#include "server/config.hpp"
#include "server/postgres_store.hpp"

namespace server {

StoreResult<std::unique_ptr<Store>> open_store(const Config& config) {
  switch (config.store_backend) {
    case StoreBackend::sqlite:
      return open_sqlite_store(config.data_dir);
    case StoreBackend::postgres: {
      PostgresOptions options;
      options.conninfo = config.postgres_url;
      options.pool_size = config.postgres_pool_size;
      return open_postgres_store(options);
    }
  }
  return StoreError{StoreError::Kind::unavailable, "unknown store backend"};
}

}  // namespace server
