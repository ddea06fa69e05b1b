// The request handler: routes of the v1 HTTP contract (../shared/ARCHITECTURE.md) as a function
// of the request. Cheap answers come back at once; tile generation comes back as Deferred work
// for the bounded generation pool. Thread-safe: sessions on any thread call handle().
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "planet/planet.hpp"
#include "server/cache.hpp"
#include "server/config.hpp"
#include "server/disk_cache.hpp"
#include "server/http.hpp"
#include "server/live.hpp"
#include "server/live_bus.hpp"
#include "server/metrics.hpp"
#include "server/redis_cache.hpp"
#include "server/scene_versions.hpp"
#include "server/static_files.hpp"
#include "server/store.hpp"
#include "server/thread_shards.hpp"
#include "terrain/image_io.hpp"
#include "terrain/scene_diff.hpp"
#include "terrain/tile_image.hpp"
#include "terrain/tile_source.hpp"

namespace server {

/// A stored planet with its definition parsed and its base mesh built, shared by every thread.
struct LoadedPlanet {
  StoredPlanet stored;
  std::shared_ptr<const planet::Planet> planet;
};

/// What the live protocol (docs/live.md) remembers of one connection.
struct LiveConnection {
  std::string scene;
  bool subscribed = false;
  bool can_edit = false;  ///< the upgrade request or `subscribe` carried the write token
  std::string author = "anonymous";
  double edit_tokens = 0.0;  ///< the edit rate limit's token bucket
  std::chrono::steady_clock::time_point refilled{};
  std::shared_ptr<LiveSubscriber> self;    ///< where replies and events go
  std::vector<std::int64_t> own_versions;  ///< versions this connection made (the latest ones)
};

class App {
 public:
  App(Config config, std::unique_ptr<Store> store);

  /// Routes one request. Never throws; errors are problem+json responses. The answer carries no
  /// CORS headers yet: whoever sends it adds them (add_cors), once, on the way out.
  Outcome handle(const Request& request);

  /// Loads the built-in example scenes (config.scenes_dir) when the store holds no scene yet;
  /// their images become stored blobs referenced by hash. Then seeds the planets.
  terrain::Status seed_examples();
  /// Stores the built-in planets (config.planets_dir/*.json; idempotent, as planets are keyed
  /// by their content hash) and makes default.json's the one the alias "default" names.
  terrain::Status seed_planets();
  /// The id "default" stands for ("" when there is no built-in default planet).
  std::string default_planet_id() const;

  const Config& config() const { return config_; }
  /// The evaluator chosen from generation.backend, and why (for the start-up log).
  const std::string& backend_reason() const { return backend_reason_; }
  Metrics& metrics() { return metrics_; }
  ProductCache& cache() { return cache_; }
  /// What a request may send as its body, decided by its header alone so that the session can
  /// refuse before reading a byte: the route's limit (0: the route takes no body), and whether
  /// the route is a write, whose token is then checked first.
  struct BodyPolicy {
    std::int64_t limit = 0;
    bool write = false;
  };
  BodyPolicy body_policy(http::verb method, std::string_view target) const;
  /// Checks a write's bearer token: result() == ok when allowed, else the 401/403 to send.
  Response authorize(const Request& request) const;

  /// The route label a request counts under in /metrics.
  static std::string_view route_label(const Request& request);
  /// Adds the CORS headers the configuration allows for this request's Origin: the session does,
  /// to every answer of a request it could read, and settle() does.
  void add_cors(const Request& request, Response& response) const;

  // Live editing (docs/live.md; app_live.cpp).
  /// True when a request's target is a scene's live channel.
  static bool is_live_target(std::string_view target);
  /// Checks a WebSocket upgrade to a live channel: the connection's state, or the response that
  /// refuses it (400 bad id, 404 unknown scene, 403 wrong token, 503 too many subscribers).
  terrain::Result<LiveConnection, Response> live_open(const Request& request);
  /// Handles one message of a live connection; replies go to connection.self.
  void live_message(LiveConnection& connection, std::string_view text);
  /// The connection ended: it leaves its scene's channel.
  void live_close(LiveConnection& connection);
  LiveHub& live() { return live_; }

 private:
  struct Target;
  /// What a route's pattern bound: the scene's or planet's ref, and the segments after it.
  struct RouteMatch {
    std::string ref;
    std::vector<std::string> rest;
  };
  /// One route of the table (app_routes.cpp): routing, /metrics labels and body limits all
  /// read it. A GET route answers HEAD too.
  struct Route {
    enum class Body { none, scene, image };  ///< the body limit: none, the scene's, the image's
    http::verb method;
    std::string_view pattern;  ///< "/api/v1/scenes/{ref}/tiles/{...}": literal segments, one
                               ///< {ref}, and {...} for one or more segments
    std::string_view label;    ///< what /metrics counts it as
    Body body;
    bool loads_version;  ///< a read of a scene version not loaded yet compiles it on the pool first
    Outcome (*handle)(App& app, const Request& request, const Target& target,
                      const RouteMatch& match);
    /// The pattern's segments, split once when the table is built.
    std::vector<std::string_view> parts = {};

    /// Whether the path's segments fit the pattern (no allocation: the hot path asks this).
    template <class Segment>
    bool fits(std::span<const Segment> segments) const;
    /// What the pattern binds in a path that fits it.
    std::optional<RouteMatch> match(std::span<const std::string> segments) const;
  };
  static const std::vector<Route>& routes();
  static Outcome scene_route(App& app, const Request& request, const Target& target,
                             const RouteMatch& match);
  static Outcome planet_route(App& app, const Request& request, const Target& target,
                              const RouteMatch& match);
  Outcome route(const Request& request, const Target& target);
  Response client_file(const Request& request, const Target& target) const;

  /// What the URL of an immutable tile or mesh came to once routed: the cache key of its bytes
  /// and the headers that the URL alone decides.
  struct ProductRoute {
    std::string cache_key;
    const char* cache_control;  ///< a static policy (detail::kImmutable, …)
    std::optional<terrain::Gray16Encoding> gray16;
  };
  struct TargetHash {
    using is_transparent = void;
    std::size_t operator()(std::string_view target) const noexcept {
      return std::hash<std::string_view>{}(target);
    }
  };
  /// Product routes by exact request target, per thread (no lock on the way of a cached tile).
  using ProductRoutes = std::unordered_map<std::string, ProductRoute, TargetHash, std::equal_to<>>;
  /// The answer to a GET or HEAD of an immutable product URL seen before whose bytes are in the
  /// memory cache, without parsing, resolving or building the cache key again; else nullopt, and
  /// the request takes the full route (which counts the cache miss).
  std::optional<Response> cached_product(const Request& request);
  /// Remembers a product URL whose answer depends on the target alone (not on Accept, say).
  void remember_product_route(const Request& request, ProductRoute route);
  Response list_scenes(const Request& request);
  Response create_scene(const Request& request, const Target& target);
  Response put_scene(const Request& request, const std::string& id);
  Response get_scene(const Request& request, const std::string& ref);
  Response versions(const Request& request, const std::string& id);
  Response upload_image(const Request& request);
  /// One product on its way through the caches to the generation pool (app_http.hpp).
  struct ProductJob;
  /// The product from the memory cache, the shared caches or `reuse`, else its making as Deferred
  /// work that keeps what it made in every cache: the one pipeline of tiles, meshes, pictures
  /// and trace bundles, of scenes and planets (app_products.cpp).
  Outcome serve_product(ProductJob job);
  Outcome scene_product(const Request& request, const std::string& ref,
                        const std::vector<std::string>& rest, const Target& target);
  /// What a picture request returns: the shaded picture, or its ray distances.
  enum class PictureProduct { png, depth };
  Outcome render(const Request& request, const LoadedVersion& loaded, const Target& target,
                 PictureProduct product);
  Outcome trace_bundle(const Request& request, const LoadedVersion& loaded, bool pinned);
  /// GET …/analysis.json: the scene's geomorphometry (app_analysis.cpp).
  Outcome scene_analysis(const Request& request, const LoadedVersion& loaded, const Target& target,
                         bool pinned);
  Response trace_glsl(const Request& request) const;
  Response material_glsl(const Request& request) const;
  Response node_types(const Request& request) const;
  bool token_matches(std::string_view given) const;  // constant time
  Response scene_changes(const Request& request, const std::string& id, const Target& target);

  /// Stores the next version of a scene and publishes its event to the live channel, whose
  /// lock the caller holds (so versions reach subscribers in order).
  StoreResult<SceneVersion> commit_version(const Request& context, LiveHub::Channel& channel,
                                           const std::string& id, SceneVersion next,
                                           std::optional<std::int64_t> expected_head);
  /// The `version` event of `current`, its changes counted from `previous`.
  nlohmann::json version_event(const Request& context, const SceneVersion& current,
                               const SceneVersion& previous);
  /// What differs between two versions' tiles (docs/live.md, `changed`).
  nlohmann::json changed_between(const LoadedVersion& before, const LoadedVersion& after);
  /// The comparison of two versions (computed once, kept for a while).
  std::shared_ptr<const terrain::SceneChange> scene_change(const LoadedVersion& before,
                                                           const LoadedVersion& after);
  /// The previous version's cached bytes of a tile, when the edit provably left the tile
  /// untouched (docs/tiles.md, "Which tiles an edit changes"); else null. `key` is the cache key
  /// less the version hash.
  std::shared_ptr<const CachedProduct> reuse_unchanged_tile(const LoadedVersion& current,
                                                            const std::string& key,
                                                            terrain::TileScheme scheme,
                                                            const terrain::TileAddress& address,
                                                            terrain::TileFormat format,
                                                            const terrain::ProductOptions& options);
  void live_subscribe(LiveConnection& connection, const nlohmann::json& message);
  /// Publishes version `version` of a scene on its channel (lock held), first the versions the
  /// channel has not published yet, read from the store (another replica made them). `event`
  /// may be null: it is then built from the store.
  void publish_version(const std::string& scene, LiveHub::Channel& channel, std::int64_t version,
                       std::shared_ptr<const std::string> event);
  /// A version event another replica published (the bus's thread).
  void on_remote_event(const std::string& scene, const std::string& event);
  /// Publishes what other replicas stored for the followed scenes (the sweep thread).
  void sweep_heads();
  void live_edit(LiveConnection& connection, const nlohmann::json& message);

  Response list_planets(const Request& request);
  Response create_planet(const Request& request);
  Response get_planet(const Request& request, const std::string& ref);
  Outcome planet_product(const Request& request, const std::string& ref,
                         const std::vector<std::string>& rest, const Target& target);
  /// The planet an id (or "default") names: 400 for a malformed id, 404 for an unknown one.
  terrain::Result<std::string, Response> planet_id_of(const Request& request,
                                                      const std::string& ref);
  terrain::Result<LoadedPlanet, Response> resolve_planet(const Request& request,
                                                         const std::string& ref);

  /// How a scene text is read: as new input (every limit of today), as a version stored
  /// already, which was valid when it was written and must stay readable (limits added since,
  /// such as the name's length, are not applied to it), or as new input only validated and
  /// canonicalised, its grids (erosion) not baked: a built-in scene being stored (its first load
  /// bakes it), a body before its canonical form is compiled.
  enum class SceneSource { input, stored, unbaked };
  terrain::Result<LoadedVersion, Response> resolve(const Request& request, const std::string& ref);
  /// The scheme and authority absolute URLs start with: server.public_url when set, else
  /// "http://" and the request's Host once validated (400 naming /headers/host otherwise).
  terrain::Result<std::string, Response> public_origin(const Request& request) const;
  /// `work` as Deferred work for the generation pool: what parses, compiles and stores a scene
  /// stays off the I/O threads.
  Outcome off_io_thread(const Request& request, std::function<Response(const Request&)> work);
  /// A scene's text parsed (images decoded once per hash, within limits.scene_image_pixels) and
  /// compiled; the version is left for the caller to fill in.
  terrain::Result<LoadedVersion, terrain::Error> compile_scene(
      const std::string& text, SceneSource source = SceneSource::input);
  /// A request body's scene checked as it will be read back: its canonical form compiled.
  terrain::Result<LoadedVersion, Response> compile_for_storing(const Request& request);
  /// Gives the bake cache the disk cache, Redis (when configured) and the store (unless
  /// store.bake_bytes is 0) as shared stores of grids.
  void share_baked_grids();
  /// An uploaded image decoded, shared by every scene and version that uses it (bounded).
  terrain::Result<std::shared_ptr<const terrain::Raster>> decoded_image(const std::string& hash);
  terrain::Result<LoadedVersion, Response> load_version(const Request& request,
                                                        const SceneVersion& version);
  terrain::Result<std::shared_ptr<const terrain::Scene>, terrain::Error> parse_stored(
      const std::string& json, SceneSource source = SceneSource::input);

  Config config_;
  std::unique_ptr<Store> store_;
  Metrics metrics_;
  ProductCache cache_;
  /// Erosion grids by the content hash of what made them: a version parsed again (stored, then
  /// loaded; edited elsewhere) does not erode again.
  terrain::BakeCache bake_cache_;
  std::unique_ptr<DiskCache> disk_cache_;  ///< null unless cache.disk_dir is set
  std::unique_ptr<RedisCache> redis_;      ///< null unless cache.redis_url is set
  /// A product from the caches behind the in-memory LRU (disk, then Redis), copied into the
  /// faster ones; null when none has it.
  std::shared_ptr<const CachedProduct> find_shared(const std::string& key);
  /// Stores a new product in the caches behind the in-memory LRU.
  void store_shared(const std::string& key, const CachedProduct& product);
  /// The Redis lines of /metrics.
  std::string cache_metrics() const;
  StaticFiles client_;
  std::shared_ptr<terrain::PointsBackend> backend_;  ///< null: the CPU
  std::string backend_reason_;
  std::mutex images_mutex_;
  std::unordered_map<std::string, std::shared_ptr<const terrain::Raster>> decoded_;  // by hash
  std::int64_t decoded_pixels_ = 0;  ///< in decoded_
  /// Scene refs resolved to compiled versions (stored ones read as SceneSource::stored).
  SceneVersions versions_;

  ThreadShards<ProductRoutes> product_routes_;

  LiveHub live_;
  std::mutex changes_mutex_;
  // Comparisons of versions by "<before hash>><after hash>" (bounded).
  std::unordered_map<std::string, std::shared_ptr<const terrain::SceneChange>> changes_;

  mutable std::mutex planets_mutex_;
  std::unordered_map<std::string, LoadedPlanet> planets_;  // by id (bounded; ids never go stale)
  std::string default_planet_id_;

  // Last, so that they stop first: they call into the members above.
  std::unique_ptr<LiveBus> bus_;  ///< null unless live.redis_url is set
  std::jthread sweeper_;          ///< reads followed scenes' heads (with a bus)
};

/// Handles a request to its answer on the calling thread, deferred work included, CORS added
/// (what the session does across its threads): for tests and tools.
Response settle(App& app, const Request& request);

}  // namespace server
