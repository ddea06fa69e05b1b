// Server configuration: built-in defaults, then config/server.toml (or --config FILE), then
// TERRAIN_* environment variables, then command-line flags. One table of options drives all
// four sources and --help, so an option is declared once.
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "terrain/result.hpp"

namespace server {

using terrain::Error;
using terrain::Result;

/// Which evaluator generates tiles (wired by the GPU backend).
enum class Backend { automatic, gpu, cpu };

/// Where scenes, versions, images and planets are stored (docs/server.md, "Storage backends").
enum class StoreBackend { sqlite, postgres };

struct Config {
  // network
  std::string address = "127.0.0.1";
  int port = 8080;
  int io_threads = 0;                     ///< 0 = one per core
  std::vector<std::string> cors_origins;  ///< "*" allows any origin; empty = no CORS headers
  /// Connections served at once; more are answered 503 and closed (also kept under the
  /// descriptor limit).
  int max_connections = 4096;
  /// "https://tiles.example.com": the base of absolute URLs in TileJSON; empty = from a
  /// validated Host header.
  std::string public_url;
  int shutdown_timeout_ms = 5'000;  ///< SIGTERM: connections still open then are closed
  // work
  int generation_threads = 0;  ///< 0 = one per core
  int queue_limit = 64;        ///< requests waiting for a generation thread before 503
  double max_cost = 5.0e7;     ///< samples × program cost a request may ask for (else 422)
  /// Pictures: pixels × picture_steps_per_pixel × program cost (else 422). Their own limit, as
  /// a traced step is a scalar evaluation with its bounds, and pictures run apart from tiles.
  double max_picture_cost = 2.0e9;
  int picture_threads = 0;       ///< render.png / depth.bin, lowest CPU priority (0 = per core)
  int picture_queue_limit = 16;  ///< pictures waiting or rendering before 503
  /// Sphere-tracing steps a picture may take per pixel, on average: its cost estimate and the
  /// bound on its work.
  int picture_steps_per_pixel = 64;
  Backend backend = Backend::automatic;
  // caches
  std::int64_t cache_bytes = 256ll << 20;       ///< in-memory LRU budget
  std::int64_t bake_cache_bytes = 256ll << 20;  ///< erosion grids kept by content hash
  std::int64_t store_bake_bytes = 1ll << 30;    ///< baked grids kept in the store (0 = none)
  /// Cell-steps all the erosion nodes of one scene may run (terrain::erosion_work), checked
  /// before any runs: the default takes about 8 s of one core at 2048².
  std::int64_t erosion_work = std::int64_t{1} << 24;
  std::string disk_cache_dir;  ///< empty = no on-disk cache
  std::int64_t disk_cache_bytes = 2ll << 30;
  std::string redis_url;  ///< shared product cache ("redis://host:port"); empty = none
  int redis_ttl_seconds = 7 * 24 * 3600;  ///< entries expire after this long
  int redis_timeout_ms = 100;             ///< per command; a slower Redis counts as down
  // storage
  StoreBackend store_backend = StoreBackend::sqlite;
  std::string data_dir = "data";  ///< holds terrain.sqlite3
  std::string postgres_url;       ///< libpq connection string or URI (store_backend postgres)
  int postgres_pool_size = 8;     ///< connections to PostgreSQL one server keeps at most
  std::string scenes_dir = "config/scenes";    ///< built-in scenes loaded on first start
  std::string planets_dir = "config/planets";  ///< built-in planets; default.json is "default"
  std::string client_dir = "client_web";       ///< static files served at /
  std::string write_token;  ///< required (Bearer) on every write; empty = writes refused
  // limits
  int header_limit = 8 * 1024;
  std::int64_t scene_body_limit = 4ll << 20;
  std::int64_t image_body_limit = 32ll << 20;
  int header_timeout_ms = 10'000;
  int body_timeout_ms = 30'000;
  int request_timeout_ms = 60'000;
  int idle_timeout_ms = 60'000;
  /// Request bodies being received at once, all connections together, before 503.
  std::int64_t bodies_in_flight_bytes = 128ll << 20;
  /// Decoded pixels of all the images one scene uses (each distinct image once).
  std::int64_t scene_image_pixels = 64ll << 20;
  // live editing (docs/live.md)
  std::int64_t live_max_message_bytes = 1ll << 20;  ///< larger messages close with 1009
  int live_handshake_timeout_ms = 10'000;           ///< time to send `subscribe`
  int live_ping_interval_ms = 20'000;  ///< idle connections are pinged; twice this closes them
  std::int64_t live_queue_bytes = 4ll << 20;  ///< outgoing backlog before a slow reader is cut
  int live_queue_messages = 1024;
  double live_edits_per_second = 10.0;  ///< per connection, token bucket
  int live_edit_burst = 20;
  int live_max_subscribers = 256;  ///< per scene
  /// What one connection may send, frames and all: a token bucket refilled at this rate that
  /// holds one message's wire budget (2 × live_max_message_bytes + 16 KiB) or one second's worth.
  std::int64_t live_read_bytes_per_second = 1ll << 20;
  std::string live_redis_url;  ///< replicas hear each other's versions here; empty = one replica
  int live_sweep_ms = 2000;    ///< with live_redis_url: how often followed scenes' heads are read
  // logging
  std::string log_level = "info";    ///< error, warn, info, debug
  int log_requests_per_second = 50;  ///< request lines at info; beyond, one summary a second

  std::string config_file;  ///< the file that was read, if any
};

/// The outcome of reading the command line: a configuration, or a request for help text.
struct Startup {
  Config config;
  bool show_help = false;
};

/// Reads defaults, the TOML file (`--config FILE`, else `default_config_file` when it exists),
/// the environment and the flags, in that order. Errors name the option and where it came from.
Result<Startup> load_config(std::span<const std::string_view> args,
                            const std::map<std::string, std::string>& environment,
                            const std::string& default_config_file = "config/server.toml");

/// The --help text: every option with its flag, environment variable, TOML key, default, meaning.
std::string help_text();

/// The current process environment as a map (only TERRAIN_* variables are read).
std::map<std::string, std::string> process_environment();

std::string_view backend_name(Backend backend);

std::string_view store_backend_name(StoreBackend backend);

}  // namespace server
