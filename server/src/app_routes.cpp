// The route table: every route of the v1 contract once — method, pattern, metrics label, body
// limit, whether a read first loads its scene version, and the handler. Routing, the labels in
// /metrics and the body limits the session applies before reading a byte all come from it.
#include <algorithm>
#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "app_http.hpp"
#include "app_support.hpp"

namespace server {

std::string_view openapi_document();  // generated from server/resources/openapi.json

using detail::make_response;

namespace {

// A path's segments; trailing and doubled slashes make no empty segments.
std::vector<std::string_view> split_path(std::string_view path) {
  std::vector<std::string_view> out;
  while (!path.empty()) {
    const std::size_t slash = path.find('/');
    const std::string_view segment = path.substr(0, slash);
    if (!segment.empty()) out.push_back(segment);
    if (slash == std::string_view::npos) break;
    path.remove_prefix(slash + 1);
  }
  return out;
}

// The same into a fixed buffer, for what every request asks (its label, its body limit): the
// segments beyond the buffer are dropped, and no route has that many, so none fits such a path.
struct PathSegments {
  std::array<std::string_view, 16> buffer;
  std::size_t count = 0;
  bool truncated = false;

  explicit PathSegments(std::string_view path) {
    while (!path.empty()) {
      const std::size_t slash = path.find('/');
      const std::string_view segment = path.substr(0, slash);
      if (!segment.empty()) {
        if (count < buffer.size()) {
          buffer[count++] = segment;
        } else {
          truncated = true;
        }
      }
      if (slash == std::string_view::npos) break;
      path.remove_prefix(slash + 1);
    }
  }
  std::span<const std::string_view> segments() const { return {buffer.data(), count}; }
};

}  // namespace

const std::vector<App::Route>& App::routes() {
  using Body = Route::Body;
  using M = RouteMatch;
  constexpr auto get = http::verb::get, post = http::verb::post, put = http::verb::put;
  // First match wins: a product's own route before its scene's catch-all.
  static const std::vector<Route> kTable = [] {
    std::vector<Route> table = {
        {get, "/healthz", "healthz", Body::none, false,
         [](App&, const Request& r, const Target&, const M&) -> Outcome {
           Response out = detail::json_response(r, http::status::ok, {{"status", "ok"}});
           out.set(http::field::cache_control, "no-store");
           return out;
         }},
        {get, "/metrics", "metrics", Body::none, false,
         [](App& a, const Request& r, const Target&, const M&) -> Outcome {
           Response out = make_response(r, http::status::ok,
                                        a.metrics_.prometheus(a.cache_) + a.cache_metrics(),
                                        "text/plain; version=0.0.4");
           out.set(http::field::cache_control, "no-store");
           return out;
         }},
        {get, "/api/v1/openapi.json", "openapi", Body::none, false,
         [](App&, const Request& r, const Target&, const M&) -> Outcome {
           Response out = make_response(r, http::status::ok, std::string(openapi_document()),
                                        "application/json");
           out.set(http::field::cache_control, "public, max-age=300");
           return out;
         }},
        {get, "/api/v1/glsl/trace.glsl", "glsl", Body::none, false,
         [](App& a, const Request& r, const Target&, const M&) -> Outcome {
           return a.trace_glsl(r);
         }},
        {get, "/api/v1/glsl/material.glsl", "material_glsl", Body::none, false,
         [](App& a, const Request& r, const Target&, const M&) -> Outcome {
           return a.material_glsl(r);
         }},
        {get, "/api/v1/node-types", "node_types", Body::none, false,
         [](App& a, const Request& r, const Target&, const M&) -> Outcome {
           return a.node_types(r);
         }},
        {post, "/api/v1/images", "images", Body::image, false,
         [](App& a, const Request& r, const Target&, const M&) -> Outcome {
           return a.upload_image(r);
         }},
        {get, "/api/v1/scenes", "scenes", Body::none, false,
         [](App& a, const Request& r, const Target&, const M&) -> Outcome {
           return a.list_scenes(r);
         }},
        {post, "/api/v1/scenes", "scenes", Body::scene, false,
         [](App& a, const Request& r, const Target& t, const M&) -> Outcome {
           return a.off_io_thread(
               r, [&a, t](const Request& copy) -> Response { return a.create_scene(copy, t); });
         }},
        {get, "/api/v1/scenes/{ref}", "scene", Body::none, true,
         [](App& a, const Request& r, const Target&, const M& m) -> Outcome {
           return a.get_scene(r, m.ref);
         }},
        {put, "/api/v1/scenes/{ref}", "scene", Body::scene, false,
         [](App& a, const Request& r, const Target&, const M& m) -> Outcome {
           return a.off_io_thread(r, [&a, ref = m.ref](const Request& copy) -> Response {
             return a.put_scene(copy, ref);
           });
         }},
        {get, "/api/v1/scenes/{ref}/versions", "versions", Body::none, false,
         [](App& a, const Request& r, const Target&, const M& m) -> Outcome {
           return a.versions(r, m.ref);
         }},
        {get, "/api/v1/scenes/{ref}/changes", "changes", Body::none, true,
         [](App& a, const Request& r, const Target& t, const M& m) -> Outcome {
           return a.scene_changes(r, m.ref, t);
         }},
        {get, "/api/v1/scenes/{ref}/live", "live", Body::none, false,
         [](App&, const Request& r, const Target&, const M&) -> Outcome {
           // Upgrades are taken by the session layer before routing; this is a plain request.
           Response out = problem(r, http::status::upgrade_required, "WebSocket required",
                                  "the live channel is a WebSocket: connect with Upgrade: "
                                  "websocket (docs/live.md)");
           out.set(http::field::upgrade, "websocket");
           // The offer to upgrade, and still a close where the client asked for one.
           out.set(http::field::connection, r.keep_alive() ? "Upgrade" : "Upgrade, close");
           return out;
         }},
        {get, "/api/v1/scenes/{ref}/tiles/{...}", "tiles", Body::none, true, &App::scene_route},
        {get, "/api/v1/scenes/{ref}/mesh/{...}", "mesh", Body::none, true, &App::scene_route},
        {get, "/api/v1/scenes/{ref}/render.png", "render", Body::none, true, &App::scene_route},
        {get, "/api/v1/scenes/{ref}/depth.bin", "depth", Body::none, true, &App::scene_route},
        {get, "/api/v1/scenes/{ref}/trace.json", "trace.json", Body::none, true, &App::scene_route},
        {get, "/api/v1/scenes/{ref}/program", "program", Body::none, true, &App::scene_route},
        {get, "/api/v1/scenes/{ref}/analysis.json", "analysis.json", Body::none, true,
         &App::scene_route},
        {get, "/api/v1/scenes/{ref}/sample", "sample", Body::none, true, &App::scene_route},
        {get, "/api/v1/scenes/{ref}/tilejson.json", "tilejson.json", Body::none, true,
         &App::scene_route},
        {get, "/api/v1/scenes/{ref}/layer.json", "layer.json", Body::none, true, &App::scene_route},
        // Anything else of a scene: its products answer 404 naming what they offer.
        {get, "/api/v1/scenes/{ref}/{...}", "scene", Body::none, true, &App::scene_route},
        {get, "/api/v1/planets", "planets", Body::none, false,
         [](App& a, const Request& r, const Target&, const M&) -> Outcome {
           return a.list_planets(r);
         }},
        {post, "/api/v1/planets", "planets", Body::scene, false,
         [](App& a, const Request& r, const Target&, const M&) -> Outcome {
           return a.create_planet(r);
         }},
        {get, "/api/v1/planets/{ref}", "planet", Body::none, false,
         [](App& a, const Request& r, const Target&, const M& m) -> Outcome {
           return a.get_planet(r, m.ref);
         }},
        {get, "/api/v1/planets/{ref}/tiles/{...}", "planet_tiles", Body::none, false,
         &App::planet_route},
        {get, "/api/v1/planets/{ref}/mesh/{...}", "planet_mesh", Body::none, false,
         &App::planet_route},
        {get, "/api/v1/planets/{ref}/sample", "planet_sample", Body::none, false,
         &App::planet_route},
        {get, "/api/v1/planets/{ref}/tilejson.json", "planet_tilejson.json", Body::none, false,
         &App::planet_route},
        {get, "/api/v1/planets/{ref}/layer.json", "planet_layer.json", Body::none, false,
         &App::planet_route},
        {get, "/api/v1/planets/{ref}/material.json", "planet_material.json", Body::none, false,
         &App::planet_route},
        {get, "/api/v1/planets/{ref}/{...}", "planet", Body::none, false, &App::planet_route},
    };
    for (Route& route : table) route.parts = split_path(route.pattern);
    return table;
  }();
  return kTable;
}

Outcome App::scene_route(App& app, const Request& request, const Target& target,
                         const RouteMatch& match) {
  return app.scene_product(request, match.ref, match.rest, target);
}

Outcome App::planet_route(App& app, const Request& request, const Target& target,
                          const RouteMatch& match) {
  return app.planet_product(request, match.ref, match.rest, target);
}

template <class Segment>
bool App::Route::fits(std::span<const Segment> segments) const {
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (parts[i] == "{...}") return i < segments.size();  // the rest is one segment or more
    if (i >= segments.size()) return false;
    if (parts[i] != "{ref}" && parts[i] != std::string_view(segments[i])) return false;
  }
  return parts.size() == segments.size();
}

std::optional<App::RouteMatch> App::Route::match(std::span<const std::string> segments) const {
  if (!fits(segments)) return std::nullopt;
  RouteMatch out;
  // The product's segments are those after the ref.
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (parts[i] != "{ref}") continue;
    out.ref = segments[i];
    out.rest.assign(segments.begin() + static_cast<std::ptrdiff_t>(i + 1), segments.end());
  }
  return out;
}

namespace {

// GET routes answer HEAD as well.
bool answers(http::verb route_method, http::verb method) {
  return method == route_method || (route_method == http::verb::get && method == http::verb::head);
}

}  // namespace

Outcome App::route(const Request& request, const Target& target) {
  const http::verb method = request.method();
  if (method == http::verb::options) {
    Response r = make_response(request, http::status::no_content, "", "text/plain");
    r.set(http::field::access_control_allow_methods, "GET, HEAD, POST, PUT, OPTIONS");
    r.set(http::field::access_control_allow_headers,
          "Authorization, Content-Type, If-Match, If-None-Match");
    r.set(http::field::access_control_max_age, "86400");
    return r;
  }
  std::vector<std::string_view> allowed;  // the methods of routes whose pattern matches
  const std::span<const std::string> segments(target.segments);
  for (const Route& route : routes()) {
    if (!route.fits(segments)) continue;
    if (!answers(route.method, method)) {
      const std::string_view name = route.method == http::verb::get    ? "GET, HEAD"
                                    : route.method == http::verb::post ? "POST"
                                                                       : "PUT";
      if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
        allowed.push_back(name);
      }
      continue;
    }
    const std::optional<RouteMatch> match = route.match(segments);
    // Parsing and compiling a version (decoding its images) is work for the pool, not for an
    // I/O thread: a read of a version not loaded yet goes there whole, once.
    if (route.loads_version && !versions_.is_loaded(match->ref)) {
      Deferred load;
      load.prepare = [this, copy = std::make_shared<const Request>(request),
                      ref = match->ref]() -> std::optional<Response> {
        auto loaded = resolve(*copy, ref);
        if (loaded) return std::nullopt;
        return loaded.error();
      };
      return load;
    }
    return route.handle(*this, request, target, *match);
  }
  if (!allowed.empty()) {
    std::string allow;
    for (std::string_view name : allowed) allow += (allow.empty() ? "" : ", ") + std::string(name);
    Response r = problem(request, http::status::method_not_allowed, "Method not allowed",
                         std::string(request.method_string()) + " is not allowed here");
    r.set(http::field::allow, allow);
    return r;
  }
  const auto& s = target.segments;
  if ((method == http::verb::get || method == http::verb::head) && (s.empty() || s[0] != "api")) {
    return client_file(request, target);
  }
  return problem(request, http::status::not_found, "Not found",
                 "no route for " + std::string(request.target()));
}

Response App::client_file(const Request& request, const Target& target) const {
  // The browser client: looked up in the table read at start, never a path on disk.
  std::string path;
  for (const std::string& seg : target.segments) path += "/" + seg;
  if (path.empty() || target.folder) path += "/";
  if (const StaticFile* file = client_.find(path)) {
    Response r = make_response(request, http::status::ok, Payload(file->body), file->media_type);
    r.set(http::field::cache_control, detail::kReleaseCacheControl);
    detail::answer_conditionally(request, r, file->etag);
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
  return problem(request, http::status::not_found, "Not found",
                 "no route for " + std::string(request.target()));
}

std::string_view App::route_label(const Request& request) {
  const std::string_view t(request.target().data(), request.target().size());
  const PathSegments path(t.substr(0, t.find('?')));
  // The route whose pattern matches, whatever the method: a scene named "sample" is a scene.
  if (!path.truncated) {
    for (const Route& route : routes()) {
      if (route.fits(path.segments())) return route.label;
    }
  }
  return path.count == 0 || path.buffer[0] != "api" ? "client" : "other";
}

App::BodyPolicy App::body_policy(http::verb method, std::string_view target) const {
  // The raw path: percent-encoded ids reach the same routes, whose fixed parts are plain.
  const PathSegments path(target.substr(0, target.find('?')));
  if (path.truncated) return {};
  for (const Route& route : routes()) {
    if (route.method != method || !route.fits(path.segments())) continue;
    switch (route.body) {
      case Route::Body::none:
        return {};
      case Route::Body::scene:
        return {config_.scene_body_limit, true};
      case Route::Body::image:
        return {config_.image_body_limit, true};
    }
  }
  return {};
}

}  // namespace server
