// The route table: every route of the v1 contract once — method, pattern, metrics label, body
// limit, whether a read first loads its scene version, and the handler. Routing, the labels in
// /metrics and the body limits the session applies before reading a byte all come from it.
#include <algorithm>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "app_support.hpp"

namespace server {

std::string_view openapi_document();  // generated from server/resources/openapi.json

using detail::make_response;

namespace {

// A path's segments, raw or decoded; trailing and doubled slashes make no empty segments.
template <class Segment>
std::vector<Segment> split_path(std::string_view path) {
  std::vector<Segment> out;
  while (!path.empty()) {
    const std::size_t slash = path.find('/');
    const std::string_view segment = path.substr(0, slash);
    if (!segment.empty()) out.emplace_back(segment);
    if (slash == std::string_view::npos) break;
    path.remove_prefix(slash + 1);
  }
  return out;
}

}  // namespace

const std::vector<App::Route>& App::routes() {
  using Body = Route::Body;
  using M = RouteMatch;
  constexpr auto get = http::verb::get, post = http::verb::post, put = http::verb::put;
  // First match wins: a product's own route before its scene's catch-all.
  static const std::vector<Route> table = {
      {get, "/healthz", "healthz", Body::none, false,
       [](App&, const Request& r, const Target&, const M&) -> Outcome {
         Response out = detail::json_response(r, http::status::ok, {{"status", "ok"}});
         out.set(http::field::cache_control, "no-store");
         return out;
       }},
      {get, "/metrics", "metrics", Body::none, false,
       [](App& a, const Request& r, const Target&, const M&) -> Outcome {
         Response out =
             make_response(r, http::status::ok, a.metrics_.prometheus(a.cache_) + a.redis_metrics(),
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
      {get, "/api/v1/planets/{ref}/sample", "planet_sample", Body::none, false, &App::planet_route},
      {get, "/api/v1/planets/{ref}/tilejson.json", "planet_tilejson.json", Body::none, false,
       &App::planet_route},
      {get, "/api/v1/planets/{ref}/layer.json", "planet_layer.json", Body::none, false,
       &App::planet_route},
      {get, "/api/v1/planets/{ref}/{...}", "planet", Body::none, false, &App::planet_route},
  };
  return table;
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
std::optional<App::RouteMatch> App::Route::match(const std::vector<Segment>& segments) const {
  const std::vector<std::string_view> parts = split_path<std::string_view>(pattern);
  RouteMatch out;
  std::size_t after_ref = 0;  // the product's segments follow the ref
  std::size_t i = 0;
  for (; i < parts.size(); ++i) {
    if (parts[i] == "{...}") {
      if (i >= segments.size()) return std::nullopt;  // the rest is at least one segment
      for (std::size_t k = after_ref; k < segments.size(); ++k) {
        out.rest.emplace_back(segments[k]);
      }
      return out;
    }
    if (i >= segments.size()) return std::nullopt;
    if (parts[i] == "{ref}") {
      out.ref = std::string(segments[i]);
      after_ref = i + 1;
    } else if (parts[i] != std::string_view(segments[i])) {
      return std::nullopt;
    }
  }
  if (i != segments.size()) return std::nullopt;
  if (after_ref > 0) {
    for (std::size_t k = after_ref; k < segments.size(); ++k) out.rest.emplace_back(segments[k]);
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
    add_cors(request, r);
    r.set(http::field::access_control_allow_methods, "GET, HEAD, POST, PUT, OPTIONS");
    r.set(http::field::access_control_allow_headers,
          "Authorization, Content-Type, If-Match, If-None-Match");
    r.set(http::field::access_control_max_age, "86400");
    return r;
  }
  std::vector<std::string_view> allowed;  // the methods of routes whose pattern matches
  for (const Route& route : routes()) {
    std::optional<RouteMatch> match = route.match(target.segments);
    if (!match) continue;
    if (!answers(route.method, method)) {
      const std::string_view name = route.method == http::verb::get    ? "GET, HEAD"
                                    : route.method == http::verb::post ? "POST"
                                                                       : "PUT";
      if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
        allowed.push_back(name);
      }
      continue;
    }
    // Parsing and compiling a version (decoding its images) is work for the pool, not for an
    // I/O thread: a read of a version not loaded yet goes there whole, once.
    if (route.loads_version && !is_loaded(match->ref)) {
      Deferred load;
      load.prepare = [this, copy = std::make_shared<const Request>(request),
                      ref = match->ref]() -> std::optional<Response> {
        auto loaded = resolve(*copy, ref);
        if (loaded) return std::nullopt;
        Response refusal = loaded.error();
        add_cors(*copy, refusal);
        return refusal;
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
    if (detail::etag_matches(request, file->etag)) {
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
  return problem(request, http::status::not_found, "Not found",
                 "no route for " + std::string(request.target()));
}

std::string_view App::route_label(const Request& request) {
  const std::string_view t(request.target().data(), request.target().size());
  const auto segments = split_path<std::string_view>(t.substr(0, t.find('?')));
  // The route whose pattern matches, whatever the method: a scene named "sample" is a scene.
  for (const Route& route : routes()) {
    if (route.match(segments)) return route.label;
  }
  return segments.empty() || segments[0] != "api" ? "client" : "other";
}

App::BodyPolicy App::body_policy(http::verb method, std::string_view target) const {
  // The raw path: percent-encoded ids reach the same routes, whose fixed parts are plain.
  const auto segments = split_path<std::string_view>(target.substr(0, target.find('?')));
  for (const Route& route : routes()) {
    if (route.method != method || !route.match(segments)) continue;
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
