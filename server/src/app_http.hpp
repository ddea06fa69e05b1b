// What the App's files share of HTTP: ETags and conditional requests, tile queries, and the
// responses of products (app.cpp, app_scenes.cpp, app_pictures.cpp, app_planets.cpp,
// app_live.cpp). The definitions are in app_http.cpp.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "app_support.hpp"
#include "server/cache.hpp"
#include "terrain/tile_image.hpp"
#include "terrain/tile_products.hpp"

namespace server::detail {

std::string quote(std::string_view s);

bool accepts_gzip(const Request& request);

std::string percent_decode(std::string_view in, bool plus_is_space, bool& ok);

std::optional<double> parse_double(std::string_view text);

std::string version_etag(const SceneVersion& v);

// Whether an If-None-Match value names this entity tag.
bool none_match_names(std::string_view header, std::string_view etag);

std::string_view if_none_match(const Request& request);

// The bytes' hash, under the product generation that made them.
std::string product_etag(std::string_view body);

// A JSON product from its text: gzipped when the client takes it and it is worth it, a strong
// ETag of the bytes sent (the gzipped and the plain representation differ), 304 when the client
// has them.
Response json_text_response(const Request& request, const std::string& text,
                            std::string_view cache_control);

std::string query_value(const std::map<std::string, std::string>& query, const std::string& key,
                        const std::string& fallback = "");

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
    const std::map<std::string, std::string>& query, bool planet);

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
Response product_response(const ReplyParts& c, const std::shared_ptr<const CachedProduct>& product);

Response product_response(const ReplyContext& c,
                          const std::shared_ptr<const CachedProduct>& product);

}  // namespace server::detail
