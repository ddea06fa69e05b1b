// What app.cpp shares with the other files of the App (app_live.cpp).
#pragma once

#include <charconv>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/app.hpp"
#include "terrain/tile_products.hpp"

namespace server {

/// A request target split into path segments and decoded query parameters.
struct App::Target {
  std::vector<std::string> segments;
  std::map<std::string, std::string> query;
  bool folder = false;  ///< the path ends with '/' (a static folder's index page)
  std::string get(const std::string& key, const std::string& fallback = "") const {
    auto it = query.find(key);
    return it == query.end() ? fallback : it->second;
  }
};

}  // namespace server

namespace server::detail {

/// Cache policies. A pinned version (`id@3`, `id@sha256:…`) never changes: immutable.
inline constexpr const char* kImmutable = "public, max-age=31536000, immutable";
/// A head ref (`id`) moves with every new version: a short life, then revalidation.
inline constexpr const char* kHeadCacheControl = "public, max-age=5, must-revalidate";
/// "default" names whatever config/planets/default.json holds, which a restart may change.
inline constexpr const char* kAliasCacheControl = "public, max-age=60, must-revalidate";
/// What a server release may change (the client's files, the node types, the shared GLSL).
inline constexpr const char* kReleaseCacheControl = "public, max-age=60";
/// The policy of a product of a pinned version or of a head ref.
inline const char* cache_policy(bool pinned) {
  return pinned ? kImmutable : kHeadCacheControl;
}

/// A response of the request's HTTP version and keep-alive, with the server's name.
Response make_response(const Request& request, http::status status, Payload body,
                       std::string_view media_type);

/// Whether the request's If-None-Match names this entity tag.
bool etag_matches(const Request& request, std::string_view etag);

/// JSON the server reads back (stored rows, events from other replicas) with the same bounds as
/// request bodies (terrain::parse_json_text); a discarded value when refused.
nlohmann::json parse_bounded_json(std::string_view text);

/// A whole decimal integer of type T, or nullopt (no sign but '-', no spaces, no suffix).
template <class T>
std::optional<T> parse_integer(std::string_view text) {
  T v{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
  return v;
}

/// Scene ids: 1 to 64 characters of a-z, 0-9, '-' and '_'.
bool valid_id(std::string_view id);

/// The problem a store error answers with: 404, 412 (conflict) or 503 with Retry-After.
Response store_problem(const Request& request, const StoreError& e, std::string_view pointer = "");

/// A JSON answer, gzipped when the client accepts it and the body is worth compressing.
Response json_response(const Request& request, http::status status, const nlohmann::json& body,
                       std::string_view media_type = "application/json");

/// What a tile URL asks for, beyond its scene.
struct TileShape {
  terrain::TileScheme scheme{};
  terrain::TileAddress address{};
  terrain::TileFormat format{};
  terrain::ProductOptions options;
};
/// Parses /tiles/{z}/{x}/{y}.{ext} or /mesh/{z}/{x}/{y}.{ext} (`rest`, four segments) with its
/// query (scheme, encoding, size, border, grid, max_error) as a scene tile request; the
/// refusal names the field.
terrain::Result<TileShape, Response> tile_shape(const Request& request,
                                                const std::vector<std::string>& rest,
                                                const std::map<std::string, std::string>& query);

}  // namespace server::detail
