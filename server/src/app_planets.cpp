// Planets: definitions stored by content hash, their products on the geographic and Web Mercator
// tilings.
#include "server/app.hpp"

#include "app_http.hpp"
#include "app_support.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <charconv>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "planet/continent_map.hpp"
#include "planet/definition.hpp"
#include "planet/tiles.hpp"
#include "server/log.hpp"
#include "terrain/gzip.hpp"
#include "terrain/image_io.hpp"
#include "terrain/json_text.hpp"
#include "terrain/tile_products.hpp"

namespace server {

namespace fs = std::filesystem;
using json = nlohmann::json;
using terrain::Error;
using namespace detail;  // NOLINT: the App's own helpers (app_support.hpp, app_http.hpp)

namespace {

// Built planets kept in memory (each holds its base mesh, a few MiB), and per generation thread
// the PlanetTiles and Samplers that cache refined triangles (up to ~200 MiB each when deep tiles
// are asked for, trimmed beyond that), so fewer of those.
constexpr std::size_t kLoadedPlanets = 16;
constexpr std::size_t kPlanetWorkersPerThread = 4;

}  // namespace

namespace {

bool valid_planet_id(std::string_view id) {
  return id.size() == 64 && std::all_of(id.begin(), id.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
         });
}

json planet_summary(const StoredPlanet& p, bool is_default) {
  return {{"id", p.id},
          {"url", "/api/v1/planets/" + p.id},
          {"created_ms", p.created_ms},
          {"default", is_default},
          {"definition", detail::parse_bounded_json(p.canonical_json)}};
}

// The continent map a definition names, looked up in the store by its hash and decoded: the only
// way a definition reaches an image, so it can never make the server read a file or fetch a URL.
struct MapLookup {
  enum class Failure { none, unknown, unavailable, invalid };
  Failure failure = Failure::none;
  std::string message;
  std::optional<planet::ContinentMap> map;  ///< empty when the definition names none
};

MapLookup load_continent_map(Store& store, const planet::PlanetDefinition& definition) {
  MapLookup out;
  if (definition.continent_map.empty()) return out;
  StoreResult<Blob> blob = store.blob(definition.continent_map);
  if (!blob) {
    const bool missing = blob.error().kind == StoreError::Kind::not_found;
    out.failure = missing ? MapLookup::Failure::unknown : MapLookup::Failure::unavailable;
    out.message = missing ? "no uploaded image has the hash " + definition.continent_map +
                                " (upload it with POST /api/v1/images first)"
                          : blob.error().message;
    return out;
  }
  planet::Result<planet::ContinentMap> map = planet::decode_continent_map(blob->bytes);
  if (!map) {
    out.failure = MapLookup::Failure::invalid;
    out.message = map.error().message;
    return out;
  }
  out.map = std::move(map).value();
  return out;
}

}  // namespace

terrain::Status App::seed_planets() {
  std::error_code ec;
  // No directory, no built-in planets: the API still stores posted ones; "default" is a 404.
  if (!fs::is_directory(config_.planets_dir, ec)) return terrain::Ok{};
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(config_.planets_dir, ec)) {
    if (entry.path().extension() == ".json") files.push_back(entry.path());
  }
  if (ec) return Error{"cannot read " + config_.planets_dir + ": " + ec.message(), ""};
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    Result<planet::PlanetDefinition> definition = planet::load_planet_file(file.string());
    if (!definition) {
      return Error{file.string() + ": " + definition.error().message, definition.error().pointer};
    }
    // Stored on every start, not only the first: put_planet is idempotent, and a changed
    // default.json is a new planet (a new id) that the alias must find in the store.
    // A built-in planet may name a continent map only once the image is in the store: refusing
    // to start beats serving a planet whose every product fails.
    if (MapLookup lookup = load_continent_map(*store_, *definition);
        lookup.failure != MapLookup::Failure::none) {
      return Error{file.string() + ": " + lookup.message, "/continent_map"};
    }
    const StoredPlanet planet{planet::planet_id(*definition), planet::canonical_text(*definition),
                              0};
    StoreResult<PlanetPut> put = store_->put_planet(planet);
    if (!put) return Error{file.string() + ": " + put.error().message, ""};
    if (file.stem() == "default") {
      std::lock_guard lock(planets_mutex_);
      default_planet_id_ = planet.id;
    }
  }
  return terrain::Ok{};
}

std::string App::default_planet_id() const {
  std::lock_guard lock(planets_mutex_);
  return default_planet_id_;
}

// The planet id a ref names ("default" is the built-in planet), or the problem saying why none.
terrain::Result<std::string, Response> App::planet_id_of(const Request& request,
                                                         const std::string& ref) {
  const std::string id = ref == "default" ? default_planet_id() : ref;
  if (id.empty()) {
    return problem(request, http::status::not_found, "Not found",
                   "this server has no built-in default planet (store.planets_dir/default.json)",
                   "/id");
  }
  if (!valid_planet_id(id)) {
    return problem(request, http::status::bad_request, "Bad planet id",
                   "a planet id is the 64 lowercase hex digits of its definition's SHA-256, or "
                   "'default'",
                   "/id");
  }
  return id;
}

terrain::Result<LoadedPlanet, Response> App::resolve_planet(const Request& request,
                                                            const std::string& ref) {
  auto id_or = planet_id_of(request, ref);
  if (!id_or) return id_or.error();
  const std::string id = std::move(id_or).value();
  {
    std::lock_guard lock(planets_mutex_);
    if (auto it = planets_.find(id); it != planets_.end()) return it->second;
  }
  StoreResult<StoredPlanet> stored = store_->get_planet(id);
  if (!stored) return store_problem(request, stored.error());
  // Building the base mesh takes milliseconds, once per planet and process; two first requests
  // at once may both build it, which costs time but changes nothing (the build is a pure
  // function of the definition).
  Result<planet::PlanetDefinition> definition = planet::parse_planet_text(stored->canonical_json);
  if (!definition) {
    return problem(request, http::status::internal_server_error, "Stored planet unreadable",
                   definition.error().message, definition.error().pointer);
  }
  // The map is looked up again after a restart: the store keeps images as it keeps planets.
  MapLookup lookup = load_continent_map(*store_, *definition);
  if (lookup.failure == MapLookup::Failure::unavailable) {
    return store_problem(request, StoreError{StoreError::Kind::unavailable, lookup.message});
  }
  if (lookup.failure != MapLookup::Failure::none) {
    return problem(request, http::status::internal_server_error, "Stored planet unreadable",
                   lookup.message, "/continent_map");
  }
  Result<std::shared_ptr<const planet::Planet>> built =
      planet::Planet::build(*definition, lookup.map ? &*lookup.map : nullptr);
  if (!built) {
    return problem(request, http::status::internal_server_error, "Stored planet unreadable",
                   built.error().message, built.error().pointer);
  }
  LoadedPlanet loaded{std::move(stored).value(), std::move(built).value()};
  std::lock_guard lock(planets_mutex_);
  if (planets_.size() >= kLoadedPlanets) planets_.clear();
  planets_.emplace(id, loaded);
  return loaded;
}

Response App::list_planets(const Request& request) {
  StoreResult<std::vector<StoredPlanet>> planets = store_->list_planets();
  if (!planets) return store_problem(request, planets.error());
  const std::string fallback = default_planet_id();
  json list = json::array();
  for (const StoredPlanet& p : *planets) list.push_back(planet_summary(p, p.id == fallback));
  Response r = json_response(
      request, http::status::ok,
      {{"planets", list}, {"default", fallback.empty() ? json(nullptr) : json(fallback)}});
  r.set(http::field::cache_control, "no-cache");
  return r;
}

Response App::create_planet(const Request& request) {
  if (Response auth = authorize(request); auth.result() != http::status::ok) return auth;
  // The same validation as Planet::from_json, without building the base mesh on this I/O
  // thread: the first product request builds it.
  Result<planet::PlanetDefinition> definition = planet::parse_planet_text(request.body());
  if (!definition) {
    return problem(request, http::status::bad_request, "Invalid planet", definition.error().message,
                   definition.error().pointer);
  }
  // A continent map must be an uploaded image that decodes as one now, so that a stored planet
  // can always be built. Decoding it here costs what the image upload's own check cost.
  if (MapLookup lookup = load_continent_map(*store_, *definition);
      lookup.failure != MapLookup::Failure::none) {
    if (lookup.failure == MapLookup::Failure::unknown) {
      return problem(request, http::status::bad_request, "Unknown continent map", lookup.message,
                     "/continent_map");
    }
    if (lookup.failure == MapLookup::Failure::unavailable) {
      return store_problem(request, StoreError{StoreError::Kind::unavailable, lookup.message});
    }
    // An image, but not one a map can be (colour, wrong size or shape): well-formed request,
    // unusable content.
    return problem(request, http::status::unprocessable_entity, "Invalid continent map",
                   lookup.message, "/continent_map");
  }
  const StoredPlanet planet{planet::planet_id(*definition), planet::canonical_text(*definition), 0};
  StoreResult<PlanetPut> put = store_->put_planet(planet);
  if (!put) {
    if (put.error().kind == StoreError::Kind::conflict) {
      return problem(request, http::status::conflict, "Planet conflict", put.error().message);
    }
    return store_problem(request, put.error());
  }
  const std::string url = "/api/v1/planets/" + put->planet.id;
  Response r = json_response(request, put->created ? http::status::created : http::status::ok,
                             {{"id", put->planet.id},
                              {"url", url},
                              {"created_ms", put->planet.created_ms},
                              {"definition", planet::canonical_json(*definition)}});
  r.set(http::field::location, url);
  r.set(http::field::etag, quote(put->planet.id));
  return r;
}

Response App::get_planet(const Request& request, const std::string& ref) {
  auto id_or = planet_id_of(request, ref);
  if (!id_or) return id_or.error();
  const std::string id = std::move(id_or).value();
  StoreResult<StoredPlanet> stored = store_->get_planet(id);
  if (!stored) return store_problem(request, stored.error());
  // The id is the hash of exactly these bytes: the strongest ETag there is.
  const std::string etag = quote(id);
  // The canonical text is sent as stored (never re-serialised, never compressed: it is small
  // and its bytes are what the id hashes).
  Response r = make_response(request, http::status::ok, stored->canonical_json, "application/json");
  r.set(http::field::cache_control, ref == id ? kImmutable : kAliasCacheControl);
  if (ref != id) r.set(http::field::content_location, "/api/v1/planets/" + id);
  answer_conditionally(request, r, etag);
  return r;
}

Outcome App::planet_product(const Request& request, const std::string& ref,
                            const std::vector<std::string>& rest, const Target& target) {
  auto loaded_or = resolve_planet(request, ref);
  if (!loaded_or) return loaded_or.error();
  const LoadedPlanet loaded = std::move(loaded_or).value();
  const std::string id = loaded.stored.id;
  const std::shared_ptr<const planet::Planet> world = loaded.planet;
  // Products of an id are immutable (the id is a content hash); through the alias they are
  // revalidated now and then, since "default" may name another planet after a restart.
  const char* const cache_control = ref == id ? kImmutable : kAliasCacheControl;
  const std::string base = "/api/v1/planets/" + id;

  auto finish_json = [&](const json& body) {
    return json_text_response(request, body.dump(), cache_control);
  };
  auto geographic_only = [&]() -> std::optional<Response> {
    const std::string scheme = target.get("scheme", "geographic");
    if (scheme == "geographic") return std::nullopt;
    return problem(request, http::status::bad_request, "Bad scheme",
                   "planets are tiled in the geographic scheme (EPSG:4326, TMS) only", "/scheme");
  };

  if (rest.size() == 1 && rest[0] == "layer.json") {
    if (auto bad = geographic_only()) return *bad;
    terrain::LayerJsonOptions options;
    options.name = "planet " + id.substr(0, 12);
    options.description = "seeded planet " + id;
    options.version = "1.0.0";
    options.tiles = {base + "/mesh/{z}/{x}/{y}.terrain"};
    return finish_json(planet::PlanetTiles::layer_json(options));
  }
  if (rest.size() == 1 && rest[0] == "material.json") {
    // What the viewer's planet mode colours land and sea with, as colour tiles do: the material
    // packed as its evaluators read it (terrain::pack_material), the relief its heights are
    // fractions of, and the beach above the sea.
    const terrain::ProductConstants constants = planet::PlanetTiles::constants_for(*world, 0);
    const terrain::PackedMaterial packed = terrain::pack_material(constants.material);
    return finish_json(json{{"material", std::vector<float>(packed.begin(), packed.end())},
                            {"relief", {constants.relief.lo, constants.relief.hi}},
                            {"shore_band", constants.shore_band}});
  }
  if (rest.size() == 1 && rest[0] == "tilejson.json") {
    const std::string scheme = target.get("scheme", "geographic");
    if (scheme != "geographic" && scheme != "webmercator") {
      return problem(request, http::status::bad_request, "Bad scheme",
                     "planet TileJSON: scheme geographic (EPSG:4326 TMS, default) or webmercator "
                     "(EPSG:3857 XYZ, for MapLibre)",
                     "/scheme");
    }
    auto images = parse_tilejson_images(request, target.query);
    if (!images) return images.error();
    const std::string what = images->color ? "colour imagery" : "height tiles";
    auto origin_or = public_origin(request);
    if (!origin_or) return origin_or.error();
    const std::string origin = std::move(origin_or).value();
    if (scheme == "webmercator") {  // MapLibre's raster-dem sources are EPSG:3857 only
      const double limit =
          terrain::web_mercator_latitude(std::numbers::pi * terrain::kWebMercatorRadius);
      json body{{"tilejson", "3.0.0"},
                {"name", "planet " + id.substr(0, 12)},
                {"description", "Web Mercator (EPSG:3857) XYZ " + what + " of seeded planet " + id},
                {"version", "1.0.0"},
                {"scheme", "xyz"},
                {"tiles", {origin + base + images->tiles_path() + "&scheme=webmercator"}},
                {"minzoom", 0},
                {"maxzoom", terrain::max_zoom(terrain::TileScheme::webmercator)},
                {"tileSize", 256},
                {"bounds", {-180.0, -limit, 180.0, limit}},
                {"center", {20.0, 15.0, 2}}};
      images->describe(body);
      return finish_json(body);
    }
    // Geographic TMS tiles (EPSG:4326, two tiles at zoom 0, rows counted from the south): for
    // Cesium and GIS clients.
    json body{{"tilejson", "3.0.0"},
              {"name", "planet " + id.substr(0, 12)},
              {"description", "geographic (EPSG:4326) TMS " + what +
                                  ", two at zoom 0; for MapLibre ask for scheme=webmercator"},
              {"version", "1.0.0"},
              {"scheme", "tms"},
              {"crs", "EPSG:4326"},
              {"tiles", {origin + base + images->tiles_path()}},
              {"minzoom", 0},
              {"maxzoom", planet::PlanetTiles::max_zoom()},
              {"tileSize", 256},
              {"bounds", {-180.0, -90.0, 180.0, 90.0}},
              {"center", {0.0, 0.0, 1}}};
    images->describe(body);
    return finish_json(body);
  }

  const ReplyContext reply_base = ReplyContext::of(request, cache_control);
  if (rest.size() == 1 && rest[0] == "sample") {
    auto coordinate = [&](const char* key, double limit) -> std::optional<double> {
      const auto v = parse_double(target.get(key));
      if (!v || *v < -limit || *v > limit) return std::nullopt;
      return v;
    };
    const auto lat = coordinate("lat", 90.0), lon = coordinate("lon", 180.0);
    if (!lat) {
      return problem(request, http::status::bad_request, "Bad sample",
                     "lat must be a latitude in degrees, -90 to 90", "/lat");
    }
    if (!lon) {
      return problem(request, http::status::bad_request, "Bad sample",
                     "lon must be a longitude in degrees, -180 to 180", "/lon");
    }
    // lod: the spacing in metres of the samples whose level of detail to use (as a tile's);
    // absent or 0, full detail.
    const std::string lod_text = target.get("lod");
    const auto lod = lod_text.empty() ? std::optional<double>(0.0) : parse_double(lod_text);
    if (!lod || !(*lod >= 0.0 && *lod <= 1e7)) {
      return problem(request, http::status::bad_request, "Bad sample",
                     "lod must be a sample spacing in metres, 0 to 1e7", "/lod");
    }
    const double la = *lat, lo = *lon, spacing = *lod;
    Deferred deferred;
    deferred.cost = static_cast<double>(world->rules().max_level) + 40.0;
    deferred.work = [=, this]() -> Response {
      thread_local std::unordered_map<std::string, std::unique_ptr<planet::Sampler>> samplers;
      if (samplers.size() >= kPlanetWorkersPerThread && !samplers.contains(id)) samplers.clear();
      std::unique_ptr<planet::Sampler>& sampler = samplers[id];
      if (!sampler) sampler = std::make_unique<planet::Sampler>(world);
      const auto start = std::chrono::steady_clock::now();
      json body = planet::sample_json(
          la, lo, spacing > 0.0 ? sampler->sample(la, lo, spacing) : sampler->sample(la, lo));
      body["id"] = id;
      metrics_.generation(
          "planet_sample",
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), "cpu");
      return json_text_response(reply_base.shadow(), body.dump(), reply_base.cache_control);
    };
    return deferred;
  }

  // Tiles and meshes on the geographic tiling: /tiles/{z}/{x}/{y}.{png,tif},
  // /mesh/{z}/{x}/{y}.{terrain,glb,drc}; height images also on Web Mercator (?scheme=).
  if (rest.size() != 4 || (rest[0] != "tiles" && rest[0] != "mesh")) {
    return problem(request, http::status::not_found, "Not found",
                   "no product '" + (rest.empty() ? std::string() : rest[0]) + "' of a planet");
  }
  auto query = parse_tile_query(request, rest, target.query, true);
  if (!query) return query.error();
  if (terrain::Status valid = planet::PlanetTiles::validate(query->scheme, query->address,
                                                            query->format, query->options);
      !valid) {
    return problem(request, http::status::bad_request, "Bad tile request", valid.error().message,
                   valid.error().pointer);
  }
  // Cost: every sample (with the ring of neighbours the slopes use, and quantized-mesh's
  // 256² water mask) descends the mesh hierarchy to the tile's level and sums the visible
  // detail octaves (a Web Mercator tile's level is one coarser: the geographic one bounds it).
  const terrain::ProductOptions options = query->options;
  const int cells = query->mesh ? options.grid - 1 : options.size;
  const double spacing = world->ground_spacing(query->address.z, cells);
  const double per_sample = static_cast<double>(world->level_for_spacing(spacing)) +
                            std::ceil(world->octaves_for_spacing(spacing)) + 1.0;
  const double side = query->mesh ? options.grid + 2.0 : options.size + 2.0 * query->border + 2.0;
  const bool water_mask = query->format == terrain::TileFormat::quantized_mesh && options.watermask;
  const double samples = side * side + (water_mask ? 258.0 * 258.0 : 0.0);
  const double cost = samples * per_sample;
  if (cost > config_.max_cost) {
    return problem(request, http::status::unprocessable_entity, "Too costly",
                   "this product would cost " + std::to_string(static_cast<long long>(cost)) +
                       " (samples x (mesh levels + detail octaves)), above the limit of " +
                       std::to_string(static_cast<long long>(config_.max_cost)));
  }
  ProductJob job;
  // "planet:" keeps planet keys apart from scene keys (which start with "sha256:").
  job.key = "planet:" + id + query->key();
  job.reply = reply_base;
  if (query->format == terrain::TileFormat::gray16) {
    job.reply.gray16 = terrain::gray16_encoding_for(world->elevation_range());
  }
  job.reply.negotiated_by_accept = query->format == terrain::TileFormat::quantized_mesh;
  // An id's URL names the same bytes and headers forever (the alias may change at a restart);
  // quantized-mesh also depends on Accept.
  if (ref == id && query->format != terrain::TileFormat::quantized_mesh) {
    remember_product_route(request, {job.key, cache_control, job.reply.gray16});
  }
  job.cost = cost;
  const terrain::TileFormatInfo& info = terrain::format_info(query->format);
  job.metric = "planet_" + std::string(info.encoding.empty() ? info.extension : info.encoding);
  job.make = [id, world, q = *query, reply = job.reply](
                 const std::atomic<bool>&) -> terrain::Result<CachedProduct, Response> {
    // One PlanetTiles per planet and thread: it keeps refined triangles between tiles (the
    // bytes never depend on them), and is not thread-safe.
    thread_local std::unordered_map<std::string, std::unique_ptr<planet::PlanetTiles>> tilers;
    if (tilers.size() >= kPlanetWorkersPerThread && !tilers.contains(id)) tilers.clear();
    std::unique_ptr<planet::PlanetTiles>& tiles = tilers[id];
    if (!tiles) tiles = std::make_unique<planet::PlanetTiles>(world);
    Result<terrain::Product> product = tiles->make(q.scheme, q.address, q.format, q.options);
    if (!product) return problem(reply.shadow(), "Bad tile request", product.error());
    CachedProduct bytes = product_bytes(std::move(product).value());
    bytes.backend = "cpu";  // planets have no GPU path yet
    return bytes;
  };
  return serve_product(std::move(job));
}

}  // namespace server
