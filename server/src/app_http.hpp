// What the App's files share of HTTP: ETags and conditional requests, tile queries, and the
// responses of products (app.cpp, app_scenes.cpp, app_pictures.cpp, app_planets.cpp,
// app_live.cpp). The definitions are in app_http.cpp.
#pragma once

#include <atomic>
#include <functional>
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
                            std::string_view cache_control,
                            std::string_view media_type = "application/json");

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

// What a TileJSON describes: height images for raster-dem sources (encoding terrain-rgb, the
// default, or terrarium; PNG) or colour imagery for raster sources (encoding color; format png,
// the default, or jpg).
struct TileJsonImages {
  std::string encoding;
  std::string extension;  ///< "png" or "jpg"
  bool color = false;
  // The tiles' URL from the product onward: "/tiles/{z}/{x}/{y}.png?encoding=color".
  std::string tiles_path() const;
  // TileJSON's fields for these images: raster-dem's "encoding" for heights.
  void describe(nlohmann::json& tilejson) const;
};
terrain::Result<TileJsonImages, Response> parse_tilejson_images(
    const Request& request, const std::map<std::string, std::string>& query);

// Parses /tiles/{z}/{x}/{y}.{ext} or /mesh/{z}/{x}/{y}.{ext} (rest = those four segments) with
// the query's scheme, encoding, size, border, grid and max_error. `planet`: geographic is the
// default scheme and local is refused (PlanetTiles::validate checks the rest).
terrain::Result<TileQuery, Response> parse_tile_query(
    const Request& request, const std::vector<std::string>& rest,
    const std::map<std::string, std::string>& query, bool planet);

// What a response needs of its request, copied so that deferred work outlives the request: the
// one way a reply carries its request's context once the request is gone.
struct ReplyContext {
  unsigned version = 11;
  bool keep_alive = false;
  bool gzip_ok = false;
  std::string if_none_match;
  /// One of the static policies (kImmutable, …): a pointer, so that no temporary string binds.
  const char* cache_control = kHeadCacheControl;
  std::optional<terrain::Gray16Encoding> gray16;  ///< X-Gray16-* headers for gray16 PNGs
  bool negotiated_by_accept = false;              ///< quantized-mesh: Accept chose the extensions

  static ReplyContext of(const Request& request, const char* cache_control);
  /// A request that problems and JSON responses can be built from: the version, keep-alive,
  /// If-None-Match and gzip acceptance of the original.
  Request shadow() const;
};

// Conditional GET in one place: sets the strong ETag, and when If-None-Match names it turns the
// response into its 304 (every header a 200 would carry, no body). True when it did.
bool answer_conditionally(std::string_view if_none_match, Response& response,
                          std::string_view etag);
bool answer_conditionally(const Request& request, Response& response, std::string_view etag);

// A product's bytes and headers as the caches keep them (the pipeline adds the ETag and file).
CachedProduct product_bytes(terrain::Product product);

// The response for a product, fresh or cached: strong ETag, 304, gzip as stored or inflated.
Response product_response(const ReplyContext& c,
                          const std::shared_ptr<const CachedProduct>& product);

}  // namespace server::detail

namespace server {

struct App::ProductJob {
  std::string key;  ///< the cache key: the content hash and everything else that shapes the bytes
  detail::ReplyContext reply;
  double cost = 0.0;  ///< in the pool's units, checked against the limits already
  Deferred::Lane lane = Deferred::Lane::product;
  std::string metric;  ///< what /metrics counts the generation time under
  /// After the caches miss, on the I/O thread: the bytes found another cheap way (a tile that an
  /// edit left untouched), or null.
  std::function<std::shared_ptr<const CachedProduct>()> reuse = {};
  /// On a worker thread: the product's body, media type, content encoding and backend (the
  /// pipeline adds the ETag and the sealed file), or the response that refuses it. `abandoned`
  /// turns true when the client has gone.
  std::function<terrain::Result<CachedProduct, Response>(const std::atomic<bool>& abandoned)> make;
  /// The response of a product (product_response, unless the product needs more headers).
  std::function<Response(const detail::ReplyContext&, const std::shared_ptr<const CachedProduct>&)>
      respond = detail::product_response;
};

}  // namespace server
