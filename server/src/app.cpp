#include "server/app.hpp"

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
// Built planets kept in memory (each holds its base mesh, a few MiB), and per generation thread
// the PlanetTiles and Samplers that cache refined triangles (up to ~200 MiB each when deep tiles
// are asked for, trimmed beyond that), so fewer of those.
constexpr std::size_t kLoadedPlanets = 16;
constexpr std::size_t kPlanetWorkersPerThread = 4;

std::string quote(std::string_view s) {
  return "\"" + std::string(s) + "\"";
}

Response make_response(const Request& request, http::status status, Payload body,
                       std::string_view media_type) {
  Response r{status, request.version()};
  r.set(http::field::server, "terrain-server");
  r.set(http::field::content_type, media_type);
  r.keep_alive(request.keep_alive());
  r.body() = std::move(body);
  r.prepare_payload();
  return r;
}

bool accepts_gzip(const Request& request) {
  const auto it = request.find(http::field::accept_encoding);
  return it != request.end() && it->value().find("gzip") != boost::beast::string_view::npos;
}

using detail::json_response;

std::string percent_decode(std::string_view in, bool plus_is_space, bool& ok) {
  std::string out;
  out.reserve(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    const char c = in[i];
    if (c == '%') {
      int v = 0;
      if (i + 2 >= in.size() ||
          std::from_chars(in.data() + i + 1, in.data() + i + 3, v, 16).ptr != in.data() + i + 3) {
        ok = false;
        return out;
      }
      out.push_back(static_cast<char>(v));
      i += 2;
    } else if (c == '+' && plus_is_space) {
      out.push_back(' ');
    } else {
      out.push_back(c);
    }
  }
  for (char c : out) {
    if (static_cast<unsigned char>(c) < 0x20) ok = false;  // no control characters anywhere
  }
  return out;
}

using detail::parse_integer;

std::optional<double> parse_double(std::string_view text) {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty() || !std::isfinite(v)) {
    return std::nullopt;
  }
  return v;
}

using detail::valid_id;

std::string slug(std::string_view name) {
  std::string s;
  for (char c : name) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    const bool keep = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
    if (keep) {
      s.push_back(c);
    } else if (!s.empty() && s.back() != '-') {
      s.push_back('-');
    }
    if (s.size() >= 40) break;
  }
  while (!s.empty() && s.back() == '-') s.pop_back();
  return s.empty() ? "scene" : s;
}

// The scene's own image references (paths beside a file, for the built-in examples) become the
// hashes of stored blobs: stored scenes never name files.
void rewrite_images(json& node, const std::map<std::string, std::string>& hashes) {
  if (node.is_object()) {
    if (node.contains("type") && node["type"] == "image" && node.contains("image") &&
        node["image"].is_string()) {
      auto it = hashes.find(node["image"].get<std::string>());
      if (it != hashes.end()) node["image"] = it->second;
    }
    for (auto& [key, value] : node.items()) rewrite_images(value, hashes);
  } else if (node.is_array()) {
    for (json& value : node) rewrite_images(value, hashes);
  }
}

void collect_images(const json& node, std::vector<std::string>& out) {
  if (node.is_object()) {
    if (node.contains("type") && node["type"] == "image" && node.contains("image") &&
        node["image"].is_string()) {
      out.push_back(node["image"].get<std::string>());
    }
    for (const auto& [key, value] : node.items()) collect_images(value, out);
  } else if (node.is_array()) {
    for (const json& value : node) collect_images(value, out);
  }
}

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

using detail::store_problem;
using detail::cache_policy;
using detail::kAliasCacheControl;
using detail::kImmutable;

std::string version_etag(const SceneVersion& v) {
  return quote(v.hash);
}

// Whether an If-None-Match value names this entity tag.
bool none_match_names(std::string_view header, std::string_view etag) {
  if (header == "*") return true;
  // A list of entity tags; weak comparison is what If-None-Match asks for.
  std::size_t at = 0;
  while ((at = header.find('"', at)) != std::string_view::npos) {
    const std::size_t end = header.find('"', at + 1);
    if (end == std::string_view::npos) break;
    if (header.substr(at, end - at + 1) == etag) return true;
    at = end + 1;
  }
  return false;
}

std::string_view if_none_match(const Request& request) {
  const auto it = request.find(http::field::if_none_match);
  return it == request.end() ? std::string_view()
                             : std::string_view(it->value().data(), it->value().size());
}

bool etag_matches(const Request& request, std::string_view etag) {
  return none_match_names(if_none_match(request), etag);
}

// The bytes' hash, under the product generation that made them.
std::string product_etag(std::string_view body) {
  return quote("g" + std::to_string(terrain::kProductGeneration) + "-" +
               terrain::sha256_hex(body).substr(0, 32));
}

// A JSON product from its text: gzipped when the client takes it and it is worth it, a strong
// ETag of the bytes sent (the gzipped and the plain representation differ), 304 when the client
// has them.
Response json_text_response(const Request& request, const std::string& text,
                            std::string_view cache_control) {
  Response r = make_response(request, http::status::ok, "", "application/json");
  r.set(http::field::vary, "Accept-Encoding, Origin");
  r.set(http::field::cache_control, cache_control);
  std::string sent = text;
  if (accepts_gzip(request) && text.size() > 1024) {
    if (auto packed = terrain::gzip_compress(std::string_view(text), 6)) {
      r.set(http::field::content_encoding, "gzip");
      sent.assign(packed->begin(), packed->end());
    }
  }
  const std::string etag = product_etag(sent);
  r.set(http::field::etag, etag);
  if (etag_matches(request, etag)) {
    r.result(http::status::not_modified);
    return r;
  }
  r.body() = std::move(sent);
  r.prepare_payload();
  return r;
}

std::string query_value(const std::map<std::string, std::string>& query, const std::string& key,
                        const std::string& fallback = "") {
  auto it = query.find(key);
  return it == query.end() ? fallback : it->second;
}

// A tile or mesh request: the address, format and options of its URL and Accept header,
// checked the same way for scenes and planets.
struct TileQuery {
  terrain::TileFormat format{};
  std::string extension;
  std::string encoding;  ///< as given (part of the cache key)
  terrain::TileScheme scheme{};
  terrain::TileAddress address{};
  terrain::ProductOptions options;
  int border = 0;
  bool mesh = false;

  /// What the cache key holds besides the content hash: everything that shapes the bytes.
  std::string key() const {
    std::string out;
    for (const std::string& part :
         {std::string(terrain::scheme_name(scheme)),
          std::to_string(address.z) + '/' + std::to_string(address.x) + '/' +
              std::to_string(address.y),
          extension, encoding, std::to_string(options.size), std::to_string(border),
          std::to_string(options.grid),
          options.max_error ? std::to_string(*options.max_error) : "auto",
          std::string{char('0' + options.octvertexnormals), char('0' + options.watermask),
                      char('0' + options.metadata)}}) {
      out += '|';
      out += part;
    }
    return out;
  }
};

// Parses /tiles/{z}/{x}/{y}.{ext} or /mesh/{z}/{x}/{y}.{ext} (rest = those four segments) with
// the query's scheme, encoding, size, border, grid and max_error. `planet`: geographic is the
// default scheme and local is refused (PlanetTiles::validate checks the rest).
terrain::Result<TileQuery, Response> parse_tile_query(
    const Request& request, const std::vector<std::string>& rest,
    const std::map<std::string, std::string>& query, bool planet) {
  auto get = [&](const char* key, const char* fallback = "") {
    return query_value(query, key, fallback);
  };
  TileQuery q;
  q.mesh = rest[0] == "mesh";
  const std::string& last = rest[3];
  const std::size_t dot = last.rfind('.');
  if (dot == std::string::npos) {
    return problem(request, http::status::not_found, "Unknown format",
                   "the tile name needs an extension", "/format");
  }
  const auto z = parse_integer<int>(rest[1]);
  const auto x = parse_integer<std::int64_t>(rest[2]);
  const auto y = parse_integer<std::int64_t>(last.substr(0, dot));
  if (!z)
    return problem(request, http::status::bad_request, "Bad tile address", "z must be an integer",
                   "/z");
  if (!x)
    return problem(request, http::status::bad_request, "Bad tile address", "x must be an integer",
                   "/x");
  if (!y)
    return problem(request, http::status::bad_request, "Bad tile address", "y must be an integer",
                   "/y");
  q.extension = last.substr(dot + 1);
  q.encoding = get("encoding");
  Result<terrain::TileFormat> format = terrain::parse_tile_format(q.extension, q.encoding);
  if (!format) {
    return problem(request, "Unknown format", format.error());
  }
  q.format = *format;
  const terrain::TileFormatInfo& info = terrain::format_info(q.format);
  if (info.mesh != q.mesh) {
    return problem(
        request, http::status::not_found, "Unknown format",
        "." + q.extension +
            (q.mesh ? " is not a mesh format (use /tiles/)" : " is a mesh format (use /mesh/)"),
        "/format");
  }
  const char* default_scheme = planet || q.format == terrain::TileFormat::quantized_mesh
                                   ? "geographic"
                               : q.mesh ? "local"
                                        : "webmercator";
  Result<terrain::TileScheme> scheme = terrain::parse_scheme(get("scheme", default_scheme));
  if (!scheme) {
    return problem(request, http::status::bad_request, "Bad scheme", scheme.error().message,
                   "/scheme");
  }
  if (planet && *scheme == terrain::TileScheme::local) {
    return problem(request, http::status::bad_request, "Bad scheme",
                   "planets are tiled in the geographic (EPSG:4326 TMS, default) and webmercator "
                   "(EPSG:3857 XYZ, height images) schemes",
                   "/scheme");
  }
  q.scheme = *scheme;
  auto integer_option = [&](const char* key, int& out, int fallback) -> bool {
    const std::string text = get(key);
    if (text.empty()) {
      out = fallback;
      return true;
    }
    auto v = parse_integer<int>(text);
    if (!v) return false;
    out = *v;
    return true;
  };
  if (!integer_option("size", q.options.size, 256)) {
    return problem(request, http::status::bad_request, "Bad option", "size must be an integer",
                   "/size");
  }
  if (!integer_option("grid", q.options.grid, 65)) {
    return problem(request, http::status::bad_request, "Bad option", "grid must be an integer",
                   "/grid");
  }
  if (!integer_option("border", q.border, 0) || (q.border != 0 && q.border != 1)) {
    return problem(request, http::status::bad_request, "Bad option", "border must be 0 or 1",
                   "/border");
  }
  q.options.border = q.border == 1;
  if (const std::string e = get("max_error"); !e.empty()) {
    q.options.max_error = parse_double(e);
    if (!q.options.max_error) {
      return problem(request, http::status::bad_request, "Bad option",
                     "max_error must be a number of metres", "/max_error");
    }
  }
  if (q.format == terrain::TileFormat::quantized_mesh) {
    // Cesium lists the extensions it wants: application/vnd.quantized-mesh;extensions=a-b-c
    const auto accept = request.find(http::field::accept);
    const std::string a = accept == request.end() ? "" : std::string(accept->value());
    q.options.octvertexnormals = a.find("octvertexnormals") != std::string::npos;
    q.options.watermask = a.find("watermask") != std::string::npos;
    q.options.metadata = a.find("metadata") != std::string::npos;
  }
  q.address = {*z, *x, *y};
  if (terrain::Status valid = terrain::validate_address(q.scheme, q.address); !valid) {
    return problem(request, http::status::bad_request, "Bad tile address", valid.error().message,
                   valid.error().pointer);
  }
  return q;
}

// What a product response needs of its request, copied so that deferred work outlives it.
struct ReplyContext {
  unsigned version = 11;
  bool keep_alive = false;
  bool gzip_ok = false;
  std::string if_none_match;
  std::string cache_control;
  std::optional<terrain::Gray16Encoding> gray16;  ///< X-Gray16-* headers for gray16 PNGs
  bool negotiated_by_accept = false;              ///< quantized-mesh: Accept chose the extensions

  static ReplyContext of(const Request& request, std::string cache_control) {
    ReplyContext c;
    c.version = request.version();
    c.keep_alive = request.keep_alive();
    c.gzip_ok = accepts_gzip(request);
    const auto it = request.find(http::field::if_none_match);
    if (it != request.end()) c.if_none_match = std::string(it->value());
    c.cache_control = std::move(cache_control);
    return c;
  }
  /// A request to build problems and responses with, once the original is gone.
  Request shadow() const {
    Request r{http::verb::get, "/", version};
    if (!if_none_match.empty()) r.set(http::field::if_none_match, if_none_match);
    r.keep_alive(keep_alive);
    return r;
  }
};

// What a product response takes from its request and URL, as views (of a ReplyContext, or of
// the request itself while it is handled).
struct ReplyParts {
  unsigned version = 11;
  bool keep_alive = false;
  bool gzip_ok = false;
  std::string_view if_none_match;
  std::string_view cache_control;
  std::optional<terrain::Gray16Encoding> gray16;
  bool negotiated_by_accept = false;

  static ReplyParts of(const ReplyContext& c) {
    return {c.version, c.keep_alive,          c.gzip_ok, c.if_none_match, c.cache_control,
            c.gray16,  c.negotiated_by_accept};
  }
};

// The response for a product, fresh or cached: strong ETag, 304, gzip as stored or inflated.
Response product_response(const ReplyParts& c,
                          const std::shared_ptr<const CachedProduct>& product) {
  const CachedProduct& p = *product;
  // A gzip-stored product sent plain is another representation: another strong ETag.
  const bool inflate = p.content_encoding == "gzip" && !c.gzip_ok;
  const std::string inflated_etag =
      inflate ? p.etag.substr(0, p.etag.size() - 1) + "-identity\"" : std::string();
  const std::string_view etag = inflate ? std::string_view(inflated_etag) : p.etag;
  Response r{http::status::ok, c.version};
  r.set(http::field::server, "terrain-server");
  r.keep_alive(c.keep_alive);
  r.set(http::field::etag, etag);
  r.set(http::field::cache_control, c.cache_control);
  // A shared cache must not hand one client's quantized-mesh extensions to another.
  r.set(http::field::vary,
        c.negotiated_by_accept ? "Accept, Accept-Encoding, Origin" : "Accept-Encoding, Origin");
  if (c.gray16) {
    r.set("X-Gray16-Offset", std::to_string(c.gray16->offset));
    r.set("X-Gray16-Scale", std::to_string(c.gray16->scale));
  }
  if (none_match_names(c.if_none_match, etag)) {
    r.result(http::status::not_modified);
    return r;
  }
  r.set(http::field::content_type, p.media_type);
  if (inflate) {
    auto raw = terrain::gzip_decompress(
        std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(p.body.data()),
                                      p.body.size()),
        std::size_t{1} << 28);
    r.body() = std::string(raw->begin(), raw->end());
  } else {
    if (!p.content_encoding.empty()) r.set(http::field::content_encoding, p.content_encoding);
    r.body() = Payload(std::shared_ptr<const std::string>(product, &p.body), p.file);
  }
  if (!p.backend.empty()) r.set("X-Terrain-Backend", p.backend);
  r.prepare_payload();  // HEAD: the session drops the body and keeps this length
  return r;
}
Response product_response(const ReplyContext& c,
                          const std::shared_ptr<const CachedProduct>& product) {
  return product_response(ReplyParts::of(c), product);
}
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
      client_(StaticFiles::load(config_.client_dir)) {
  if (RedisCache::Options redis;
      !config_.redis_url.empty() && RedisCache::parse_url(config_.redis_url, redis)) {
    redis.ttl_seconds = config_.redis_ttl_seconds;
    redis.timeout_ms = config_.redis_timeout_ms;
    redis_ = std::make_unique<RedisCache>(redis);
  }
  if (!config_.disk_cache_dir.empty()) {
    disk_cache_ = std::make_unique<DiskCache>(config_.disk_cache_dir, config_.disk_cache_bytes);
  }
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

std::string_view App::route_label(const Request& request) {
  const std::string_view t(request.target().data(), request.target().size());
  std::string_view path = t.substr(0, t.find('?'));
  // The label is read off the segments' positions, never by searching the path: a scene named
  // "sample" is a scene, not the sample route.
  std::array<std::string_view, 5> s{};
  std::size_t n = 0;
  while (!path.empty()) {
    const std::size_t slash = path.find('/');
    const std::string_view segment = path.substr(0, slash);
    if (!segment.empty()) {
      if (n < s.size()) s[n] = segment;
      ++n;
    }
    if (slash == std::string_view::npos) break;
    path.remove_prefix(slash + 1);
  }
  if (n == 1 && s[0] == "healthz") return "healthz";
  if (n == 1 && s[0] == "metrics") return "metrics";
  if (n == 0 || s[0] != "api") return "client";  // the browser client's files
  if (n < 2 || s[1] != "v1") return "other";
  if (n == 2) return "other";
  if (s[2] == "glsl") return "glsl";
  if (s[2] == "node-types") return "node_types";
  if (s[2] == "openapi.json") return "openapi";
  if (s[2] == "images") return "images";
  // A scene's or a planet's products, by the segment after its ref.
  static constexpr std::array<std::string_view, 12> kSceneProducts = {
      "tiles",       "live",     "changes", "render.png", "depth.bin",     "trace.json",
      "mesh",        "versions", "program", "sample",     "tilejson.json", "layer.json"};
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 5> kPlanetProducts =
      {{{"tiles", "planet_tiles"},
        {"mesh", "planet_mesh"},
        {"sample", "planet_sample"},
        {"tilejson.json", "planet_tilejson.json"},
        {"layer.json", "planet_layer.json"}}};
  if (s[2] == "planets") {
    if (n == 3) return "planets";
    if (n == 4) return "planet";
    for (const auto& [product, label] : kPlanetProducts) {
      if (s[4] == product) return label;
    }
    return "planet";
  }
  if (s[2] == "scenes") {
    if (n == 3) return "scenes";
    if (n == 4) return "scene";
    for (std::string_view product : kSceneProducts) {
      if (s[4] != product) continue;
      if (product == "render.png") return "render";
      if (product == "depth.bin") return "depth";
      return product;
    }
    return "scene";
  }
  return "other";
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
  return product_response({request.version(), request.keep_alive(), accepts_gzip(request),
                           if_none_match(request), known.cache_control, known.gray16},
                          product);
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
    if (std::optional<Response> known = cached_product(request)) {
      add_cors(request, *known);
      return std::move(*known);
    }
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
    Outcome outcome = route(request, target);
    if (Response* r = std::get_if<Response>(&outcome)) add_cors(request, *r);
    return outcome;
  } catch (const std::exception& e) {
    // A broken internal contract: answer 500 rather than drop the connection.
    return problem(request, http::status::internal_server_error, "Internal error", e.what());
  }
}

Outcome App::route(const Request& request, const Target& target) {
  const auto& s = target.segments;
  const http::verb method = request.method();
  auto not_allowed = [&](const char* allow) {
    Response r = problem(request, http::status::method_not_allowed, "Method not allowed",
                         std::string(request.method_string()) + " is not allowed here");
    r.set(http::field::allow, allow);
    return r;
  };
  if (method == http::verb::options) {
    Response r = make_response(request, http::status::no_content, "", "text/plain");
    add_cors(request, r);
    r.set(http::field::access_control_allow_methods, "GET, HEAD, POST, PUT, OPTIONS");
    r.set(http::field::access_control_allow_headers,
          "Authorization, Content-Type, If-Match, If-None-Match");
    r.set(http::field::access_control_max_age, "86400");
    return r;
  }
  const bool read = method == http::verb::get || method == http::verb::head;
  if (s.size() == 1 && s[0] == "healthz") {
    if (!read) return not_allowed("GET, HEAD");
    Response r = json_response(request, http::status::ok, {{"status", "ok"}});
    r.set(http::field::cache_control, "no-store");
    return r;
  }
  if (s.size() == 3 && s[0] == "api" && s[1] == "v1" && s[2] == "openapi.json") {
    if (!read) return not_allowed("GET, HEAD");
    Response r = make_response(request, http::status::ok, std::string(openapi_document()),
                               "application/json");
    r.set(http::field::cache_control, "public, max-age=300");
    return r;
  }
  if (s.size() == 1 && s[0] == "metrics") {
    if (!read) return not_allowed("GET, HEAD");
    Response r =
        make_response(request, http::status::ok, metrics_.prometheus(cache_) + redis_metrics(),
                      "text/plain; version=0.0.4");
    r.set(http::field::cache_control, "no-store");
    return r;
  }
  if (s.size() >= 2 && s[0] == "api" && s[1] == "v1") {
    if (s.size() == 4 && s[2] == "glsl" && s[3] == "trace.glsl") {
      if (!read) return not_allowed("GET, HEAD");
      return trace_glsl(request);
    }
    if (s.size() == 3 && s[2] == "node-types") {
      if (!read) return not_allowed("GET, HEAD");
      return node_types(request);
    }
    if (s.size() == 3 && s[2] == "images") {
      if (method != http::verb::post) return not_allowed("POST");
      return upload_image(request);
    }
    if (s.size() >= 3 && s[2] == "scenes") {
      if (s.size() == 3) {
        if (read) return list_scenes(request);
        if (method == http::verb::post) {
          return off_io_thread(request, [this, target](const Request& r) -> Response {
            return create_scene(r, target);
          });
        }
        return not_allowed("GET, HEAD, POST");
      }
      const std::string& ref = s[3];
      // Parsing and compiling a version (decoding its images) is work for the pool, not for an
      // I/O thread: a read of a version not loaded yet goes there whole, once.
      const bool loads = read && (s.size() == 4 || (s[4] != "versions" && s[4] != "live"));
      if (loads && !is_loaded(ref)) {
        Deferred load;
        load.prepare = [this, copy = std::make_shared<const Request>(request),
                        ref]() -> std::optional<Response> {
          auto loaded = resolve(*copy, ref);
          if (loaded) return std::nullopt;
          Response refusal = loaded.error();
          add_cors(*copy, refusal);
          return refusal;
        };
        return load;
      }
      if (s.size() == 4) {
        if (read) return get_scene(request, ref);
        if (method == http::verb::put) {
          return off_io_thread(
              request, [this, ref](const Request& r) -> Response { return put_scene(r, ref); });
        }
        return not_allowed("GET, HEAD, PUT");
      }
      if (s.size() == 5 && s[4] == "versions") {
        if (!read) return not_allowed("GET, HEAD");
        return versions(request, ref);
      }
      if (s.size() == 5 && s[4] == "changes") {
        if (!read) return not_allowed("GET, HEAD");
        return scene_changes(request, ref, target);
      }
      if (s.size() == 5 && s[4] == "live") {
        // Upgrades are taken by the session layer before routing; this is a plain request.
        Response r = problem(request, http::status::upgrade_required, "WebSocket required",
                             "the live channel is a WebSocket: connect with Upgrade: websocket "
                             "(docs/live.md)");
        r.set(http::field::upgrade, "websocket");
        // The offer to upgrade, and still a close where the client asked for one.
        r.set(http::field::connection, request.keep_alive() ? "Upgrade" : "Upgrade, close");
        return r;
      }
      if (!read) return not_allowed("GET, HEAD");
      return scene_product(request, ref, std::vector<std::string>(s.begin() + 4, s.end()), target);
    }
    if (s.size() >= 3 && s[2] == "planets") {
      if (s.size() == 3) {
        if (read) return list_planets(request);
        if (method == http::verb::post) return create_planet(request);
        return not_allowed("GET, HEAD, POST");
      }
      if (!read) return not_allowed("GET, HEAD");
      if (s.size() == 4) return get_planet(request, s[3]);
      return planet_product(request, s[3], std::vector<std::string>(s.begin() + 4, s.end()),
                            target);
    }
  }
  if (read && (s.empty() || s[0] != "api")) {
    // The browser client: looked up in the table read at start, never a path on disk.
    std::string path;
    for (const std::string& seg : s) path += "/" + seg;
    if (path.empty() || target.folder) path += "/";
    if (const StaticFile* file = client_.find(path)) {
      if (etag_matches(request, file->etag)) {
        Response r = make_response(request, http::status::not_modified, "", file->media_type);
        r.set(http::field::etag, file->etag);
        return r;
      }
      Response r = make_response(request, http::status::ok, Payload(file->body), file->media_type);
      r.set(http::field::etag, file->etag);
      r.set(http::field::cache_control, "public, max-age=60");
      return r;
    }
    if (!path.ends_with('/') && client_.find(path + "/") != nullptr) {
      // A folder named without its slash: its page's relative links need the slash.
      Response r = make_response(request, http::status::moved_permanently, "", "text/plain");
      r.set(http::field::location, path + "/");
      return r;
    }
    if (path == "/" && client_.empty()) {
      return problem(request, http::status::not_found, "No browser client",
                     "the browser client is not installed (client.dir = " + config_.client_dir +
                         "); the API is under /api/v1/ (see /api/v1/openapi.json)");
    }
  }
  return problem(request, http::status::not_found, "Not found",
                 "no route for " + std::string(request.target()));
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

App::BodyPolicy App::body_policy(http::verb method, std::string_view target) const {
  std::string_view path = target.substr(0, target.find('?'));
  while (path.size() > 1 && path.back() == '/') path.remove_suffix(1);
  // Percent-encoded ids reach the same routes: the checks below only look at the fixed parts.
  if (method == http::verb::post && path == "/api/v1/images") {
    return {config_.image_body_limit, true};
  }
  if (method == http::verb::post && (path == "/api/v1/scenes" || path == "/api/v1/planets")) {
    return {config_.scene_body_limit, true};
  }
  constexpr std::string_view kScenes = "/api/v1/scenes/";
  if (method == http::verb::put && path.starts_with(kScenes) &&
      path.find('/', kScenes.size()) == std::string_view::npos) {
    return {config_.scene_body_limit, true};
  }
  return {};
}

Outcome App::off_io_thread(const Request& request, std::function<Response(const Request&)> work) {
  auto copy = std::make_shared<const Request>(request);
  Deferred deferred;
  deferred.work = [this, copy, work = std::move(work)]() -> Response {
    Response response = work(*copy);
    add_cors(*copy, response);
    return response;
  };
  return deferred;
}

Response settle(App& app, const Request& request) {
  for (int pass = 0;; ++pass) {
    Outcome outcome = app.handle(request);
    Deferred* deferred = std::get_if<Deferred>(&outcome);
    if (deferred == nullptr) return std::move(std::get<Response>(outcome));
    if (!deferred->prepare) return deferred->work();
    std::optional<Response> answer = deferred->prepare();
    if (answer) return std::move(*answer);
    assert(pass == 0);  // prepared once, the request is handled without another
  }
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

Response App::list_scenes(const Request& request) {
  StoreResult<std::vector<SceneSummary>> scenes = store_->list_scenes();
  if (!scenes) return store_problem(request, scenes.error());
  json list = json::array();
  for (const SceneSummary& s : *scenes) {
    list.push_back({{"id", s.id},
                    {"name", s.name},
                    {"version", s.head_version},
                    {"hash", s.head_hash},
                    {"url", "/api/v1/scenes/" + s.id}});
  }
  Response r = json_response(request, http::status::ok, {{"scenes", list}});
  r.set(http::field::cache_control, "no-cache");
  return r;
}

Response App::create_scene(const Request& request, const Target& target) {
  if (Response auth = authorize(request); auth.result() != http::status::ok) return auth;
  auto compiled = compile_for_storing(request);
  if (!compiled) return compiled.error();
  const std::shared_ptr<const terrain::Scene> scene = compiled->scene;
  std::string id = target.get("id");
  if (!id.empty() && !valid_id(id)) {
    return problem(request, http::status::bad_request, "Bad scene id",
                   "scene ids are 1 to 64 characters of a-z, 0-9, '-' and '_'", "/id");
  }
  SceneVersion first;
  first.name = scene->name;
  first.hash = scene->hash;
  first.canonical_json = scene->canonical_text();
  first.author = "api";
  StoreResult<SceneVersion> created = StoreError{};
  if (!id.empty()) {
    created = store_->create_scene(id, first);
  } else {
    // A readable id from the name; a number appended while it is taken.
    const std::string base = slug(first.name);
    for (int n = 1; n < 1000; ++n) {
      id = n == 1 ? base : base + "-" + std::to_string(n);
      created = store_->create_scene(id, first);
      if (created || created.error().kind != StoreError::Kind::conflict) break;
    }
  }
  if (!created) {
    if (created.error().kind == StoreError::Kind::conflict) {
      return problem(request, http::status::conflict, "Scene exists", created.error().message,
                     "/id");
    }
    return store_problem(request, created.error());
  }
  compiled->version = *created;
  compiled->version.canonical_json.clear();
  keep_loaded(*compiled);  // its first tile needs no parse
  Response r = json_response(request, http::status::created,
                             {{"id", created->scene_id},
                              {"version", created->version},
                              {"hash", created->hash},
                              {"url", "/api/v1/scenes/" + created->scene_id}});
  r.set(http::field::location, "/api/v1/scenes/" + created->scene_id);
  r.set(http::field::etag, version_etag(*created));
  return r;
}

Response App::put_scene(const Request& request, const std::string& id) {
  if (!valid_id(id)) {
    return problem(request, http::status::bad_request, "Bad scene id",
                   "PUT names a scene id (no @version): 1 to 64 characters of a-z, 0-9, '-', '_'",
                   "/id");
  }
  if (Response auth = authorize(request); auth.result() != http::status::ok) return auth;
  auto compiled = compile_for_storing(request);
  if (!compiled) return compiled.error();
  const std::shared_ptr<const terrain::Scene> scene = compiled->scene;
  // The live channel's lock puts this version among live edits in one order (docs/live.md).
  auto channel = live_.channel(id);
  auto held = channel->lock();
  StoreResult<SceneVersion> head = store_->head(id);
  if (!head) return store_problem(request, head.error());
  std::optional<std::int64_t> expected;
  if (const auto it = request.find(http::field::if_match); it != request.end()) {
    const std::string_view given(it->value().data(), it->value().size());
    if (given != "*" && given != version_etag(*head)) {
      Response r =
          problem(request, http::status::precondition_failed, "Version mismatch",
                  "the scene is at " + version_etag(*head) + ", not " + std::string(given));
      r.set(http::field::etag, version_etag(*head));
      return r;
    }
    expected = head->version;  // the store refuses if another writer got in between
  }
  SceneVersion next;
  next.name = scene->name;
  next.hash = scene->hash;
  next.canonical_json = scene->canonical_text();
  next.author = "api";
  StoreResult<SceneVersion> stored =
      commit_version(request, *channel, id, std::move(next), expected);
  if (!stored) {
    if (stored.error().kind == StoreError::Kind::conflict) {
      return problem(request, http::status::precondition_failed, "Version mismatch",
                     stored.error().message);
    }
    return store_problem(request, stored.error());
  }
  compiled->version = *stored;
  compiled->version.canonical_json.clear();
  keep_loaded(*compiled);
  Response r =
      json_response(request, http::status::ok,
                    {{"id", stored->scene_id},
                     {"version", stored->version},
                     {"hash", stored->hash},
                     {"url", "/api/v1/scenes/" + id + "@" + std::to_string(stored->version)}});
  r.set(http::field::etag, version_etag(*stored));
  return r;
}

Response App::get_scene(const Request& request, const std::string& ref) {
  auto loaded = resolve(request, ref);
  if (!loaded) return loaded.error();
  const std::string etag = version_etag(loaded->version);
  const bool pinned = ref.find('@') != std::string::npos;
  auto cache_headers = [&](Response& r) {
    r.set(http::field::etag, etag);
    r.set(http::field::cache_control,
          cache_policy(pinned));
  };
  if (etag_matches(request, etag)) {
    Response r = make_response(request, http::status::not_modified, "", "application/json");
    cache_headers(r);
    return r;
  }
  Response r = json_response(request, http::status::ok, loaded->scene->canonical);
  cache_headers(r);
  r.set("X-Scene-Version", std::to_string(loaded->version.version));
  return r;
}

Response App::versions(const Request& request, const std::string& id) {
  if (!valid_id(id)) {
    return problem(request, http::status::bad_request, "Bad scene id", "bad scene id", "/id");
  }
  StoreResult<std::vector<SceneVersion>> all = store_->versions(id);
  if (!all) return store_problem(request, all.error());
  json list = json::array();
  for (const SceneVersion& v : *all) {
    list.push_back({{"version", v.version},
                    {"hash", v.hash},
                    {"name", v.name},
                    {"author", v.author},
                    {"created_ms", v.created_ms},
                    {"url", "/api/v1/scenes/" + id + "@" + std::to_string(v.version)}});
  }
  Response r = json_response(request, http::status::ok, {{"id", id}, {"versions", list}});
  r.set(http::field::cache_control, "no-cache");
  return r;
}

Response App::upload_image(const Request& request) {
  if (Response auth = authorize(request); auth.result() != http::status::ok) return auth;
  const std::string& body = request.body();
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(body.data());
  // Format and dimensions are checked by the decoder's limits before any pixel is decoded.
  terrain::Result<terrain::Raster> raster =
      terrain::decode_heightfield(std::span<const std::uint8_t>(bytes, body.size()), "png");
  if (!raster) {
    return problem(request, http::status::bad_request, "Invalid image", raster.error().message,
                   "/image");
  }
  std::string media = "image/png";
  if (body.size() >= 4 && (body.compare(0, 2, "II") == 0 || body.compare(0, 2, "MM") == 0)) {
    media = "image/tiff";
  } else if (body.size() >= 4 && static_cast<unsigned char>(body[0]) == 0x76 &&
             static_cast<unsigned char>(body[1]) == 0x2f) {
    media = "image/x-exr";
  }
  Blob blob{content_hash(body.data(), body.size()), media,
            std::vector<std::uint8_t>(bytes, bytes + body.size())};
  StoreResult<bool> stored = store_->put_blob(blob);
  if (!stored) return store_problem(request, stored.error());
  return json_response(request, http::status::created,
                       {{"hash", blob.hash},
                        {"media_type", media},
                        {"width", raster->width},
                        {"height", raster->height}});
}

Outcome App::scene_product(const Request& request, const std::string& ref,
                           const std::vector<std::string>& rest, const Target& target) {
  auto loaded_or = resolve(request, ref);
  if (!loaded_or) return loaded_or.error();
  const LoadedVersion loaded = std::move(loaded_or).value();
  const bool pinned = ref.find('@') != std::string::npos;
  const std::string id = loaded.version.scene_id;
  const std::string pinned_ref = id + "@" + std::to_string(loaded.version.version);
  const std::string cache_control =
      cache_policy(pinned);
  const terrain::Program& program = *loaded.source->terrain;

  // JSON products are products too: a strong ETag of the bytes sent (so the gzipped and the
  // plain representation differ) and 304 when the client has them.
  auto finish_json = [&](const json& body, std::string_view media = "application/json") {
    Response r = json_response(request, http::status::ok, body, media);
    r.set(http::field::cache_control, cache_control);
    const std::string etag = product_etag(r.body());
    r.set(http::field::etag, etag);
    if (etag_matches(request, etag)) {
      r.result(http::status::not_modified);
      r.body().clear();
      r.erase(http::field::content_length);
    }
    return r;
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
    return finish_json({{"x", *x},
                        {"y", *y},
                        {"lod", *lod},
                        {"elevation", s.elevation},
                        {"weight", s.weight},
                        {"gradient", {s.elevation_gradient.x, s.elevation_gradient.y}},
                        {"lipschitz", b.elevation_lipschitz},
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
    if (!scheme || *scheme == terrain::TileScheme::geographic) {
      return problem(request, http::status::bad_request, "Bad scheme",
                     "TileJSON describes XYZ tiles: scheme webmercator (default) or local",
                     "/scheme");
    }
    const std::string encoding = target.get("encoding", "terrain-rgb");
    if (encoding != "terrain-rgb" && encoding != "terrarium") {
      return problem(request, http::status::bad_request, "Bad encoding",
                     "TileJSON for raster-dem: encoding terrain-rgb or terrarium", "/encoding");
    }
    terrain::ProductMaker maker(*loaded.source);
    auto origin_or = public_origin(request);
    if (!origin_or) return origin_or.error();
    const std::string origin = std::move(origin_or).value();
    const std::string scheme_name(terrain::scheme_name(*scheme));
    json body{{"tilejson", "3.0.0"},
              {"name", loaded.scene->name},
              {"version", "1.0.0"},
              {"scheme", "xyz"},
              {"tiles",
               {origin + "/api/v1/scenes/" + pinned_ref +
                "/tiles/{z}/{x}/{y}.png?encoding=" + encoding + "&scheme=" + scheme_name}},
              {"minzoom", 0},
              {"maxzoom", maker.constants().max_useful_zoom[static_cast<int>(*scheme)]},
              {"tileSize", 256},
              {"encoding", encoding == "terrain-rgb" ? "mapbox" : "terrarium"}};
    if (*scheme == terrain::TileScheme::webmercator) {
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
  const terrain::TileAddress address = query->address;
  const double samples =
      mesh ? static_cast<double>(options.grid) * options.grid +
                 (options.watermask && loaded.source->water ? 65536.0 : 0.0)
           : static_cast<double>(options.size + 2 * border) * (options.size + 2 * border);
  const double cost = samples * static_cast<double>(std::max<std::size_t>(program.code.size(), 1));
  if (cost > config_.max_cost) {
    return problem(request, http::status::unprocessable_entity, "Too costly",
                   "this product would cost " + std::to_string(static_cast<long long>(cost)) +
                       " (samples x program size), above the limit of " +
                       std::to_string(static_cast<long long>(config_.max_cost)));
  }
  const std::string cache_key = loaded.version.hash + query->key();
  ReplyContext reply = ReplyContext::of(request, cache_control);
  if (query->format == terrain::TileFormat::gray16) {
    reply.gray16 = terrain::gray16_encoding_for(loaded.source->elevation_range);
  }
  reply.negotiated_by_accept = query->format == terrain::TileFormat::quantized_mesh;
  // A pinned version's URL names the same bytes and headers forever; quantized-mesh also
  // depends on Accept.
  if (pinned && query->format != terrain::TileFormat::quantized_mesh) {
    remember_product_route(request, {cache_key, cache_control, reply.gray16});
  }
  auto respond = [reply](const std::shared_ptr<const CachedProduct>& product) {
    return product_response(reply, product);
  };
  const unsigned version = request.version();
  const bool keep_alive = request.keep_alive();

  if (auto hit = cache_.find(cache_key)) return respond(hit);
  if (auto hit = find_shared(cache_key)) {
    cache_.insert(cache_key, hit);
    return respond(hit);
  }
  if (auto reused = reuse_unchanged_tile(loaded, query->key(), query->scheme, address,
                                         query->format, options)) {
    cache_.insert(cache_key, reused);
    return respond(reused);
  }

  auto source = loaded.source;
  const std::string version_hash = loaded.version.hash;
  const terrain::TileScheme s = query->scheme;
  const terrain::TileFormat f = query->format;
  Deferred deferred;
  deferred.cost = cost;
  deferred.work = [=, this]() -> Response {
    thread_local std::unordered_map<std::string, std::unique_ptr<terrain::ProductMaker>> makers;
    if (makers.size() > kMakersPerThread && !makers.contains(version_hash)) makers.clear();
    std::unique_ptr<terrain::ProductMaker>& maker = makers[version_hash];
    if (!maker) {
      maker = std::make_unique<terrain::ProductMaker>(*source);
      maker->set_backend(backend_);
    }
    const auto start = std::chrono::steady_clock::now();
    Result<terrain::Product> product = maker->make(s, address, f, options);
    metrics_.generation(
        terrain::format_info(f).encoding.empty() ? terrain::format_info(f).extension
                                                 : terrain::format_info(f).encoding,
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
        !product                                    ? "cpu"
        : product->backend.starts_with("gpu")       ? "gpu"
        : product->backend.starts_with("cpu (fall") ? "cpu-fallback"
                                                    : "cpu");
    if (!product) {
      Request shadow{http::verb::get, "/", version};
      shadow.keep_alive(keep_alive);
      return problem(shadow, "Bad tile request", product.error());
    }
    auto cached = std::make_shared<CachedProduct>();
    cached->body.assign(product->bytes.begin(), product->bytes.end());
    cached->media_type = product->media_type;
    cached->content_encoding = product->content_encoding;
    cached->etag = product_etag(cached->body);
    cached->file = SealedFile::create(cached->body);
    cached->backend = product->backend;
    cache_.insert(cache_key, cached);
    store_shared(cache_key, *cached);
    return respond(cached);
  };
  return deferred;
}

Outcome App::render(const Request& request, const LoadedVersion& loaded, const Target& target,
                    PictureProduct product) {
  auto bad = [&](const char* pointer, const std::string& detail) -> Outcome {
    return problem(request, http::status::bad_request, "Bad picture request", detail, pointer);
  };
  int width = 640, height = 400;
  if (const std::string w = target.get("width"); !w.empty()) {
    const auto v = parse_integer<int>(w);
    if (!v || *v < 16 || *v > 1920) return bad("/width", "width must be 16 to 1920 pixels");
    width = *v;
  }
  if (const std::string h = target.get("height"); !h.empty()) {
    const auto v = parse_integer<int>(h);
    if (!v || *v < 16 || *v > 1080) return bad("/height", "height must be 16 to 1080 pixels");
    height = *v;
  }
  const terrain::Program& program = *loaded.source->terrain;
  const terrain::Box2 area = loaded.scene->area();
  terrain::Camera camera = terrain::default_camera(program, area, width, height);
  auto vector3 = [&](const char* key, terrain::Vec3& out) -> bool {
    const std::string text = target.get(key);
    if (text.empty()) return true;
    double v[3];
    std::size_t start = 0;
    for (int i = 0; i < 3; ++i) {
      const std::size_t comma = text.find(',', start);
      if ((i < 2) == (comma == std::string::npos)) return false;
      const auto d = parse_double(std::string_view(text).substr(start, comma - start));
      if (!d || std::abs(*d) > 1e7) return false;
      v[i] = *d;
      start = comma + 1;
    }
    out = {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])};
    return true;
  };
  if (!vector3("eye", camera.position)) return bad("/eye", "eye must be x,y,z in scene metres");
  if (!vector3("target", camera.target)) {
    return bad("/target", "target must be x,y,z in scene metres");
  }
  if (const std::string f = target.get("fov"); !f.empty()) {
    const auto v = parse_double(f);
    if (!v || *v < 5 || *v > 120) return bad("/fov", "fov must be 5 to 120 degrees");
    camera.vertical_fov_degrees = static_cast<float>(*v);
  }
  terrain::RenderOptions options;
  options.threads = 1;  // the generation pool provides the parallelism
  if (const std::string w = target.get("water"); !w.empty()) {
    const auto v = parse_double(w);
    if (!v || std::abs(*v) > 1e5) return bad("/water", "water must be an elevation in metres");
    options.water_level = static_cast<float>(*v);
  }
  // A picture's work is its sphere-tracing steps, each an evaluation of the program: it is
  // costed by the steps it may take (picture_steps_per_pixel on average) and stopped there,
  // so that the estimate is a bound, whatever the camera and the tightness of the terrain's
  // Lipschitz bounds.
  const std::int64_t pixels = static_cast<std::int64_t>(width) * height;
  const std::int64_t step_budget = pixels * config_.picture_steps_per_pixel;
  const double cost = static_cast<double>(step_budget) *
                      static_cast<double>(std::max<std::size_t>(program.code.size(), 1));
  if (cost > config_.max_picture_cost) {
    return problem(request, http::status::unprocessable_entity, "Too costly",
                   "this picture may cost " + std::to_string(static_cast<long long>(cost)) +
                       " (pixels x " + std::to_string(config_.picture_steps_per_pixel) +
                       " steps x program size), above the limit of " +
                       std::to_string(static_cast<long long>(config_.max_picture_cost)) +
                       ": ask for fewer pixels",
                   "/width");
  }
  const bool pinned = request.target().find('@') != boost::beast::string_view::npos;
  const bool depth = product == PictureProduct::depth;
  // Pictures are products: cached by what decides their bytes, answered with ETag and 304.
  auto bits = [](float v) {
    char text[16];
    std::snprintf(text, sizeof text, "%08x", std::bit_cast<std::uint32_t>(v));
    return std::string(text);
  };
  const std::string cache_key =
      loaded.version.hash + "/picture." + (depth ? "depth" : "png") + "/" + std::to_string(width) +
      "x" + std::to_string(height) + "/" + bits(camera.position.x) + bits(camera.position.y) +
      bits(camera.position.z) + bits(camera.target.x) + bits(camera.target.y) +
      bits(camera.target.z) + bits(camera.vertical_fov_degrees) + bits(options.water_level) + "/" +
      std::to_string(config_.picture_steps_per_pixel);
  const ReplyContext reply =
      ReplyContext::of(request, cache_policy(pinned));
  auto respond = [reply, depth, width, height](const std::shared_ptr<const CachedProduct>& p) {
    Response r = product_response(reply, p);
    if (depth) r.set("X-Picture-Size", std::to_string(width) + "x" + std::to_string(height));
    return r;
  };
  if (auto hit = cache_.find(cache_key)) return respond(hit);
  if (auto hit = find_shared(cache_key)) {
    cache_.insert(cache_key, hit);
    return respond(hit);
  }
  auto source = loaded.source;
  Deferred deferred;
  deferred.cost = cost;
  deferred.lane = Deferred::Lane::picture;
  options.step_budget = step_budget;
  options.cancel = deferred.abandoned.get();
  deferred.work = [=, this, abandoned = deferred.abandoned]() -> Response {
    const auto start = std::chrono::steady_clock::now();
    // The GPU tracer when the server has a GPU backend; the CPU when there is none or it fails
    // (unsupported program, lost context, llvmpipe's loop limit), and the response says which.
    terrain::Picture picture;
    std::string produced = "cpu";
    bool traced = false;
    if (backend_) {
      Result<terrain::Picture> gpu_picture =
          backend_->render(*source->terrain, area, camera, options);
      if (gpu_picture) {
        picture = std::move(gpu_picture).value();
        produced = backend_->name();
        traced = true;
      } else {
        produced = "cpu (fallback: " + gpu_picture.error().message + ")";
      }
    }
    if (!traced) picture = terrain::render(*source->terrain, area, camera, options);
    const Request shadow = reply.shadow();
    if (picture.stopped == terrain::Picture::Stop::cancelled) {
      return problem(shadow, http::status::service_unavailable, "Abandoned",
                     "the client left before the picture was done");
    }
    if (picture.stopped == terrain::Picture::Stop::budget) {
      return problem(shadow, http::status::unprocessable_entity, "Too costly",
                     "the picture needed more than " + std::to_string(step_budget) +
                         " sphere-tracing steps (" +
                         std::to_string(config_.picture_steps_per_pixel) +
                         " per pixel, generation.picture_steps_per_pixel): ask for fewer pixels "
                         "or a camera nearer the terrain",
                     "/width");
    }
    auto cached = std::make_shared<CachedProduct>();
    if (depth) {
      // Ray distances as little-endian float32, row-major from the top-left pixel.
      cached->body.assign(picture.depth.size() * sizeof(float), '\0');
      for (std::size_t i = 0; i < picture.depth.size(); ++i) {
        const auto value = std::bit_cast<std::uint32_t>(picture.depth[i]);
        for (std::size_t k = 0; k < 4; ++k) {
          cached->body[4 * i + k] = static_cast<char>((value >> (8 * k)) & 0xffu);
        }
      }
      cached->media_type = "application/octet-stream";
    } else {
      auto png = terrain::encode_png_rgb8(picture.width, picture.height, picture.rgb.data());
      if (!png) {
        return problem(shadow, http::status::internal_server_error, "Encoding failed",
                       png.error().message);
      }
      cached->body.assign(png->begin(), png->end());
      cached->media_type = "image/png";
    }
    metrics_.generation(
        depth ? "depth" : "render",
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
        traced ? "gpu" : (backend_ ? "cpu-fallback" : "cpu"));
    cached->etag = product_etag(cached->body);
    cached->file = SealedFile::create(cached->body);
    cached->backend = produced;
    cache_.insert(cache_key, cached);
    store_shared(cache_key, *cached);
    return respond(cached);
  };
  return deferred;
}

terrain::Status App::seed_examples() {
  StoreResult<bool> empty = store_->empty();
  if (!empty) return Error{empty.error().message, ""};
  if (!*empty) return seed_planets();
  std::error_code ec;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(config_.scenes_dir, ec)) {
    if (entry.path().extension() == ".json") files.push_back(entry.path());
  }
  if (ec) return Error{"cannot read " + config_.scenes_dir + ": " + ec.message(), ""};
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    std::ifstream in(file);
    json document = json::parse(in, nullptr, false);  // a built-in file
    if (document.is_discarded()) return Error{file.string() + ": not JSON", ""};
    std::vector<std::string> images;
    collect_images(document, images);
    std::map<std::string, std::string> hashes;
    for (const std::string& image : images) {
      const fs::path path = file.parent_path() / image;
      std::ifstream img(path, std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(img)),
                              std::istreambuf_iterator<char>());
      if (!img && bytes.empty()) return Error{"cannot read " + path.string(), ""};
      Blob blob{content_hash(bytes.data(), bytes.size()), "image/png",
                std::vector<std::uint8_t>(bytes.begin(), bytes.end())};
      if (StoreResult<bool> s = store_->put_blob(blob); !s) return Error{s.error().message, ""};
      hashes[image] = blob.hash;
    }
    rewrite_images(document, hashes);
    auto scene = parse_stored(document.dump());
    if (!scene) return Error{file.string() + ": " + scene.error().message, scene.error().pointer};
    SceneVersion first;
    first.name = (*scene)->name;
    first.hash = (*scene)->hash;
    first.canonical_json = (*scene)->canonical_text();
    first.author = "built-in";
    StoreResult<SceneVersion> created = store_->create_scene(file.stem().string(), first);
    // A conflict means another replica sharing the store (PostgreSQL) seeded it meanwhile.
    if (!created && created.error().kind != StoreError::Kind::conflict) {
      return Error{created.error().message, ""};
    }
  }
  return seed_planets();
}

// ---------------------------------------------------------------------------------------------
// Planets: definitions stored by content hash, products on the geographic tiling.

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
  auto cache_headers = [&](Response& r) {
    r.set(http::field::etag, etag);
    r.set(http::field::cache_control, ref == id ? kImmutable : kAliasCacheControl);
    if (ref != id) r.set(http::field::content_location, "/api/v1/planets/" + id);
  };
  if (etag_matches(request, etag)) {
    Response r = make_response(request, http::status::not_modified, "", "application/json");
    cache_headers(r);
    return r;
  }
  // The canonical text is sent as stored (never re-serialised, never compressed: it is small
  // and its bytes are what the id hashes).
  Response r = make_response(request, http::status::ok, stored->canonical_json, "application/json");
  cache_headers(r);
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
  const std::string cache_control = ref == id ? kImmutable : kAliasCacheControl;
  const std::string base = "/api/v1/planets/" + id;

  auto finish_json = [&](const json& body) {
    Response r = json_response(request, http::status::ok, body);
    r.set(http::field::cache_control, cache_control);
    const std::string etag = product_etag(r.body());
    r.set(http::field::etag, etag);
    if (etag_matches(request, etag)) {
      r.result(http::status::not_modified);
      r.body().clear();
      r.erase(http::field::content_length);
    }
    return r;
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
  if (rest.size() == 1 && rest[0] == "tilejson.json") {
    const std::string scheme = target.get("scheme", "geographic");
    if (scheme != "geographic" && scheme != "webmercator") {
      return problem(request, http::status::bad_request, "Bad scheme",
                     "planet TileJSON: scheme geographic (EPSG:4326 TMS, default) or webmercator "
                     "(EPSG:3857 XYZ, for MapLibre)",
                     "/scheme");
    }
    const std::string encoding = target.get("encoding", "terrain-rgb");
    if (encoding != "terrain-rgb" && encoding != "terrarium") {
      return problem(request, http::status::bad_request, "Bad encoding",
                     "TileJSON for height tiles: encoding terrain-rgb or terrarium", "/encoding");
    }
    auto origin_or = public_origin(request);
    if (!origin_or) return origin_or.error();
    const std::string origin = std::move(origin_or).value();
    if (scheme == "webmercator") {  // MapLibre's raster-dem sources are EPSG:3857 only
      const double limit =
          terrain::web_mercator_latitude(std::numbers::pi * terrain::kWebMercatorRadius);
      return finish_json(
          {{"tilejson", "3.0.0"},
           {"name", "planet " + id.substr(0, 12)},
           {"description", "Web Mercator (EPSG:3857) XYZ height tiles of seeded planet " + id},
           {"version", "1.0.0"},
           {"scheme", "xyz"},
           {"tiles",
            {origin + base + "/tiles/{z}/{x}/{y}.png?scheme=webmercator&encoding=" + encoding}},
           {"minzoom", 0},
           {"maxzoom", terrain::max_zoom(terrain::TileScheme::webmercator)},
           {"tileSize", 256},
           {"bounds", {-180.0, -limit, 180.0, limit}},
           {"center", {20.0, 15.0, 2}},
           {"encoding", encoding == "terrain-rgb" ? "mapbox" : "terrarium"}});
    }
    // Geographic TMS tiles (EPSG:4326, two tiles at zoom 0, rows counted from the south): for
    // Cesium and GIS clients.
    return finish_json({{"tilejson", "3.0.0"},
                        {"name", "planet " + id.substr(0, 12)},
                        {"description",
                         "geographic (EPSG:4326) TMS height tiles, two at zoom 0; for MapLibre "
                         "ask for scheme=webmercator"},
                        {"version", "1.0.0"},
                        {"scheme", "tms"},
                        {"crs", "EPSG:4326"},
                        {"tiles", {origin + base + "/tiles/{z}/{x}/{y}.png?encoding=" + encoding}},
                        {"minzoom", 0},
                        {"maxzoom", planet::PlanetTiles::max_zoom()},
                        {"tileSize", 256},
                        {"bounds", {-180.0, -90.0, 180.0, 90.0}},
                        {"center", {0.0, 0.0, 1}},
                        {"encoding", encoding == "terrain-rgb" ? "mapbox" : "terrarium"}});
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
      const Request shadow = reply_base.shadow();
      Response r = json_response(shadow, http::status::ok, body);
      r.set(http::field::cache_control, reply_base.cache_control);
      const std::string etag = product_etag(r.body());
      r.set(http::field::etag, etag);
      if (etag_matches(shadow, etag)) {
        r.result(http::status::not_modified);
        r.body().clear();
        r.erase(http::field::content_length);
      }
      return r;
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
  // "planet:" keeps planet keys apart from scene keys (which start with "sha256:").
  const std::string cache_key = "planet:" + id + query->key();
  ReplyContext reply = reply_base;
  if (query->format == terrain::TileFormat::gray16) {
    reply.gray16 = terrain::gray16_encoding_for(world->elevation_range());
  }
  reply.negotiated_by_accept = query->format == terrain::TileFormat::quantized_mesh;
  // An id's URL names the same bytes and headers forever (the alias may change at a restart);
  // quantized-mesh also depends on Accept.
  if (ref == id && query->format != terrain::TileFormat::quantized_mesh) {
    remember_product_route(request, {cache_key, cache_control, reply.gray16});
  }
  if (auto hit = cache_.find(cache_key)) return product_response(reply, hit);
  if (auto hit = find_shared(cache_key)) {
    cache_.insert(cache_key, hit);
    return product_response(reply, hit);
  }
  const terrain::TileScheme scheme = query->scheme;
  const terrain::TileAddress address = query->address;
  const terrain::TileFormat format = query->format;
  Deferred deferred;
  deferred.cost = cost;
  deferred.work = [=, this]() -> Response {
    // One PlanetTiles per planet and thread: it keeps refined triangles between tiles (the
    // bytes never depend on them), and is not thread-safe.
    thread_local std::unordered_map<std::string, std::unique_ptr<planet::PlanetTiles>> tilers;
    if (tilers.size() >= kPlanetWorkersPerThread && !tilers.contains(id)) tilers.clear();
    std::unique_ptr<planet::PlanetTiles>& tiles = tilers[id];
    if (!tiles) tiles = std::make_unique<planet::PlanetTiles>(world);
    const auto start = std::chrono::steady_clock::now();
    Result<terrain::Product> product = tiles->make(scheme, address, format, options);
    const terrain::TileFormatInfo& info = terrain::format_info(format);
    metrics_.generation(
        "planet_" + std::string(info.encoding.empty() ? info.extension : info.encoding),
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), "cpu");
    if (!product) {
      return problem(reply.shadow(), "Bad tile request", product.error());
    }
    auto cached = std::make_shared<CachedProduct>();
    cached->body.assign(product->bytes.begin(), product->bytes.end());
    cached->media_type = product->media_type;
    cached->content_encoding = product->content_encoding;
    cached->etag = product_etag(cached->body);
    cached->file = SealedFile::create(cached->body);
    cached->backend = "cpu";  // planets have no GPU path yet
    cache_.insert(cache_key, cached);
    store_shared(cache_key, *cached);
    return product_response(reply, cached);
  };
  return deferred;
}

Response App::node_types(const Request& request) const {
  // The registry, for clients that build or edit scenes (the browser's editor picks what it can
  // move by category): the same list the parser, the compiler and the shaders are driven by.
  static const std::string text = [] {
    json types = json::array();
    for (const terrain::NodeType* type : terrain::node_types()) {
      static constexpr const char* kCategories[] = {"primitive", "blend", "binary", "warp"};
      json entry{
          {"id", type->id},
          {"name", type->name},
          {"category", kCategories[static_cast<int>(type->category)]},
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
  return json_text_response(request, text, "public, max-age=60");
}

Response App::trace_glsl(const Request& request) const {
  // The node functions, the interpreter and the tracer: the very text the server's compute
  // shaders are built from, for the browser to put after its own texture-reading prelude.
  static const std::string text =
      std::string(gpu::shared_glsl()) + "\n" + std::string(gpu::trace_glsl());
  static const std::string etag = product_etag(text);
  if (etag_matches(request, etag)) {
    Response r = make_response(request, http::status::not_modified, "", "text/plain");
    r.set(http::field::etag, etag);
    return r;
  }
  Response r = make_response(request, http::status::ok, text, "text/plain; charset=utf-8");
  r.set(http::field::etag, etag);
  r.set(http::field::cache_control, "public, max-age=60");
  return r;
}

// GET …/trace.json: everything a browser needs to sphere-trace the scene itself, as
// terrain::render and the GPU tracer do — the program, its pool as shaders read it, the
// Lipschitz grid of local bounds, the traced domain and options, and a default camera. The grid
// walks the program over the whole area, so the bundle is built on the generation pool once per
// version and cached like a tile.
Outcome App::trace_bundle(const Request& request, const LoadedVersion& loaded, bool pinned) {
  // The bundle names its version (and author), which two versions of equal content do not share.
  const std::string key = loaded.version.hash + "|trace.json|" + loaded.version.scene_id + "@" +
                          std::to_string(loaded.version.version);
  const std::string cache_control =
      cache_policy(pinned);
  Request shadow{http::verb::get, "/", request.version()};
  shadow.keep_alive(request.keep_alive());
  for (const http::field f : {http::field::accept_encoding, http::field::if_none_match}) {
    if (const auto it = request.find(f); it != request.end()) shadow.set(f, it->value());
  }
  auto respond = [shadow, cache_control](const CachedProduct& p) {
    Response r = json_text_response(shadow, p.body, cache_control);
    r.set("X-Terrain-Backend", p.backend);
    return r;
  };
  if (auto hit = cache_.find(key)) return respond(*hit);
  auto source = loaded.source;
  const terrain::Box2 area = loaded.scene->area();
  const std::string scene_id = loaded.version.scene_id;
  const std::int64_t version = loaded.version.version;
  const std::string hash = loaded.version.hash;
  const std::string author = loaded.version.author;
  const std::int64_t created_ms = loaded.version.created_ms;
  Deferred deferred;
  deferred.cost = static_cast<double>(source->terrain->code.size()) * 64.0 * 64.0 * 5.0;
  deferred.work = [=, this]() -> Response {
    const terrain::Program& program = *source->terrain;
    terrain::Evaluator evaluator(program);
    const terrain::LipschitzGrid grid(evaluator, area);
    const std::vector<float> bounds = grid.pack();
    const std::vector<float> pool = gpu::prepare_pool(program);
    const terrain::TraceDomain domain = terrain::trace_domain(program, area);
    const terrain::TraceOptions defaults;
    const float span = std::max(area.size().x, area.size().y);
    const terrain::Camera camera = terrain::default_camera(program, area, 640, 400);
    const terrain::Vec3 sun = terrain::sun_direction();
    const auto [fields, frames] = gpu::shader_stacks(program);
    // What the browser's tracer builds its shader from besides the shared GLSL: the node types
    // and fractal kinds the program uses, the program unrolled, and whether unrolling pays
    // (gpu/program_glsl.hpp, docs/client.md).
    terrain::Result<std::string> program_glsl = gpu::specialised_program_glsl(program);
    json body{{"scene_id", scene_id},
              {"version", version},
              {"hash", hash},
              {"author", author},
              {"created_ms", created_ms},
              {"code", terrain::base64(program.code.data(),
                                       program.code.size() * sizeof(terrain::Instruction))},
              {"pool", terrain::base64(pool.data(), pool.size() * sizeof(float))},
              {"bounds", terrain::base64(bounds.data(), bounds.size() * sizeof(float))},
              {"stacks", {{"fields", fields}, {"frames", frames}}},
              {"setup",
               {{"area", {domain.area.lo.x, domain.area.lo.y, domain.area.hi.x, domain.area.hi.y}},
                {"elevation", {domain.elevation.lo, domain.elevation.hi}},
                {"epsilon", defaults.epsilon},
                {"max_steps", defaults.max_steps},
                {"initial_step", defaults.initial_step},
                {"t_max", std::min(defaults.t_max, 4.0f * span + 1e4f)},
                {"water_level", terrain::RenderOptions{}.water_level},
                {"span", span},
                {"sun", {sun.x, sun.y, sun.z}}}},
              {"camera",
               {{"eye", {camera.position.x, camera.position.y, camera.position.z}},
                {"target", {camera.target.x, camera.target.y, camera.target.z}},
                {"fov", camera.vertical_fov_degrees}}}};
    if (program_glsl) body["program_glsl"] = *program_glsl;
    body["glsl_defines"] = gpu::node_type_defines(program);
    body["unroll_pays"] = gpu::unroll_pays(program);
    auto cached = std::make_shared<CachedProduct>();
    cached->body = body.dump();
    cached->media_type = "application/json";
    cached->etag = product_etag(cached->body);
    cached->backend = "cpu";
    cache_.insert(key, cached);
    return respond(*cached);
  };
  return deferred;
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

std::string App::redis_metrics() const {
  if (!redis_) return "";
  std::ostringstream out;
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
