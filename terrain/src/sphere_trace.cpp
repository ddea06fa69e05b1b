#include "terrain/sphere_trace.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <thread>

#include "material_model.hpp"
#include "terrain/lighting.hpp"
#include "terrain/material.hpp"

namespace terrain {
namespace {

Vec3 at(const Ray& r, float t) {
  return {r.origin.x + t * r.direction.x, r.origin.y + t * r.direction.y,
          r.origin.z + t * r.direction.z};
}

float height_above(Evaluator& e, Vec3 p, float spacing) {
  return p.z - e.sample({p.x, p.y}, spacing).elevation;
}

/// Ray parameter interval inside the domain's box (slab method); empty when lo > hi.
Interval clip(const TraceDomain& d, const Ray& r, float t_max) {
  float lo = 0.0f, hi = t_max;
  const float o[3] = {r.origin.x, r.origin.y, r.origin.z};
  const float u[3] = {r.direction.x, r.direction.y, r.direction.z};
  const float mins[3] = {d.area.lo.x, d.area.lo.y, d.elevation.lo};
  const float maxs[3] = {d.area.hi.x, d.area.hi.y, d.elevation.hi};
  for (int k = 0; k < 3; ++k) {
    if (std::abs(u[k]) < 1e-12f) {
      if (o[k] < mins[k] || o[k] > maxs[k]) return {};
      continue;
    }
    float t0 = (mins[k] - o[k]) / u[k];
    float t1 = (maxs[k] - o[k]) / u[k];
    if (t0 > t1) std::swap(t0, t1);
    lo = std::max(lo, t0);
    hi = std::min(hi, t1);
  }
  return {lo, hi};
}

}  // namespace

LipschitzGrid::LipschitzGrid(Evaluator& evaluator, const Box2& area, int cells)
    : area_(area), cells_(cells), spacings_{0.0f, 1.0f, 4.0f, 16.0f, 64.0f} {
  const Vec2 size = area.size();
  for (std::size_t k = 0; k < spacings_.size(); ++k) {
    // Level k serves every spacing up to the next level's (the last: every coarser one), so its
    // bounds are asked for that whole band.
    const float spacing = spacings_[k];
    const float coarsest =
        k + 1 < spacings_.size() ? spacings_[k + 1] : std::numeric_limits<float>::max();
    std::vector<float>& level = levels_.emplace_back(static_cast<std::size_t>(cells * cells));
    for (int j = 0; j < cells; ++j) {
      for (int i = 0; i < cells; ++i) {
        const Vec2 lo{area.lo.x + size.x * static_cast<float>(i) / static_cast<float>(cells),
                      area.lo.y + size.y * static_cast<float>(j) / static_cast<float>(cells)};
        const Vec2 hi{area.lo.x + size.x * static_cast<float>(i + 1) / static_cast<float>(cells),
                      area.lo.y + size.y * static_cast<float>(j + 1) / static_cast<float>(cells)};
        level[static_cast<std::size_t>(j * cells + i)] =
            evaluator
                .bounds(
                    {Box2{lo, hi}.expanded(1e-3f * std::max(size.x, size.y)), spacing, coarsest})
                .elevation_lipschitz;
      }
    }
    for (float b : level) global_ = std::max(global_, b);
  }
}

float LipschitzGrid::bound(const Box2& box, float spacing, float far_spacing) const {
  if (!area_.intersects(box)) return 0.0f;  // outside the traced area nothing is hit
  std::size_t level = 0;
  while (level + 1 < spacings_.size() && spacings_[level + 1] <= spacing) ++level;
  std::size_t last = level;
  while (last + 1 < spacings_.size() && spacings_[last + 1] < far_spacing) ++last;
  const Vec2 size = area_.size();
  auto cell = [&](float v, float lo, float extent) {
    const float c = (v - lo) / extent * static_cast<float>(cells_);
    return std::clamp(static_cast<int>(std::floor(c)), 0, cells_ - 1);
  };
  const int i0 = cell(box.lo.x, area_.lo.x, size.x), i1 = cell(box.hi.x, area_.lo.x, size.x);
  const int j0 = cell(box.lo.y, area_.lo.y, size.y), j1 = cell(box.hi.y, area_.lo.y, size.y);
  // Past a quarter of a level's cells the lookups cost more than the global bound loses.
  const auto levels = static_cast<int>(last - level + 1);
  if ((i1 - i0 + 1) * (j1 - j0 + 1) * levels > cells_ * cells_ / 4) return global_;
  float worst = 0.0f;
  for (std::size_t k = level; k <= last; ++k) {
    const std::vector<float>& grid = levels_[k];
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i)
        worst = std::max(worst, grid[static_cast<std::size_t>(j * cells_ + i)]);
    }
  }
  return worst;
}

std::vector<float> LipschitzGrid::pack() const {
  std::vector<float> out{static_cast<float>(cells_),
                         static_cast<float>(spacings_.size()),
                         global_,
                         area_.lo.x,
                         area_.lo.y,
                         area_.hi.x,
                         area_.hi.y};
  out.insert(out.end(), spacings_.begin(), spacings_.end());
  for (const std::vector<float>& level : levels_) out.insert(out.end(), level.begin(), level.end());
  return out;
}

TraceDomain trace_domain(const Program& program, const Box2& area) {
  Interval z = program.bounds.elevation.hull(Interval::point(program.base_elevation));
  return {area, {z.lo - 1.0f, z.hi + 1.0f}};
}

TraceResult sphere_trace(Evaluator& evaluator, const TraceDomain& domain, const Ray& ray,
                         const TraceOptions& options) {
  TraceResult result;
  const Interval span = clip(domain, ray, options.t_max);
  if (span.empty()) return result;
  const float horizontal =
      std::sqrt(ray.direction.x * ray.direction.x + ray.direction.y * ray.direction.y);
  // The global bound at every spacing the ray may sample (the grid's, which GPU tracers share).
  const float global_lambda =
      options.bounds != nullptr ? options.bounds->global()
      : options.lod_per_metre > 0.0f
          ? evaluator.bounds({Box2::everywhere(), 0.0f, std::numeric_limits<float>::max()})
                .elevation_lipschitz
          : evaluator.global_bounds().elevation_lipschitz;
  float t = span.lo;
  float delta = options.initial_step;
  float last_lambda = global_lambda;
  while (t <= span.hi && result.steps < options.max_steps) {
    ++result.steps;
    const Vec3 p = at(ray, t);
    const float spacing = options.lod_per_metre * (options.lod_offset + t);
    const float h = height_above(evaluator, p, spacing);
    // A hit within ε, within half the level-of-detail spacing (the surface is not defined more
    // finely than that), or within what float precision of t can still resolve.
    const float tolerance =
        std::max({options.epsilon, 0.5f * spacing, t * 4e-7f * (1.0f + last_lambda)});
    if (h < tolerance) {
      result.hit = true;
      result.t = t;
      result.position = p;
      return result;
    }
    if (t > 0.0f) result.closest = std::min(result.closest, h / t);
    float lambda = global_lambda;
    float limit = std::numeric_limits<float>::infinity();
    last_lambda = lambda;
    if (options.accelerated) {
      // Local bound over the candidate segment [t, t + δ] (its horizontal footprint) at the
      // spacings sampled along it.
      const float ahead = t + delta;
      const float far_spacing = options.lod_per_metre * (options.lod_offset + ahead);
      const Vec3 q = at(ray, ahead);
      const Box2 box = Box2::of_point({p.x, p.y}).with({q.x, q.y});
      lambda = options.bounds != nullptr
                   ? options.bounds->bound(box, spacing, far_spacing)
                   : evaluator.bounds({box, spacing, far_spacing}).elevation_lipschitz;
      last_lambda = lambda;
      limit = delta;
    }
    // h_Δ'(t) ≥ u_z − |u_xy| λ: if that is non-negative the ray climbs away from the terrain.
    const float approach = horizontal * lambda - ray.direction.z;
    float step = approach > 0.0f ? h / approach : std::numeric_limits<float>::infinity();
    step = std::min(step, limit);
    if (!std::isfinite(step)) break;  // moving away everywhere: no hit in the domain
    t += step;
    // §7.2 step 2.3 doubles δ. Doubling the segment actually advanced (not the candidate) keeps
    // the segment, and so its Lipschitz bound, local after steps cut short near the terrain.
    delta = std::max(options.initial_step, 2.0f * step);
  }
  return result;
}

TraceResult march_dense(Evaluator& evaluator, const TraceDomain& domain, const Ray& ray, float step,
                        float t_max, float lod_per_metre) {
  TraceResult result;
  const Interval span = clip(domain, ray, t_max);
  if (span.empty()) return result;
  auto h_at = [&](float t) { return height_above(evaluator, at(ray, t), lod_per_metre * t); };
  float t_prev = span.lo;
  float h_prev = h_at(t_prev);
  if (h_prev < 0.0f) return {true, t_prev, at(ray, t_prev), 1};
  for (float t = span.lo + step; t <= span.hi + step; t += step) {
    ++result.steps;
    const float tt = std::min(t, span.hi);
    const float h = h_at(tt);
    if (h < 0.0f) {
      float lo = t_prev, hi = tt;
      for (int k = 0; k < 40; ++k) {
        const float mid = 0.5f * (lo + hi);
        (h_at(mid) < 0.0f ? hi : lo) = mid;
      }
      return {true, hi, at(ray, hi), result.steps};
    }
    t_prev = tt;
    h_prev = h;
    if (tt >= span.hi) break;
  }
  return result;
}

Camera::Basis Camera::basis() const {
  Basis b;
  b.forward = normalise({target.x - position.x, target.y - position.y, target.z - position.z});
  b.right = normalise({b.forward.y, -b.forward.x, 0.0f});
  if (!std::isfinite(b.right.x)) b.right = {1, 0, 0};
  b.up = {b.right.y * b.forward.z - b.right.z * b.forward.y,
          b.right.z * b.forward.x - b.right.x * b.forward.z,
          b.right.x * b.forward.y - b.right.y * b.forward.x};
  b.tan_half = std::tan(vertical_fov_degrees * std::numbers::pi_v<float> / 360.0f);
  b.aspect = static_cast<float>(width) / static_cast<float>(height);
  return b;
}

// gpu/glsl/trace.glsl (trace_ray_direction) repeats this arithmetic operation for operation.
Ray Camera::ray(float px, float py) const {
  const Basis b = basis();
  const float sx = (2.0f * (px / static_cast<float>(width)) - 1.0f) * b.tan_half * b.aspect;
  const float sy = (1.0f - 2.0f * (py / static_cast<float>(height))) * b.tan_half;
  return {position, normalise({b.forward.x + sx * b.right.x + sy * b.up.x,
                               b.forward.y + sx * b.right.y + sy * b.up.y,
                               b.forward.z + sx * b.right.z + sy * b.up.z})};
}

float pixel_footprint(const Camera& camera) {
  return 2.0f * std::tan(camera.vertical_fov_degrees * std::numbers::pi_v<float> / 360.0f) /
         static_cast<float>(camera.height);
}

Camera default_camera(const Program& program, const Box2& area, int width, int height) {
  const Vec2 c = area.center();
  const Vec2 s = area.size();
  const float span = std::max(s.x, s.y);
  const Interval z = program.bounds.elevation.hull(Interval::point(program.base_elevation));
  Camera cam;
  cam.width = width;
  cam.height = height;
  // From the south-south-west, low enough that relief reads against the sky.
  cam.position = {c.x - 0.35f * span, c.y - 0.80f * span, z.hi + 0.18f * span};
  cam.target = {c.x, c.y + 0.1f * span, z.lo + 0.3f * (z.hi - z.lo)};
  return cam;
}

namespace {

// Shadow and sky light (docs/client.md#lighting): the sky's scale of sky-visibility samples, and
// how far above the surface a shadow ray starts, in units of the hit's tolerance.
constexpr float kSkyVisibilityRadius = 0.03f;  // of the traced area's larger side
constexpr float kShadowLift = 2.0f;
// Aerial perspective's visibility length, in units of the traced area's larger side.
constexpr float kVisibility = 2.5f;

/// The colour of a hit with unit normal `n`: material, sun and sky light, water, then the air in
/// front of it.
Rgb shade(const FieldSample& s, Vec3 n, Vec3 sun, const Ray& ray, float t, float z,
          const Interval& range, float water_top, float sun_visible, float sky_visible, float span,
          const PackedMaterial& material) {
  MaterialInput input;
  input.slope = std::sqrt(1.0f - std::min(1.0f, n.z * n.z));  // sine of the slope angle
  input.height = range.width() > 0 ? (z - range.lo) / range.width() : 0.5f;
  input.northness = northness(s.elevation_gradient.x, s.elevation_gradient.y);
  input.water = z < water_top;
  input.shore =
      input.water ? 0.0f : 1.0f - material_model::ramp(z - water_top, 0.0f, shore_band_for(range));
  Rgb colour = lit_surface(material_albedo(input, material), n, sun, sun_visible, sky_visible);
  if (input.water) colour = water_surface(colour, ray.direction, sun, sun_visible);
  return aerial_perspective(colour, ray.direction, t, kVisibility * span, sun);
}

}  // namespace

WaterRaster water_raster(const Program& water, const Box2& area, int size) {
  WaterRaster raster;
  raster.area = area;
  raster.size = size;
  raster.surface.assign(static_cast<std::size_t>(size) * static_cast<std::size_t>(size),
                        kNoWaterSurface);
  Evaluator evaluator(water);
  const float cell_x = area.size().x / static_cast<float>(size);
  const float cell_y = area.size().y / static_cast<float>(size);
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const Vec2 p{area.lo.x + (static_cast<float>(i) + 0.5f) * cell_x,
                   area.lo.y + (static_cast<float>(j) + 0.5f) * cell_y};
      const FieldSample s = evaluator.sample(p, std::max(cell_x, cell_y));
      if (s.weight >= 0.5f) {
        raster.surface[static_cast<std::size_t>(j) * static_cast<std::size_t>(size) +
                       static_cast<std::size_t>(i)] = s.elevation;
      }
    }
  }
  return raster;
}

float water_surface_at(const WaterRaster& raster, float x, float y) {
  if (raster.size == 0) return kNoWaterSurface;
  // The GLSL twin (trace_water_surface) computes the same floats.
  const auto n = static_cast<float>(raster.size);
  const float u = (x - raster.area.lo.x) / (raster.area.hi.x - raster.area.lo.x) * n;
  const float v = (y - raster.area.lo.y) / (raster.area.hi.y - raster.area.lo.y) * n;
  if (!(u >= 0.0f && u < n && v >= 0.0f && v < n)) return kNoWaterSurface;
  const auto i = static_cast<std::size_t>(u), j = static_cast<std::size_t>(v);
  return raster.surface[j * static_cast<std::size_t>(raster.size) + i];
}

float sky_visibility(Evaluator& evaluator, Vec3 position, float spacing, float radius) {
  // Sample i looks east, north, west, south; the GLSL twin takes them in the same order so that
  // it can stop and resume between them. A horizon `radius` away needs no detail finer than a
  // quarter of that (and the coarser level of detail costs less).
  constexpr Vec2 kDirections[kSkyVisibilitySamples] = {
      {1.0f, 0.0f}, {0.0f, 1.0f}, {-1.0f, 0.0f}, {0.0f, -1.0f}};
  const float coarse = std::max(spacing, 0.25f * radius);
  float sum = 0.0f;
  for (const Vec2 d : kDirections) {
    const Vec2 q{position.x + d.x * radius, position.y + d.y * radius};
    const float rise =
        std::max(0.0f, (evaluator.sample(q, coarse).elevation - position.z) / radius);
    sum += rise / std::sqrt(1.0f + rise * rise);  // sine of the horizon's elevation
  }
  return 1.0f - sum / 4.0f;
}

Vec3 sun_direction() {
  return normalise({-0.8f, -0.2f, 0.5f});
}

Picture render(const Program& program, const Box2& area, const Camera& camera,
               const RenderOptions& options) {
  Picture picture;
  picture.width = camera.width;
  picture.height = camera.height;
  picture.rgb.assign(static_cast<std::size_t>(camera.width * camera.height) * 3, 0);
  picture.depth.assign(static_cast<std::size_t>(camera.width * camera.height), -1.0f);
  const TraceDomain domain = trace_domain(program, area);
  const float span = std::max(area.size().x, area.size().y);
  std::atomic<int> next_row{0};
  std::atomic<int> rows_done{0};
  std::atomic<std::int64_t> steps{0};
  TraceOptions trace = options.trace;
  if (trace.lod_per_metre == 0.0f) {
    // One pixel's footprint per metre of distance: detail the picture can show, no more.
    trace.lod_per_metre = pixel_footprint(camera);
  }
  trace.t_max = std::min(trace.t_max, 4.0f * span + 1e4f);

  Evaluator grid_evaluator(program);
  const LipschitzGrid bounds(grid_evaluator, area);
  if (trace.accelerated && trace.bounds == nullptr) trace.bounds = &bounds;
  std::atomic<bool> out_of_budget{false};
  const Vec3 sun = sun_direction();
  const PackedMaterial material = pack_material(options.material);
  auto worker = [&] {
    Evaluator evaluator(program);
    TraceOptions ray_trace = trace;
    for (int y = next_row.fetch_add(1); y < camera.height; y = next_row.fetch_add(1)) {
      for (int x = 0; x < camera.width; ++x) {
        if (options.cancel != nullptr && options.cancel->load(std::memory_order_relaxed)) {
          next_row = camera.height;  // the other threads stop at their next row
          break;
        }
        if (options.step_budget > 0) {
          // No ray may take more steps than the picture has left.
          const std::int64_t left = options.step_budget - steps.load();
          if (left <= 0) {
            out_of_budget = true;
            next_row = camera.height;
            break;
          }
          ray_trace.max_steps = static_cast<int>(std::min<std::int64_t>(trace.max_steps, left));
        }
        const Ray ray = camera.ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
        const TraceResult hit = sphere_trace(evaluator, domain, ray, ray_trace);
        int pixel_steps = hit.steps;
        Rgb color = sky_radiance(ray.direction, sun);
        const std::size_t at = static_cast<std::size_t>(y * camera.width + x);
        if (hit.hit) {
          const float spacing = trace.lod_per_metre * hit.t;
          const FieldSample s = evaluator.sample({hit.position.x, hit.position.y}, spacing);
          const Vec3 n = normalise({-s.elevation_gradient.x, -s.elevation_gradient.y, 1.0f});
          float sun_visible = 1.0f;
          if (options.shadows && dot(n, sun) > 0.0f) {
            // From just above the surface towards the sun, at the level of detail of the light's
            // whole path from the eye.
            const float lift = kShadowLift * std::max(trace.epsilon, spacing);
            const Ray towards_sun{{hit.position.x, hit.position.y, s.elevation + lift}, sun};
            TraceOptions shadow_trace = ray_trace;
            shadow_trace.lod_offset = hit.t;
            if (options.step_budget > 0) {
              shadow_trace.max_steps = static_cast<int>(std::clamp<std::int64_t>(
                  ray_trace.max_steps - static_cast<std::int64_t>(hit.steps), 0, trace.max_steps));
            }
            const TraceResult shadow = sphere_trace(evaluator, domain, towards_sun, shadow_trace);
            pixel_steps += shadow.steps;
            sun_visible = shadow.hit ? 0.0f : sun_visibility(shadow.closest, sun);
          }
          float sky_visible = 1.0f;
          if (options.occlusion) {
            sky_visible = sky_visibility(evaluator, {hit.position.x, hit.position.y, s.elevation},
                                         spacing, kSkyVisibilityRadius * span);
            pixel_steps += kSkyVisibilitySamples;
          }
          // The water here: the picture's level, or the scene's water layer above it.
          const float water_top =
              std::max(options.water_level,
                       options.water != nullptr
                           ? water_surface_at(*options.water, hit.position.x, hit.position.y)
                           : kNoWaterSurface);
          color = shade(s, n, sun, ray, hit.t, hit.position.z, domain.elevation, water_top,
                        sun_visible, sky_visible, span, material);
          picture.depth[at] = hit.t;
        }
        steps += pixel_steps;
        picture.rgb[at * 3 + 0] = material_model::colour_byte(color.r);
        picture.rgb[at * 3 + 1] = material_model::colour_byte(color.g);
        picture.rgb[at * 3 + 2] = material_model::colour_byte(color.b);
      }
      ++rows_done;
    }
  };
  const int count = options.threads > 0
                        ? options.threads
                        : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::thread> threads;
  for (int t = 1; t < count; ++t) threads.emplace_back(worker);
  if (options.progress) {
    // The calling thread reports progress while the others trace.
    std::thread last(worker);
    auto stopped = [&] {
      return out_of_budget.load() || (options.cancel != nullptr && options.cancel->load());
    };
    while (rows_done.load() < camera.height && !stopped()) {
      options.progress(static_cast<float>(rows_done.load()) / static_cast<float>(camera.height));
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    last.join();
    options.progress(1.0f);
  } else {
    worker();
  }
  for (std::thread& t : threads) t.join();
  picture.total_steps = steps.load();
  if (options.cancel != nullptr && options.cancel->load()) {
    picture.stopped = Picture::Stop::cancelled;
  } else if (out_of_budget) {
    picture.stopped = Picture::Stop::budget;
  }
  return picture;
}

}  // namespace terrain
