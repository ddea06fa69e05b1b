// Pictures: render.png and depth.bin sphere-traced on the server, and trace.json for the browser
// to trace itself.
#include "server/app.hpp"

#include "app_http.hpp"
#include "app_support.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "gpu/backend.hpp"
#include "gpu/evaluator.hpp"
#include "gpu/program_glsl.hpp"
#include "server/log.hpp"
#include "terrain/gzip.hpp"
#include "terrain/program.hpp"
#include "terrain/sphere_trace.hpp"
#include "terrain/tile_products.hpp"

namespace server {

using json = nlohmann::json;
using terrain::Error;
using namespace detail;  // NOLINT: the App's own helpers (app_support.hpp, app_http.hpp)

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
  options.material = loaded.scene->material;
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
  ProductJob job;
  job.key = cache_key;
  job.reply = ReplyContext::of(request, cache_policy(pinned));
  job.cost = cost;
  job.lane = Deferred::Lane::picture;
  job.metric = depth ? "depth" : "render";
  if (depth) {
    job.respond = [width, height](const ReplyContext& reply,
                                  const std::shared_ptr<const CachedProduct>& p) {
      Response r = product_response(reply, p);
      r.set("X-Picture-Size", std::to_string(width) + "x" + std::to_string(height));
      return r;
    };
  }
  options.step_budget = step_budget;
  job.make =
      [=, this, source = loaded.source, reply = job.reply](
          const std::atomic<bool>& abandoned) mutable -> terrain::Result<CachedProduct, Response> {
    options.cancel = &abandoned;
    // The scene's water layer, drawn as every evaluator draws it (terrain::WaterRaster).
    std::optional<terrain::WaterRaster> water;
    if (source->water) {
      water = terrain::water_raster(*source->water, area);
      options.water = &*water;
    }
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
    if (picture.stopped == terrain::Picture::Stop::cancelled) {
      return problem(reply.shadow(), http::status::service_unavailable, "Abandoned",
                     "the client left before the picture was done");
    }
    if (picture.stopped == terrain::Picture::Stop::budget) {
      return problem(reply.shadow(), http::status::unprocessable_entity, "Too costly",
                     "the picture needed more than " + std::to_string(step_budget) +
                         " sphere-tracing steps (" +
                         std::to_string(config_.picture_steps_per_pixel) +
                         " per pixel, generation.picture_steps_per_pixel): ask for fewer pixels "
                         "or a camera nearer the terrain",
                     "/width");
    }
    CachedProduct bytes;
    bytes.backend = produced;
    if (depth) {
      // Ray distances as little-endian float32, row-major from the top-left pixel.
      bytes.body.assign(picture.depth.size() * sizeof(float), '\0');
      for (std::size_t i = 0; i < picture.depth.size(); ++i) {
        const auto value = std::bit_cast<std::uint32_t>(picture.depth[i]);
        for (std::size_t k = 0; k < 4; ++k) {
          bytes.body[4 * i + k] = static_cast<char>((value >> (8 * k)) & 0xffu);
        }
      }
      bytes.media_type = "application/octet-stream";
      return bytes;
    }
    auto png = terrain::encode_png_rgb8(picture.width, picture.height, picture.rgb.data(),
                                        terrain::PngKind::shaded);
    if (!png) {
      return problem(reply.shadow(), http::status::internal_server_error, "Encoding failed",
                     png.error().message);
    }
    bytes.body.assign(png->begin(), png->end());
    bytes.media_type = "image/png";
    return bytes;
  };
  return serve_product(std::move(job));
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
  ProductJob job;
  job.key = key;
  job.reply = ReplyContext::of(request, cache_policy(pinned));
  job.respond = [](const ReplyContext& reply, const std::shared_ptr<const CachedProduct>& p) {
    Response r = json_text_response(reply.shadow(), p->body, reply.cache_control);
    r.set("X-Terrain-Backend", p->backend);
    return r;
  };
  const terrain::Box2 area = loaded.scene->area();
  const std::string scene_id = loaded.version.scene_id;
  const std::int64_t version = loaded.version.version;
  const std::string hash = loaded.version.hash;
  const std::string author = loaded.version.author;
  const std::int64_t created_ms = loaded.version.created_ms;
  const terrain::Material scene_material = loaded.scene->material;
  job.cost = static_cast<double>(loaded.source->terrain->code.size()) * 64.0 * 64.0 * 5.0;
  job.metric = "trace_bundle";
  job.make = [=, source = loaded.source](
                 const std::atomic<bool>&) -> terrain::Result<CachedProduct, Response> {
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
    if (source->water) {
      // The scene's water layer as the tracers look it up (terrain::WaterRaster).
      const terrain::WaterRaster water = terrain::water_raster(*source->water, area);
      body["water"] = {
          {"area", {water.area.lo.x, water.area.lo.y, water.area.hi.x, water.area.hi.y}},
          {"size", water.size},
          {"surface", terrain::base64(water.surface.data(), water.surface.size() * sizeof(float))}};
    }
    // The scene's material as the tracer's uniform u_material reads it (terrain::pack_material).
    const terrain::PackedMaterial material = terrain::pack_material(scene_material);
    body["material"] = std::vector<float>(material.begin(), material.end());
    body["glsl_defines"] = gpu::node_type_defines(program);
    body["unroll_pays"] = gpu::unroll_pays(program);
    CachedProduct bytes;
    bytes.body = body.dump();
    bytes.media_type = "application/json";
    return bytes;
  };
  return serve_product(std::move(job));
}

}  // namespace server
