#include "app_http.hpp"

#include <span>

#include "terrain/gzip.hpp"
#include "terrain/scene.hpp"

namespace server {

using detail::ReplyContext;
using detail::TileQuery;

std::string detail::quote(std::string_view s) {
  return "\"" + std::string(s) + "\"";
}

bool detail::accepts_gzip(const Request& request) {
  const auto it = request.find(http::field::accept_encoding);
  return it != request.end() && it->value().find("gzip") != boost::beast::string_view::npos;
}

std::string detail::percent_decode(std::string_view in, bool plus_is_space, bool& ok) {
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

std::optional<double> detail::parse_double(std::string_view text) {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty() || !std::isfinite(v)) {
    return std::nullopt;
  }
  return v;
}

std::string detail::version_etag(const SceneVersion& v) {
  return quote(v.hash);
}

bool detail::none_match_names(std::string_view header, std::string_view etag) {
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

std::string_view detail::if_none_match(const Request& request) {
  const auto it = request.find(http::field::if_none_match);
  return it == request.end() ? std::string_view()
                             : std::string_view(it->value().data(), it->value().size());
}

std::string detail::product_etag(std::string_view body) {
  return quote("g" + std::to_string(terrain::kProductGeneration) + "-" +
               terrain::sha256_hex(body).substr(0, 32));
}

Response detail::json_text_response(const Request& request, const std::string& text,
                                    std::string_view cache_control, std::string_view media_type) {
  Response r = make_response(request, http::status::ok, "", media_type);
  r.set(http::field::vary, "Accept-Encoding, Origin");
  r.set(http::field::cache_control, cache_control);
  std::string sent = text;
  if (accepts_gzip(request) && text.size() > 1024) {
    if (auto packed = terrain::gzip_compress(std::string_view(text), 6)) {
      r.set(http::field::content_encoding, "gzip");
      sent.assign(packed->begin(), packed->end());
    }
  }
  if (answer_conditionally(request, r, product_etag(sent))) return r;
  r.body() = std::move(sent);
  r.prepare_payload();
  return r;
}

std::string detail::query_value(const std::map<std::string, std::string>& query,
                                const std::string& key, const std::string& fallback) {
  auto it = query.find(key);
  return it == query.end() ? fallback : it->second;
}

std::string detail::TileJsonImages::tiles_path() const {
  return "/tiles/{z}/{x}/{y}." + extension + "?encoding=" + encoding;
}

void detail::TileJsonImages::describe(nlohmann::json& tilejson) const {
  if (!color) tilejson["encoding"] = encoding == "terrain-rgb" ? "mapbox" : "terrarium";
}

terrain::Result<detail::TileJsonImages, Response> detail::parse_tilejson_images(
    const Request& request, const std::map<std::string, std::string>& query) {
  TileJsonImages images;
  images.encoding = query_value(query, "encoding", "terrain-rgb");
  images.color = images.encoding == "color";
  if (!images.color && images.encoding != "terrain-rgb" && images.encoding != "terrarium") {
    return problem(request, http::status::bad_request, "Bad encoding",
                   "TileJSON describes height tiles (encoding terrain-rgb or terrarium, for "
                   "raster-dem sources) or colour imagery (encoding color, for raster sources)",
                   "/encoding");
  }
  images.extension = query_value(query, "format", "png");
  if (images.extension != "png" && (images.extension != "jpg" || !images.color)) {
    return problem(request, http::status::bad_request, "Bad format",
                   images.color ? "colour imagery comes as png (default) or jpg"
                                : "height tiles come as png only",
                   "/format");
  }
  return images;
}

terrain::Result<detail::TileQuery, Response> detail::parse_tile_query(
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

detail::ReplyContext detail::ReplyContext::of(const Request& request, const char* cache_control) {
  ReplyContext c;
  c.version = request.version();
  c.keep_alive = request.keep_alive();
  c.gzip_ok = accepts_gzip(request);
  c.if_none_match = std::string(detail::if_none_match(request));
  c.cache_control = cache_control;
  return c;
}

Request detail::ReplyContext::shadow() const {
  Request r{http::verb::get, "/", version};
  if (!if_none_match.empty()) r.set(http::field::if_none_match, if_none_match);
  if (gzip_ok) r.set(http::field::accept_encoding, "gzip");
  r.keep_alive(keep_alive);
  return r;
}

bool detail::answer_conditionally(std::string_view if_none_match, Response& response,
                                  std::string_view etag) {
  response.set(http::field::etag, etag);
  if (!none_match_names(if_none_match, etag)) return false;
  response.result(http::status::not_modified);
  response.body().clear();
  response.erase(http::field::content_length);
  return true;
}

bool detail::answer_conditionally(const Request& request, Response& response,
                                  std::string_view etag) {
  return answer_conditionally(if_none_match(request), response, etag);
}

CachedProduct detail::product_bytes(terrain::Product product) {
  CachedProduct bytes;
  bytes.body.assign(product.bytes.begin(), product.bytes.end());
  bytes.media_type = std::move(product.media_type);
  bytes.content_encoding = std::move(product.content_encoding);
  bytes.backend = std::move(product.backend);
  return bytes;
}

Response detail::product_response(const ReplyContext& c,
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
  r.set(http::field::cache_control, c.cache_control);
  // A shared cache must not hand one client's quantized-mesh extensions to another.
  r.set(http::field::vary,
        c.negotiated_by_accept ? "Accept, Accept-Encoding, Origin" : "Accept-Encoding, Origin");
  if (c.gray16) {
    r.set("X-Gray16-Offset", std::to_string(c.gray16->offset));
    r.set("X-Gray16-Scale", std::to_string(c.gray16->scale));
  }
  if (answer_conditionally(c.if_none_match, r, etag)) return r;
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

}  // namespace server
