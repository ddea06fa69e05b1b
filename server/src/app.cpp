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

#include "gpu/backend.hpp"
#include "gpu/evaluator.hpp"
#include "gpu/program_glsl.hpp"
#include "planet/continent_map.hpp"
#include "planet/definition.hpp"
#include "planet/tiles.hpp"
#include "server/log.hpp"
#include "terrain/gzip.hpp"
#include "terrain/image_io.hpp"
#include "terrain/json_text.hpp"
#include "terrain/node.hpp"
#include "terrain/program.hpp"
#include "terrain/sphere_trace.hpp"
#include "terrain/tile_products.hpp"

namespace server {

std::string_view openapi_document();  // generated from server/resources/openapi.json

nlohmann::json detail::parse_bounded_json(std::string_view text) {
  terrain::Result<nlohmann::json> parsed = terrain::parse_json_text(text, "stored JSON");
  return parsed ? std::move(parsed).value() : nlohmann::json(nlohmann::json::value_t::discarded);
}

bool detail::valid_id(std::string_view id) {
  if (id.empty() || id.size() > 64) return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
  });
}

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using terrain::Error;

constexpr std::size_t kMakersPerThread = 8;  // per-thread product makers (evaluators)

}  // namespace

Response detail::make_response(const Request& request, http::status status, Payload body,
                               std::string_view media_type) {
  Response r{status, request.version()};
  r.set(http::field::server, "terrain-server");
  r.set(http::field::content_type, media_type);
  r.keep_alive(request.keep_alive());
  r.body() = std::move(body);
  r.prepare_payload();
  return r;
}

namespace {

using namespace detail;  // NOLINT: the App's own helpers (app_support.hpp, app_http.hpp)
using detail::make_response;

using detail::json_response;

using detail::parse_integer;

using detail::valid_id;

http::status store_status(const StoreError& e) {
  switch (e.kind) {
    case StoreError::Kind::not_found:
      return http::status::not_found;
    case StoreError::Kind::conflict:
      return http::status::precondition_failed;
    case StoreError::Kind::unavailable:
      return http::status::service_unavailable;
  }
  return http::status::internal_server_error;
}

using detail::cache_policy;
using detail::kAliasCacheControl;
using detail::kImmutable;
using detail::store_problem;

}  // namespace

bool detail::etag_matches(const Request& request, std::string_view etag) {
  return none_match_names(if_none_match(request), etag);
}

namespace {

using detail::etag_matches;

}  // namespace

std::string escape_invalid_utf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  std::size_t i = 0;
  while (i < text.size()) {
    const auto lead = static_cast<unsigned char>(text[i]);
    // The length of a well-formed sequence starting here (RFC 3629), or 0.
    std::size_t length = 0;
    if (lead < 0x80) {
      length = 1;
    } else if (lead >= 0xc2 && lead <= 0xf4) {
      length = lead < 0xe0 ? 2 : lead < 0xf0 ? 3 : 4;
      if (i + length > text.size()) length = 0;
      for (std::size_t k = 1; k < length; ++k) {
        if ((static_cast<unsigned char>(text[i + k]) & 0xc0) != 0x80) length = 0;
      }
      if (length >= 3) {
        const auto second = static_cast<unsigned char>(text[i + 1]);
        // Overlong forms, UTF-16 surrogates and code points above U+10FFFF.
        if ((lead == 0xe0 && second < 0xa0) || (lead == 0xed && second >= 0xa0) ||
            (lead == 0xf0 && second < 0x90) || (lead == 0xf4 && second >= 0x90)) {
          length = 0;
        }
      }
    }
    if (length == 0) {
      static constexpr char kHex[] = "0123456789ABCDEF";
      out += "\\x";
      out += kHex[lead >> 4];
      out += kHex[lead & 15];
      ++i;
    } else {
      out.append(text.substr(i, length));
      i += length;
    }
  }
  return out;
}

Response problem(const Request& request, http::status status, std::string_view title,
                 std::string_view detail, std::string_view pointer) {
  // Details echo what the client sent (a parser's message quotes the bad byte): bytes that are
  // not UTF-8 are written as \xHH so that the answer is JSON at all.
  json body{{"type", "about:blank"},
            {"title", title},
            {"status", static_cast<int>(status)},
            {"detail", escape_invalid_utf8(detail)}};
  if (!pointer.empty()) body["pointer"] = escape_invalid_utf8(pointer);
  Response r =
      make_response(request, status, body.dump(-1, ' ', false, json::error_handler_t::replace),
                    "application/problem+json");
  r.set(http::field::cache_control, "no-store");
  return r;
}

http::status status_of(terrain::ErrorKind kind) {
  switch (kind) {
    case terrain::ErrorKind::invalid:
      return http::status::bad_request;
    case terrain::ErrorKind::not_found:
      return http::status::not_found;
    case terrain::ErrorKind::unsupported:
      return http::status::unprocessable_entity;
    case terrain::ErrorKind::internal:
      return http::status::internal_server_error;
  }
  assert(false && "unknown error kind");
  return http::status::internal_server_error;
}

Response problem(const Request& request, std::string_view title, const terrain::Error& error) {
  const http::status status = status_of(error.kind);
  if (error.kind == terrain::ErrorKind::internal) {
    log(LogLevel::error, "internal error",
        {{"target",
          escape_invalid_utf8(std::string_view(request.target().data(), request.target().size()))},
         {"message", escape_invalid_utf8(error.message)},
         {"pointer", escape_invalid_utf8(error.pointer)}});
    return problem(request, status, "Internal error", error.message, error.pointer);
  }
  return problem(request, status, title, error.message, error.pointer);
}

// JSON answers are gzipped when the client accepts it and the body is worth compressing.
Response detail::json_response(const Request& request, http::status status, const json& body,
                               std::string_view media_type) {
  // A string that is not UTF-8 is replaced (U+FFFD) rather than thrown about: every string
  // that reaches an answer should have been checked, but an answer must never fail.
  std::string text = body.dump(-1, ' ', false, json::error_handler_t::replace);
  Response r = make_response(request, status, "", media_type);
  if (accepts_gzip(request) && text.size() > 1024) {
    auto packed = terrain::gzip_compress(std::string_view(text), 6);
    if (packed) {
      r.set(http::field::content_encoding, "gzip");
      text.assign(packed->begin(), packed->end());
    }
  }
  r.set(http::field::vary, "Accept-Encoding, Origin");
  r.body() = std::move(text);
  r.prepare_payload();
  return r;
}

terrain::Result<detail::TileShape, Response> detail::tile_shape(
    const Request& request, const std::vector<std::string>& rest,
    const std::map<std::string, std::string>& query) {
  auto parsed = parse_tile_query(request, rest, query, false);
  if (!parsed) return parsed.error();
  return TileShape{parsed->scheme, parsed->address, parsed->format, parsed->options};
}

Response detail::store_problem(const Request& request, const StoreError& e,
                               std::string_view pointer) {
  Response r = problem(request, store_status(e),
                       e.kind == StoreError::Kind::unavailable ? "Store unavailable"
                       : e.kind == StoreError::Kind::not_found ? "Not found"
                                                               : "Conflict",
                       e.message, pointer);
  if (e.kind == StoreError::Kind::unavailable) r.set(http::field::retry_after, "1");
  return r;
}

App::App(Config config, std::unique_ptr<Store> store)
    : config_(std::move(config)),
      store_(std::move(store)),
      cache_(config_.cache_bytes),
      bake_cache_(static_cast<std::size_t>(config_.bake_cache_bytes)),
      client_(StaticFiles::load(config_.client_dir)),
      versions_(*store_, [this](const std::string& text) {
        return compile_scene(text, SceneSource::stored);
      }) {
  if (RedisCache::Options redis;
      !config_.redis_url.empty() && RedisCache::parse_url(config_.redis_url, redis)) {
    redis.ttl_seconds = config_.redis_ttl_seconds;
    redis.timeout_ms = config_.redis_timeout_ms;
    redis_ = std::make_unique<RedisCache>(redis);
  }
  if (!config_.disk_cache_dir.empty()) {
    disk_cache_ = std::make_unique<DiskCache>(config_.disk_cache_dir, config_.disk_cache_bytes);
  }
  share_baked_grids();
  terrain::Result<gpu::BackendChoice> choice = gpu::choose_backend(backend_name(config_.backend));
  if (choice) {
    backend_ = choice->backend;
    backend_reason_ = choice->reason;
  } else {
    // backend = gpu with no working device: serve from the CPU and say so, rather than fail.
    backend_reason_ = "cpu: backend = gpu but " + choice.error().message;
  }
  if (RedisCache::Options where;
      !config_.live_redis_url.empty() && RedisCache::parse_url(config_.live_redis_url, where)) {
    where.timeout_ms = config_.redis_timeout_ms;
    bus_ = std::make_unique<LiveBus>(where,
                                     [this](const std::string& scene, const std::string& event) {
                                       on_remote_event(scene, event);
                                     });
    // News can be lost (Redis down, a replica killed between storing and publishing): the
    // store is read now and then for the scenes someone follows.
    sweeper_ = std::jthread([this](std::stop_token stop) {
      while (!stop.stop_requested()) {
        for (int slept = 0; slept < config_.live_sweep_ms && !stop.stop_requested(); slept += 10) {
          std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        if (!stop.stop_requested()) sweep_heads();
      }
    });
  }
}

void App::add_cors(const Request& request, Response& response) const {
  const auto origin = request.find(http::field::origin);
  if (origin == request.end() || config_.cors_origins.empty()) return;
  const std::string value(origin->value());
  const bool any = std::find(config_.cors_origins.begin(), config_.cors_origins.end(), "*") !=
                   config_.cors_origins.end();
  if (!any && std::find(config_.cors_origins.begin(), config_.cors_origins.end(), value) ==
                  config_.cors_origins.end()) {
    return;
  }
  response.set(http::field::access_control_allow_origin, any ? "*" : value);
  response.set(http::field::access_control_expose_headers,
               "ETag, Content-Encoding, Content-Length, X-Gray16-Offset, X-Gray16-Scale");
  if (!any) {
    // Add Origin to what the response already varies by (Accept-Encoding, say), never replace.
    const auto vary = response.find(http::field::vary);
    if (vary == response.end()) {
      response.set(http::field::vary, "Origin");
    } else if (vary->value().find("Origin") == boost::beast::string_view::npos) {
      response.set(http::field::vary, std::string(vary->value()) + ", Origin");
    }
  }
}

std::optional<Response> App::cached_product(const Request& request) {
  if (request.method() != http::verb::get && request.method() != http::verb::head) {
    return std::nullopt;
  }
  const ProductRoutes& routes = product_routes_.local();
  const auto route =
      routes.find(std::string_view(request.target().data(), request.target().size()));
  if (route == routes.end()) return std::nullopt;
  const ProductRoute& known = route->second;
  auto product = cache_.find_hit(known.cache_key);
  if (!product) return std::nullopt;
  ReplyContext reply = ReplyContext::of(request, known.cache_control);
  reply.gray16 = known.gray16;
  return product_response(reply, product);
}

void App::remember_product_route(const Request& request, ProductRoute route) {
  constexpr std::size_t kRememberedRoutes = 4096;  // per thread; forgotten all at once beyond
  ProductRoutes& routes = product_routes_.local();
  if (routes.size() >= kRememberedRoutes) routes.clear();
  routes.insert_or_assign(std::string(request.target()), std::move(route));
}

Outcome App::handle(const Request& request) {
  try {
    // A cached immutable tile asked for again: the same answer as the full route below gives.
    if (std::optional<Response> known = cached_product(request)) return std::move(*known);
    const std::string_view raw(request.target().data(), request.target().size());
    if (raw.empty() || raw.front() != '/') {
      return problem(request, http::status::bad_request, "Bad request target",
                     "the target must be an absolute path");
    }
    Target target;
    bool ok = true;
    const std::size_t q = raw.find('?');
    const std::string_view path = raw.substr(0, q);
    target.folder = path.size() > 1 && path.ends_with('/');
    std::size_t start = 1;
    while (start <= path.size()) {
      const std::size_t slash = path.find('/', start);
      const std::string_view seg =
          path.substr(start, slash == std::string_view::npos ? path.npos : slash - start);
      if (!seg.empty()) {
        std::string decoded = percent_decode(seg, false, ok);
        if (decoded == ".." || decoded == "." || decoded.find('/') != std::string::npos) ok = false;
        target.segments.push_back(std::move(decoded));
      }
      if (slash == std::string_view::npos) break;
      start = slash + 1;
    }
    if (q != std::string_view::npos) {
      std::string_view query = raw.substr(q + 1);
      int count = 0;
      while (!query.empty()) {
        const std::size_t amp = query.find('&');
        const std::string_view pair = query.substr(0, amp);
        if (!pair.empty()) {
          const std::size_t eq = pair.find('=');
          std::string key = percent_decode(pair.substr(0, eq), true, ok);
          std::string value =
              eq == std::string_view::npos ? "" : percent_decode(pair.substr(eq + 1), true, ok);
          target.query[std::move(key)] = std::move(value);
          if (++count > 32) ok = false;
        }
        if (amp == std::string_view::npos) break;
        query.remove_prefix(amp + 1);
      }
    }
    if (!ok) {
      return problem(request, http::status::bad_request, "Bad request target",
                     "the path or query is malformed (bad percent-encoding, control "
                     "characters, dot segments or too many parameters)");
    }
    return route(request, target);
  } catch (const std::exception& e) {
    // A broken internal contract: answer 500 rather than drop the connection.
    return problem(request, http::status::internal_server_error, "Internal error", e.what());
  }
}

terrain::Result<std::string, Response> App::public_origin(const Request& request) const {
  if (!config_.public_url.empty()) {
    std::string_view base = config_.public_url;
    while (base.ends_with('/')) base.remove_suffix(1);
    return std::string(base);
  }
  const auto host = request.find(http::field::host);
  if (host == request.end()) return std::string();  // HTTP/1.0: URLs relative to the server
  if (request.count(http::field::host) > 1) {       // RFC 9112 §3.2
    return problem(request, http::status::bad_request, "Bad Host header",
                   "a request carries one Host header", "/headers/host");
  }
  // A host name, IPv4 or [IPv6] address, and an optional port: nothing that could lead a
  // client elsewhere than this server's own name (no user info, path, or script).
  const std::string_view value(host->value().data(), host->value().size());
  std::string_view name = value;
  if (const std::size_t colon = value.rfind(':');
      colon != std::string_view::npos && value.find(']', colon) == std::string_view::npos) {
    const std::string_view port = value.substr(colon + 1);
    const auto number = parse_integer<int>(port);
    if (port.empty() || port.size() > 5 || !number || *number < 1 || *number > 65535) {
      name = {};
    } else {
      name = value.substr(0, colon);
    }
  }
  const bool bracketed = name.size() > 2 && name.front() == '[' && name.back() == ']';
  const std::string_view allowed =
      bracketed ? "0123456789abcdefABCDEF:."
                : "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789.-";
  const std::string_view inner = bracketed ? name.substr(1, name.size() - 2) : name;
  if (inner.empty() || value.size() > 255 ||
      inner.find_first_not_of(allowed) != std::string_view::npos) {
    return problem(request, http::status::bad_request, "Bad Host header",
                   "Host must be a host name or address with an optional port (or set "
                   "server.public_url)",
                   "/headers/host");
  }
  return "http://" + std::string(value);
}

Outcome App::off_io_thread(const Request& request, std::function<Response(const Request&)> work) {
  auto copy = std::make_shared<const Request>(request);
  Deferred deferred;
  deferred.work = [copy, work = std::move(work)]() -> Response { return work(*copy); };
  return deferred;
}

Response settle(App& app, const Request& request) {
  auto answer = [&]() -> Response {
    for (int pass = 0;; ++pass) {
      Outcome outcome = app.handle(request);
      Deferred* deferred = std::get_if<Deferred>(&outcome);
      if (deferred == nullptr) return std::move(std::get<Response>(outcome));
      if (!deferred->prepare) return deferred->work();
      std::optional<Response> prepared = deferred->prepare();
      if (prepared) return std::move(*prepared);
      assert(pass == 0);  // prepared once, the request is handled without another
    }
  };
  Response response = answer();
  app.add_cors(request, response);
  return response;
}

Response App::authorize(const Request& request) const {
  if (config_.write_token.empty()) {
    return problem(request, http::status::forbidden, "Writes disabled",
                   "this server has no write token configured (auth.write_token)");
  }
  const auto it = request.find(http::field::authorization);
  if (it == request.end()) {
    Response r = problem(request, http::status::unauthorized, "Authorization required",
                         "writes need 'Authorization: Bearer <write token>'");
    r.set(http::field::www_authenticate, "Bearer");
    return r;
  }
  const std::string_view given(it->value().data(), it->value().size());
  if (!given.starts_with("Bearer ") || !token_matches(given.substr(7))) {
    return problem(request, http::status::forbidden, "Forbidden", "the write token is wrong");
  }
  Response ok{http::status::ok, request.version()};
  return ok;
}

Outcome App::scene_product(const Request& request, const std::string& ref,
                           const std::vector<std::string>& rest, const Target& target) {
  auto loaded_or = resolve(request, ref);
  if (!loaded_or) return loaded_or.error();
  const LoadedVersion loaded = std::move(loaded_or).value();
  const bool pinned = ref.find('@') != std::string::npos;
  const std::string id = loaded.version.scene_id;
  const std::string pinned_ref = id + "@" + std::to_string(loaded.version.version);
  const char* const cache_control = cache_policy(pinned);
  const terrain::Program& program = *loaded.source->terrain;

  // JSON products are products too: a strong ETag of the bytes sent (so the gzipped and the
  // plain representation differ) and 304 when the client has them.
  auto finish_json = [&](const json& body) {
    return json_text_response(request, body.dump(), cache_control);
  };

  if (rest.size() == 1 && rest[0] == "program") {
    json body = program.to_json();
    body["scene_id"] = id;
    body["version"] = loaded.version.version;
    return finish_json(body);
  }
  if (rest.size() == 1 && rest[0] == "sample") {
    const auto x = parse_double(target.get("x")), y = parse_double(target.get("y"));
    const auto lod = parse_double(target.get("lod", "0"));
    if (!x || std::abs(*x) > 1e7) {
      return problem(request, http::status::bad_request, "Bad sample", "x must be a number", "/x");
    }
    if (!y || std::abs(*y) > 1e7) {
      return problem(request, http::status::bad_request, "Bad sample", "y must be a number", "/y");
    }
    if (!lod || *lod < 0 || *lod > 1e6) {
      return problem(request, http::status::bad_request, "Bad sample",
                     "lod must be a sample spacing in metres, 0 to 1e6", "/lod");
    }
    terrain::Evaluator evaluator(program);
    const terrain::FieldSample s = evaluator.sample(
        {static_cast<float>(*x), static_cast<float>(*y)}, static_cast<float>(*lod));
    const terrain::NodeBounds& b = evaluator.global_bounds();
    // The water layer's rule (the water masks'): wet where its weight is at least 0.5 and its
    // surface lies above the ground.
    json water = nullptr;
    if (loaded.source->water) {
      terrain::Evaluator water_evaluator(*loaded.source->water);
      const terrain::FieldSample w = water_evaluator.sample(
          {static_cast<float>(*x), static_cast<float>(*y)}, static_cast<float>(*lod));
      const bool wet = w.weight >= 0.5f && w.elevation > s.elevation;
      water = {{"wet", wet}, {"surface", wet ? json(w.elevation) : json(nullptr)}};
    }
    return finish_json({{"x", *x},
                        {"y", *y},
                        {"lod", *lod},
                        {"elevation", s.elevation},
                        {"weight", s.weight},
                        {"gradient", {s.elevation_gradient.x, s.elevation_gradient.y}},
                        {"lipschitz", b.elevation_lipschitz},
                        {"water", water},
                        {"version", loaded.version.version}});
  }
  if (rest.size() == 1 && rest[0] == "layer.json") {
    terrain::LayerJsonOptions options;
    options.name = loaded.scene->name;
    options.version = std::to_string(loaded.version.version);
    options.tiles = {"/api/v1/scenes/" + pinned_ref + "/mesh/{z}/{x}/{y}.terrain"};
    terrain::ProductMaker maker(*loaded.source);
    return finish_json(maker.layer_json(options));
  }
  if (rest.size() == 1 && rest[0] == "tilejson.json") {
    Result<terrain::TileScheme> scheme = terrain::parse_scheme(target.get("scheme", "webmercator"));
    if (!scheme) {
      return problem(request, http::status::bad_request, "Bad scheme",
                     "TileJSON describes XYZ tiles (scheme webmercator, the default, or local) or "
                     "geographic TMS tiles (scheme geographic, for Cesium's imagery)",
                     "/scheme");
    }
    const bool geographic = *scheme == terrain::TileScheme::geographic;
    auto images = parse_tilejson_images(request, target.query);
    if (!images) return images.error();
    terrain::ProductMaker maker(*loaded.source);
    auto origin_or = public_origin(request);
    if (!origin_or) return origin_or.error();
    const std::string origin = std::move(origin_or).value();
    const std::string scheme_name(terrain::scheme_name(*scheme));
    json body{{"tilejson", "3.0.0"},
              {"name", loaded.scene->name},
              {"version", "1.0.0"},
              {"scheme", geographic ? "tms" : "xyz"},
              {"tiles",
               {origin + "/api/v1/scenes/" + pinned_ref + images->tiles_path() +
                "&scheme=" + scheme_name}},
              {"minzoom", 0},
              {"maxzoom", maker.constants().max_useful_zoom[static_cast<int>(*scheme)]},
              {"tileSize", 256}};
    images->describe(body);
    if (geographic) body["crs"] = "EPSG:4326";  // two tiles at zoom 0, rows from the south
    if (*scheme != terrain::TileScheme::local) {
      const terrain::Georeference& g = loaded.source->georeference;
      const terrain::TileRange r =
          terrain::tiles_covering_area(*loaded.source, terrain::TileScheme::geographic, 14);
      const double step = 180.0 / 16384.0;
      auto d = [](std::int64_t v) { return static_cast<double>(v); };
      body["bounds"] = {-180.0 + d(r.min_x) * step, -90.0 + d(r.min_y) * step,
                        -180.0 + d(r.max_x + 1) * step, -90.0 + d(r.max_y + 1) * step};
      body["center"] = {g.longitude, g.latitude, 12};
    }
    return finish_json(body);
  }

  if (rest.size() == 1 && rest[0] == "render.png") {
    return render(request, loaded, target, PictureProduct::png);
  }
  if (rest.size() == 1 && rest[0] == "depth.bin") {
    return render(request, loaded, target, PictureProduct::depth);
  }
  if (rest.size() == 1 && rest[0] == "trace.json") return trace_bundle(request, loaded, pinned);
  if (rest.size() == 1 && rest[0] == "analysis.json") {
    return scene_analysis(request, loaded, target, pinned);
  }

  // Tiles and meshes: /tiles/{z}/{x}/{y}.{png,tif}, /mesh/{z}/{x}/{y}.{terrain,glb,drc}
  if (rest.size() != 4 || (rest[0] != "tiles" && rest[0] != "mesh")) {
    return problem(request, http::status::not_found, "Not found",
                   "no product '" + (rest.empty() ? std::string() : rest[0]) + "' of a scene");
  }
  auto query = parse_tile_query(request, rest, target.query, false);
  if (!query) return query.error();
  const bool mesh = query->mesh;
  const terrain::ProductOptions options = query->options;
  const int border = query->border;
  const double samples =
      mesh ? static_cast<double>(options.grid) * options.grid +
                 (options.watermask && loaded.source->water ? 65536.0 : 0.0)
           : static_cast<double>(options.size + 2 * border) * (options.size + 2 * border) *
                 (terrain::is_color(query->format) && loaded.source->water ? 2.0
                                                                           : 1.0);  // and water
  const double cost = samples * static_cast<double>(std::max<std::size_t>(program.code.size(), 1));
  if (cost > config_.max_cost) {
    return problem(request, http::status::unprocessable_entity, "Too costly",
                   "this product would cost " + std::to_string(static_cast<long long>(cost)) +
                       " (samples x program size), above the limit of " +
                       std::to_string(static_cast<long long>(config_.max_cost)));
  }
  ProductJob job;
  job.key = loaded.version.hash + query->key();
  job.reply = ReplyContext::of(request, cache_control);
  if (query->format == terrain::TileFormat::gray16) {
    job.reply.gray16 = terrain::gray16_encoding_for(loaded.source->elevation_range);
  }
  job.reply.negotiated_by_accept = query->format == terrain::TileFormat::quantized_mesh;
  // A pinned version's URL names the same bytes and headers forever; quantized-mesh also
  // depends on Accept.
  if (pinned && query->format != terrain::TileFormat::quantized_mesh) {
    remember_product_route(request, {job.key, cache_control, job.reply.gray16});
  }
  job.cost = cost;
  const terrain::TileFormatInfo& info = terrain::format_info(query->format);
  job.metric = info.encoding.empty() ? info.extension : info.encoding;
  job.reuse = [this, loaded, key = query->key(), q = *query] {
    return reuse_unchanged_tile(loaded, key, q.scheme, q.address, q.format, q.options);
  };
  job.make = [this, source = loaded.source, version_hash = loaded.version.hash, q = *query,
              reply =
                  job.reply](const std::atomic<bool>&) -> terrain::Result<CachedProduct, Response> {
    // A maker per version and thread: it keeps what tiles of a version share (not thread-safe).
    thread_local std::unordered_map<std::string, std::unique_ptr<terrain::ProductMaker>> makers;
    if (makers.size() > kMakersPerThread && !makers.contains(version_hash)) makers.clear();
    std::unique_ptr<terrain::ProductMaker>& maker = makers[version_hash];
    if (!maker) {
      maker = std::make_unique<terrain::ProductMaker>(*source);
      maker->set_backend(backend_);
    }
    Result<terrain::Product> product = maker->make(q.scheme, q.address, q.format, q.options);
    if (!product) return problem(reply.shadow(), "Bad tile request", product.error());
    return product_bytes(std::move(product).value());
  };
  return serve_product(std::move(job));
}

Response App::node_types(const Request& request) const {
  // The registry, for clients that build or edit scenes (the browser's editor picks what it can
  // move by category): the same list the parser, the compiler and the shaders are driven by.
  static const std::string text = [] {
    json types = json::array();
    for (const terrain::NodeType* type : terrain::node_types()) {
      json entry{
          {"id", type->id},
          {"name", type->name},
          {"category", terrain::category_name(type->category)},
          {"min_children", type->min_children},
          {"summary", type->summary},
          {"gpu", type->category == terrain::NodeCategory::blend || type->shader.implemented()},
          {"example", json::parse(type->example_json)}};
      entry["max_children"] =
          type->max_children == 0xffff ? json(nullptr) : json(type->max_children);
      types.push_back(std::move(entry));
    }
    return json{{"node_types", std::move(types)}}.dump();
  }();
  return json_text_response(request, text, kReleaseCacheControl);
}

namespace {
// GLSL of this release, revalidated by its ETag.
Response glsl_response(const Request& request, const std::string& text, const std::string& etag) {
  Response r = make_response(request, http::status::ok, text, "text/plain; charset=utf-8");
  r.set(http::field::cache_control, kReleaseCacheControl);
  answer_conditionally(request, r, etag);
  return r;
}
}  // namespace

Response App::trace_glsl(const Request& request) const {
  // The node functions, the interpreter, the material model and the tracer: the very text the
  // server's compute shaders are built from, for the browser to put after its own
  // texture-reading prelude.
  static const std::string text =
      std::string(gpu::shared_glsl()) + "\n" + std::string(gpu::trace_glsl());
  static const std::string etag = product_etag(text);
  return glsl_response(request, text, etag);
}

Response App::material_glsl(const Request& request) const {
  // The material model alone (planet mode colours land with it).
  static const std::string text(gpu::material_glsl());
  static const std::string etag = product_etag(text);
  return glsl_response(request, text, etag);
}

// The caches shared with other processes and other versions of the server hold a product under
// the generation that made it: a server of another generation neither reads nor overwrites it.
namespace {
std::string shared_key(const std::string& key) {
  return "g" + std::to_string(terrain::kProductGeneration) + "/" + key;
}
}  // namespace

std::shared_ptr<const CachedProduct> App::find_shared(const std::string& product_key) {
  const std::string key = shared_key(product_key);
  if (disk_cache_) {
    if (auto hit = disk_cache_->find(key)) return hit;
  }
  if (redis_) {
    if (auto hit = redis_->find(key)) {
      if (disk_cache_) disk_cache_->insert(key, *hit);
      return hit;
    }
  }
  return nullptr;
}

void App::store_shared(const std::string& product_key, const CachedProduct& product) {
  const std::string key = shared_key(product_key);
  if (disk_cache_) disk_cache_->insert(key, product);
  if (redis_) redis_->insert(key, product);
}

std::string App::cache_metrics() const {
  std::ostringstream out;
  append_sample(out, "terrain_bake_made_total", "counter",
                "Baked grids (erosion, drainage) this server computed", bake_cache_.made());
  append_sample(out, "terrain_bake_shared_hits_total", "counter",
                "Baked grids this server found in the disk cache or Redis instead of computing",
                bake_cache_.shared_hits());
  if (!redis_) return out.str();
  append_sample(out, "terrain_redis_up", "gauge",
                "1 when the last exchange with the shared Redis cache worked; 0: products are "
                "generated instead",
                redis_->up() ? 1 : 0);
  append_sample(out, "terrain_redis_hits_total", "counter", "Products found in Redis.",
                redis_->hits());
  append_sample(out, "terrain_redis_misses_total", "counter", "Products Redis did not have.",
                redis_->misses());
  append_sample(out, "terrain_redis_errors_total", "counter",
                "Failed exchanges with Redis (timeouts, refused connections, errors, unreadable "
                "entries).",
                redis_->errors());
  return out.str();
}

}  // namespace server
