#include "server/config.hpp"

#include "server/redis_cache.hpp"

#include <toml++/toml.h>

#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <limits>
#include <sstream>
#include <variant>

extern char** environ;

namespace server {
namespace {

using Member =
    std::variant<int Config::*, std::int64_t Config::*, double Config::*, std::string Config::*,
                 std::vector<std::string> Config::*, Backend Config::*, StoreBackend Config::*>;

struct Option {
  std::string_view key;   ///< "section.name" in the TOML file
  std::string_view flag;  ///< command-line flag, "" when the option has none
  std::string_view env;   ///< environment variable
  Member member;
  double min = 0.0;  ///< numbers only
  double max = 0.0;
  std::string_view help;
};

constexpr double kIntMax = std::numeric_limits<int>::max();
constexpr double kBig = 9.0e15;  // int64 options stay exactly representable as doubles

const std::vector<Option>& options() {
  static const std::vector<Option> table = {
      {"server.address", "--address", "TERRAIN_ADDRESS", &Config::address, 0, 0,
       "address to listen on"},
      {"server.port", "--port", "TERRAIN_PORT", &Config::port, 0, 65535,
       "TCP port (0 = any free port, printed at start)"},
      {"server.io_threads", "--io-threads", "TERRAIN_IO_THREADS", &Config::io_threads, 0, 1024,
       "threads running network I/O (0 = one per core)"},
      {"server.cors_origins", "--cors-origins", "TERRAIN_CORS_ORIGINS", &Config::cors_origins, 0, 0,
       "origins allowed by CORS, comma-separated in flags and environment (\"*\" = any)"},
      {"server.max_connections", "--max-connections", "TERRAIN_MAX_CONNECTIONS",
       &Config::max_connections, 1, 1e7,
       "connections served at once; more are answered 503 and closed"},
      {"server.public_url", "--public-url", "TERRAIN_PUBLIC_URL", &Config::public_url, 0, 0,
       "base of absolute URLs the server writes (TileJSON), e.g. https://tiles.example.com "
       "(empty = from the Host header, validated)"},
      {"server.shutdown_timeout_ms", "--shutdown-timeout-ms", "TERRAIN_SHUTDOWN_TIMEOUT_MS",
       &Config::shutdown_timeout_ms, 0, kIntMax,
       "on SIGTERM, how long in-flight requests may take before their connections are closed"},
      {"generation.threads", "--generation-threads", "TERRAIN_GENERATION_THREADS",
       &Config::generation_threads, 0, 1024, "threads generating tiles (0 = one per core)"},
      {"generation.queue_limit", "--queue-limit", "TERRAIN_QUEUE_LIMIT", &Config::queue_limit, 1,
       1e6, "requests waiting for a generation thread before 503"},
      {"generation.max_cost", "--max-cost", "TERRAIN_MAX_COST", &Config::max_cost, 1, 1e15,
       "largest estimated cost (samples x program cost) of one request before 422"},
      {"generation.max_picture_cost", "--max-picture-cost", "TERRAIN_MAX_PICTURE_COST",
       &Config::max_picture_cost, 1, 1e15,
       "largest cost of one picture (pixels x steps per pixel x program cost) before 422"},
      {"generation.picture_threads", "--picture-threads", "TERRAIN_PICTURE_THREADS",
       &Config::picture_threads, 0, 1024,
       "threads rendering pictures, at the lowest CPU priority (0 = one per core)"},
      {"generation.picture_queue_limit", "--picture-queue-limit", "TERRAIN_PICTURE_QUEUE_LIMIT",
       &Config::picture_queue_limit, 1, 1e6, "pictures waiting or rendering before 503"},
      {"generation.picture_steps_per_pixel", "--picture-steps-per-pixel",
       "TERRAIN_PICTURE_STEPS_PER_PIXEL", &Config::picture_steps_per_pixel, 1, 1 << 16,
       "sphere-tracing steps a picture may take per pixel on average (its cost and its bound)"},
      {"generation.backend", "--backend", "TERRAIN_BACKEND", &Config::backend, 0, 0,
       "evaluator: auto, gpu or cpu"},
      {"cache.memory_bytes", "--cache-bytes", "TERRAIN_CACHE_BYTES", &Config::cache_bytes, 0, kBig,
       "in-memory tile cache budget (suffixes K, M, G allowed)"},
      {"cache.bake_bytes", "--bake-cache-bytes", "TERRAIN_BAKE_CACHE_BYTES",
       &Config::bake_cache_bytes, 0, kBig,
       "erosion grids kept in memory by content hash, so a scene parsed again does not erode "
       "again"},
      {"cache.disk_dir", "--disk-cache-dir", "TERRAIN_DISK_CACHE_DIR", &Config::disk_cache_dir, 0,
       0, "directory of the on-disk tile cache (empty = none)"},
      {"cache.disk_bytes", "--disk-cache-bytes", "TERRAIN_DISK_CACHE_BYTES",
       &Config::disk_cache_bytes, 0, kBig, "on-disk tile cache budget"},
      {"cache.redis_url", "--redis-url", "TERRAIN_REDIS_URL", &Config::redis_url, 0, 0,
       "Redis shared by replicas as a product cache, redis://host:port (empty = none)"},
      {"cache.redis_ttl_seconds", "--redis-ttl-seconds", "TERRAIN_REDIS_TTL_SECONDS",
       &Config::redis_ttl_seconds, 1, kIntMax, "time to live of products stored in Redis"},
      {"cache.redis_timeout_ms", "--redis-timeout-ms", "TERRAIN_REDIS_TIMEOUT_MS",
       &Config::redis_timeout_ms, 1, 60000,
       "connect and command timeout of Redis (a slower Redis is skipped for a while)"},
      {"store.backend", "--store-backend", "TERRAIN_STORE_BACKEND", &Config::store_backend, 0, 0,
       "where scenes are stored: sqlite (in store.data_dir) or postgres (at store.postgres_url)"},
      {"store.data_dir", "--data-dir", "TERRAIN_DATA_DIR", &Config::data_dir, 0, 0,
       "directory of the SQLite store (terrain.sqlite3)"},
      {"store.postgres_url", "--postgres-url", "TERRAIN_POSTGRES_URL", &Config::postgres_url, 0, 0,
       "libpq connection string or URI of the PostgreSQL store "
       "(postgresql://user@host:5432/terrain)"},
      {"store.postgres_pool_size", "--postgres-pool-size", "TERRAIN_POSTGRES_POOL_SIZE",
       &Config::postgres_pool_size, 1, 1000, "connections to PostgreSQL one server keeps at most"},
      {"store.bake_bytes", "--store-bake-bytes", "TERRAIN_STORE_BAKE_BYTES",
       &Config::store_bake_bytes, 0, kBig,
       "baked erosion and drainage grids kept in the store, so that no replica or restart "
       "computes them again; the oldest go first (0 = none)"},
      {"store.scenes_dir", "--scenes-dir", "TERRAIN_SCENES_DIR", &Config::scenes_dir, 0, 0,
       "built-in example scenes loaded into an empty store"},
      {"store.planets_dir", "--planets-dir", "TERRAIN_PLANETS_DIR", &Config::planets_dir, 0, 0,
       "built-in planets stored at start; default.json is /api/v1/planets/default"},
      {"client.dir", "--client-dir", "TERRAIN_CLIENT_DIR", &Config::client_dir, 0, 0,
       "static browser client served at /"},
      {"auth.write_token", "--write-token", "TERRAIN_WRITE_TOKEN", &Config::write_token, 0, 0,
       "bearer token every write must carry (empty = writes refused)"},
      {"limits.header_bytes", "--header-limit", "TERRAIN_HEADER_LIMIT", &Config::header_limit, 1024,
       1 << 20, "largest request header"},
      {"limits.scene_body_bytes", "--scene-body-limit", "TERRAIN_SCENE_BODY_LIMIT",
       &Config::scene_body_limit, 1024, kBig, "largest scene JSON body"},
      {"limits.image_body_bytes", "--image-body-limit", "TERRAIN_IMAGE_BODY_LIMIT",
       &Config::image_body_limit, 1024, kBig, "largest uploaded image"},
      {"limits.header_timeout_ms", "--header-timeout-ms", "TERRAIN_HEADER_TIMEOUT_MS",
       &Config::header_timeout_ms, 1, kIntMax, "time to receive a request's header (else 408)"},
      {"limits.body_timeout_ms", "--body-timeout-ms", "TERRAIN_BODY_TIMEOUT_MS",
       &Config::body_timeout_ms, 1, kIntMax, "time to receive a request's body (else 408)"},
      {"limits.request_timeout_ms", "--request-timeout-ms", "TERRAIN_REQUEST_TIMEOUT_MS",
       &Config::request_timeout_ms, 1, kIntMax, "time to answer one request"},
      {"limits.idle_timeout_ms", "--idle-timeout-ms", "TERRAIN_IDLE_TIMEOUT_MS",
       &Config::idle_timeout_ms, 1, kIntMax, "keep-alive connection idle time"},
      {"limits.bodies_in_flight_bytes", "--bodies-in-flight-limit",
       "TERRAIN_BODIES_IN_FLIGHT_LIMIT", &Config::bodies_in_flight_bytes, 1024, kBig,
       "request body bytes being received at once, all connections together, before 503"},
      {"limits.scene_image_pixels", "--scene-image-pixels", "TERRAIN_SCENE_IMAGE_PIXELS",
       &Config::scene_image_pixels, 1, kBig,
       "decoded pixels of the distinct images one scene may use"},
      {"limits.erosion_work", "--erosion-work", "TERRAIN_EROSION_WORK", &Config::erosion_work, 0,
       kBig,
       "cell-steps the erosion nodes of one scene may run (resolution² × steps over their grids), "
       "else 422"},
      {"live.max_message_bytes", "--live-max-message-bytes", "TERRAIN_LIVE_MAX_MESSAGE_BYTES",
       &Config::live_max_message_bytes, 1024, kBig, "largest live message (else close 1009)"},
      {"live.handshake_timeout_ms", "--live-handshake-timeout-ms",
       "TERRAIN_LIVE_HANDSHAKE_TIMEOUT_MS", &Config::live_handshake_timeout_ms, 1, kIntMax,
       "time for a live client to subscribe"},
      {"live.ping_interval_ms", "--live-ping-interval-ms", "TERRAIN_LIVE_PING_INTERVAL_MS",
       &Config::live_ping_interval_ms, 10, kIntMax,
       "idle live connections are pinged this often and closed after twice as long"},
      {"live.queue_bytes", "--live-queue-bytes", "TERRAIN_LIVE_QUEUE_BYTES",
       &Config::live_queue_bytes, 1024, kBig, "outgoing backlog of one live connection"},
      {"live.queue_messages", "--live-queue-messages", "TERRAIN_LIVE_QUEUE_MESSAGES",
       &Config::live_queue_messages, 1, 1e9, "outgoing messages one live connection may owe"},
      {"live.edits_per_second", "--live-edits-per-second", "TERRAIN_LIVE_EDITS_PER_SECOND",
       &Config::live_edits_per_second, 0.001, 1e9, "sustained edit rate of one connection"},
      {"live.edit_burst", "--live-edit-burst", "TERRAIN_LIVE_EDIT_BURST", &Config::live_edit_burst,
       1, 1e9, "edits one connection may send at once"},
      {"live.max_subscribers", "--live-max-subscribers", "TERRAIN_LIVE_MAX_SUBSCRIBERS",
       &Config::live_max_subscribers, 1, 1e9, "live connections per scene"},
      {"live.read_bytes_per_second", "--live-read-bytes-per-second",
       "TERRAIN_LIVE_READ_BYTES_PER_SECOND", &Config::live_read_bytes_per_second, 1024, kBig,
       "what one live connection may send per second (frames and all), in bursts of one "
       "message's wire budget"},
      {"live.redis_url", "--live-redis-url", "TERRAIN_LIVE_REDIS_URL", &Config::live_redis_url, 0,
       0, "Redis whose pub/sub carries version events between replicas (empty = one replica)"},
      {"live.sweep_ms", "--live-sweep-ms", "TERRAIN_LIVE_SWEEP_MS", &Config::live_sweep_ms, 10,
       kIntMax, "with live.redis_url: how often followed scenes' heads are read from the store"},
      {"log.level", "--log-level", "TERRAIN_LOG_LEVEL", &Config::log_level, 0, 0,
       "error, warn, info or debug"},
      {"log.requests_per_second", "--log-requests-per-second", "TERRAIN_LOG_REQUESTS_PER_SECOND",
       &Config::log_requests_per_second, 0, kIntMax,
       "request lines logged at info per second; the rest are counted in one line a second"},
  };
  return table;
}

Error option_error(const Option& o, std::string_view where, const std::string& why) {
  return Error{std::string(where) + ": " + why, "/" + std::string(o.key)};
}

Result<double> parse_number(std::string_view text, bool allow_suffix) {
  double scale = 1.0;
  if (allow_suffix && !text.empty()) {
    const char last = text.back();
    if (last == 'K' || last == 'k') scale = 1024.0;
    if (last == 'M' || last == 'm') scale = 1024.0 * 1024.0;
    if (last == 'G' || last == 'g') scale = 1024.0 * 1024.0 * 1024.0;
    if (scale != 1.0) text.remove_suffix(1);
  }
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty()) {
    return Error{"'" + std::string(text) + "' is not a number", ""};
  }
  return value * scale;
}

std::vector<std::string> split_list(std::string_view text) {
  std::vector<std::string> items;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    std::string_view item =
        text.substr(start, comma == std::string_view::npos ? text.npos : comma - start);
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
    if (!item.empty()) items.emplace_back(item);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return items;
}

// Sets an option from text (flags, environment, or a TOML scalar rendered as text).
terrain::Status set_from_text(Config& config, const Option& o, std::string_view text,
                              std::string_view where) {
  struct Visitor {
    Config& config;
    const Option& o;
    std::string_view text;
    std::string_view where;

    terrain::Status number_into(double& out, bool integral, bool suffix) const {
      Result<double> v = parse_number(text, suffix);
      if (!v) return option_error(o, where, v.error().message);
      if (integral && *v != static_cast<double>(static_cast<std::int64_t>(*v))) {
        return option_error(o, where, "must be a whole number");
      }
      if (*v < o.min || *v > o.max) {
        std::ostringstream range;
        range << "must be between " << o.min << " and " << o.max;
        return option_error(o, where, range.str());
      }
      out = *v;
      return terrain::Ok{};
    }
    terrain::Status operator()(int Config::*m) const {
      double v = 0;
      if (terrain::Status s = number_into(v, true, false); !s) return s;
      config.*m = static_cast<int>(v);
      return terrain::Ok{};
    }
    terrain::Status operator()(std::int64_t Config::*m) const {
      double v = 0;
      if (terrain::Status s = number_into(v, true, true); !s) return s;
      config.*m = static_cast<std::int64_t>(v);
      return terrain::Ok{};
    }
    terrain::Status operator()(double Config::*m) const {
      return number_into(config.*m, false, false);
    }
    terrain::Status operator()(std::string Config::*m) const {
      config.*m = std::string(text);
      return terrain::Ok{};
    }
    terrain::Status operator()(std::vector<std::string> Config::*m) const {
      config.*m = split_list(text);
      return terrain::Ok{};
    }
    terrain::Status operator()(Backend Config::*m) const {
      for (Backend b : {Backend::automatic, Backend::gpu, Backend::cpu}) {
        if (backend_name(b) == text) {
          config.*m = b;
          return terrain::Ok{};
        }
      }
      return option_error(o, where, "'" + std::string(text) + "' is not auto, gpu or cpu");
    }
    terrain::Status operator()(StoreBackend Config::*m) const {
      for (StoreBackend b : {StoreBackend::sqlite, StoreBackend::postgres}) {
        if (store_backend_name(b) == text) {
          config.*m = b;
          return terrain::Ok{};
        }
      }
      return option_error(o, where, "'" + std::string(text) + "' is not sqlite or postgres");
    }
  };
  return std::visit(Visitor{config, o, text, where}, o.member);
}

std::string value_text(const Config& config, const Option& o) {
  return std::visit(
      [&](auto member) -> std::string {
        const auto& v = config.*member;
        using V = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<V, std::string>) {
          return v.empty() ? "\"\"" : v;
        } else if constexpr (std::is_same_v<V, std::vector<std::string>>) {
          std::string joined;
          for (const std::string& s : v) joined += (joined.empty() ? "" : ",") + s;
          return joined.empty() ? "\"\"" : joined;
        } else if constexpr (std::is_same_v<V, Backend>) {
          return std::string(backend_name(v));
        } else if constexpr (std::is_same_v<V, StoreBackend>) {
          return std::string(store_backend_name(v));
        } else {
          std::ostringstream out;
          out << v;
          return out.str();
        }
      },
      o.member);
}

terrain::Status apply_toml(Config& config, const std::string& path) {
  toml::table document;
  try {
    document = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    std::ostringstream where;
    where << path << ":" << e.source().begin.line << ":" << e.source().begin.column << ": "
          << e.description();
    return Error{where.str(), ""};
  }
  // Every key must be known: a misspelt option silently ignored is a misconfigured server.
  for (const auto& [section, node] : document) {
    const toml::table* table = node.as_table();
    if (table == nullptr) {
      return Error{path + ": '" + std::string(section.str()) + "' must be a [section]",
                   "/" + std::string(section.str())};
    }
    for (const auto& [name, value] : *table) {
      const std::string key = std::string(section.str()) + "." + std::string(name.str());
      const Option* option = nullptr;
      for (const Option& o : options()) {
        if (o.key == key) option = &o;
      }
      if (option == nullptr) return Error{path + ": unknown option '" + key + "'", "/" + key};
      std::string text;
      if (const toml::array* list = value.as_array()) {
        for (const toml::node& item : *list) {
          if (!item.is_string()) {
            return option_error(*option, path, "must be a list of strings");
          }
          text += (text.empty() ? "" : ",") + std::string(*item.value<std::string>());
        }
      } else if (value.is_string()) {
        text = *value.value<std::string>();
      } else if (value.is_integer()) {
        text = std::to_string(*value.value<std::int64_t>());
      } else if (value.is_floating_point()) {
        std::ostringstream out;
        out.precision(17);
        out << *value.value<double>();
        text = out.str();
      } else {
        return option_error(*option, path, "has an unsupported type");
      }
      if (terrain::Status s = set_from_text(config, *option, text, path); !s) return s;
    }
  }
  config.config_file = path;
  return terrain::Ok{};
}

}  // namespace

std::string_view backend_name(Backend backend) {
  switch (backend) {
    case Backend::automatic:
      return "auto";
    case Backend::gpu:
      return "gpu";
    case Backend::cpu:
      return "cpu";
  }
  return "auto";
}

std::string_view store_backend_name(StoreBackend backend) {
  switch (backend) {
    case StoreBackend::sqlite:
      return "sqlite";
    case StoreBackend::postgres:
      return "postgres";
  }
  return "sqlite";
}

Result<Startup> load_config(std::span<const std::string_view> args,
                            const std::map<std::string, std::string>& environment,
                            const std::string& default_config_file) {
  Startup startup;
  // The config file comes first, so find --config before anything else.
  std::string config_file;
  bool explicit_file = false;
  if (auto it = environment.find("TERRAIN_CONFIG"); it != environment.end()) {
    config_file = it->second;
    explicit_file = true;
  }
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") startup.show_help = true;
    if (args[i] == "--config") {
      if (i + 1 >= args.size()) return Error{"--config needs a file", "/config"};
      config_file = std::string(args[i + 1]);
      explicit_file = true;
    } else if (args[i].starts_with("--config=")) {
      config_file = std::string(args[i].substr(9));
      explicit_file = true;
    }
  }
  if (startup.show_help) return startup;
  if (!explicit_file) config_file = default_config_file;
  if (!config_file.empty()) {
    std::error_code ec;
    if (std::filesystem::exists(config_file, ec)) {
      if (terrain::Status s = apply_toml(startup.config, config_file); !s) return s.error();
    } else if (explicit_file) {
      return Error{"config file '" + config_file + "' does not exist", "/config"};
    }
  }
  for (const Option& o : options()) {
    if (auto it = environment.find(std::string(o.env)); it != environment.end()) {
      if (terrain::Status s = set_from_text(startup.config, o, it->second, o.env); !s) {
        return s.error();
      }
    }
  }
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string_view arg = args[i];
    if (arg == "--config") {
      ++i;
      continue;
    }
    if (arg.starts_with("--config=")) continue;
    std::string_view value;
    bool has_value = false;
    if (const std::size_t eq = arg.find('='); eq != std::string_view::npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
      has_value = true;
    }
    const Option* option = nullptr;
    for (const Option& o : options()) {
      if (!o.flag.empty() && o.flag == arg) option = &o;
    }
    if (option == nullptr) {
      return Error{"unknown argument '" + std::string(arg) + "' (see --help)", ""};
    }
    if (!has_value) {
      if (i + 1 >= args.size()) return option_error(*option, arg, "needs a value");
      value = args[++i];
    }
    if (terrain::Status s = set_from_text(startup.config, *option, value, arg); !s) {
      return s.error();
    }
  }
  const std::string& level = startup.config.log_level;
  if (level != "error" && level != "warn" && level != "info" && level != "debug") {
    return Error{"log level '" + level + "' is not error, warn, info or debug", "/log.level"};
  }
  if (RedisCache::Options redis; !startup.config.redis_url.empty() &&
                                 !RedisCache::parse_url(startup.config.redis_url, redis)) {
    return Error{"redis url '" + startup.config.redis_url + "' is not redis://host[:port]",
                 "/cache.redis_url"};
  }
  if (RedisCache::Options redis; !startup.config.live_redis_url.empty() &&
                                 !RedisCache::parse_url(startup.config.live_redis_url, redis)) {
    return Error{"redis url '" + startup.config.live_redis_url + "' is not redis://host[:port]",
                 "/live.redis_url"};
  }
  // An empty string would make libpq fall back on PG* variables and a local socket: a server
  // told to use PostgreSQL must be told which.
  if (startup.config.store_backend == StoreBackend::postgres &&
      startup.config.postgres_url.empty()) {
    return Error{"store.backend is postgres but no store.postgres_url is set",
                 "/store.postgres_url"};
  }
  return startup;
}

std::string help_text() {
  const Config defaults;
  std::ostringstream out;
  out << "terrain-server: procedural terrain tiles and meshes over HTTP\n\n"
         "Usage: terrain-server [--config FILE] [--OPTION VALUE | --OPTION=VALUE]...\n\n"
         "Each option is read, later sources winning, from: its default, the TOML file\n"
         "(--config FILE or TERRAIN_CONFIG, else config/server.toml when it exists; keys as\n"
         "[section] name), the environment variable, the flag.\n\n";
  for (const Option& o : options()) {
    out << "  " << o.flag << "  (" << o.env << ", [" << o.key.substr(0, o.key.find('.')) << "] "
        << o.key.substr(o.key.find('.') + 1) << ")\n      " << o.help
        << "; default: " << value_text(defaults, o) << "\n";
  }
  out << "  --config FILE  (TERRAIN_CONFIG)\n      the TOML configuration file\n"
      << "  --help\n      this text\n";
  return out.str();
}

std::map<std::string, std::string> process_environment() {
  std::map<std::string, std::string> env;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    std::string_view entry(*e);
    if (!entry.starts_with("TERRAIN_")) continue;
    const std::size_t eq = entry.find('=');
    if (eq == std::string_view::npos) continue;
    env.emplace(std::string(entry.substr(0, eq)), std::string(entry.substr(eq + 1)));
  }
  return env;
}

}  // namespace server
