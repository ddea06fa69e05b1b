// CPU sphere tracing of the terrain h(p) = p_z − f(p_xy) (Génevaux §7.1–7.2): the plain algorithm
// with the global Lipschitz bound, and the accelerated one with local bounds over a candidate
// segment whose length doubles after every step. Both report whether and where the ray hit and
// how many steps it took; reference pictures and tests use them.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "terrain/evaluate.hpp"
#include "terrain/material.hpp"

namespace terrain {

struct Ray {
  Vec3 origin;
  Vec3 direction;  ///< unit length
};

/// Local Lipschitz bounds precomputed on a grid of cells over the traced area, at a few levels
/// of detail: a lookup replaces a walk of the program at every step (the paper's "standard space
/// partitioning", §7.2). Bounds are maxima over the cells a segment touches, so they stay safe.
/// Level k holds bounds for every spacing from its own to the next level's (the last: any
/// coarser one), since local bounds need not shrink with the level of detail.
class LipschitzGrid {
 public:
  LipschitzGrid(Evaluator& evaluator, const Box2& area, int cells = 64);
  /// A bound of |∇f| over `box` at every sample spacing from `spacing` to `far_spacing` (the
  /// spacings along a tracer's candidate segment): the levels covering that band.
  float bound(const Box2& box, float spacing, float far_spacing) const;
  /// A bound of |∇f| over the traced area at every spacing (the largest cell of any level).
  float global() const { return global_; }

  /// The grid as one float array, for GPU tracers that repeat bound() (gpu/glsl/trace.glsl):
  /// [cells, levels L, global bound, area lo.x, lo.y, hi.x, hi.y, spacings × L, then L levels of
  /// cells × cells bounds, row-major from area.lo].
  std::vector<float> pack() const;

 private:
  Box2 area_;
  int cells_;
  float global_ = 0.0f;
  std::vector<float> spacings_;             // ascending; level k: from it to the next
  std::vector<std::vector<float>> levels_;  // cells_ × cells_ bounds per level
};

struct TraceOptions {
  bool accelerated = true;
  float epsilon = 0.01f;  ///< metres above the surface that count as a hit (at least)
  int max_steps = 1 << 16;
  float initial_step = 10.0f;  ///< δ of the accelerated algorithm, metres
  float lod_per_metre = 0.0f;  ///< sample spacing grows by this much per metre of distance
  /// Metres the light travelled before the ray's origin (a shadow ray's primary hit distance):
  /// the spacing at ray parameter t is lod_per_metre · (lod_offset + t).
  float lod_offset = 0.0f;
  float t_max = 1e7f;
  const LipschitzGrid* bounds = nullptr;  ///< precomputed local bounds (else the program is walked)
};

struct TraceResult {
  bool hit = false;
  float t = 0.0f;
  Vec3 position;
  int steps = 0;
  /// The least height over distance h/t the ray kept above the terrain at its steps (t > 0):
  /// how narrowly a ray that escaped missed (soft shadows).
  float closest = std::numeric_limits<float>::infinity();
};

/// The region traced: the ray's parameter interval inside `area` × [lowest, highest elevation].
struct TraceDomain {
  Box2 area;
  Interval elevation;
};
TraceDomain trace_domain(const Program& program, const Box2& area);

TraceResult sphere_trace(Evaluator& evaluator, const TraceDomain& domain, const Ray& ray,
                         const TraceOptions& options = {});

/// Reference: marches with a fixed step and reports the first sign change of h (bisected), at the
/// same level of detail as sphere_trace with `lod_per_metre`.
TraceResult march_dense(Evaluator& evaluator, const TraceDomain& domain, const Ray& ray, float step,
                        float t_max, float lod_per_metre = 0.0f);

/// A pinhole camera looking from `position` towards `target`, z up.
struct Camera {
  Vec3 position;
  Vec3 target;
  float vertical_fov_degrees = 50.0f;
  int width = 640;
  int height = 400;
  Ray ray(float px, float py) const;  ///< through pixel centre (px, py), py = 0 at the top

  /// What ray() derives from the camera before it looks at the pixel: GPU tracers take these
  /// (computed here, once) and repeat ray()'s per-pixel arithmetic, so both get the same rays.
  struct Basis {
    Vec3 forward, right, up;
    float tan_half = 0.0f;  ///< tan(vertical field of view / 2)
    float aspect = 1.0f;    ///< width / height
  };
  Basis basis() const;
};

/// Sample spacing per metre of distance that matches one pixel of `camera`.
float pixel_footprint(const Camera& camera);

/// The unit direction towards the sun in render()'s shading (GPU tracers take it from here).
Vec3 sun_direction();

/// The share of the sky a point at `position` on the surface sees, 0..1 (horizon-based ambient
/// occlusion): 1 − the mean sine of the horizon's elevation over the four axis directions,
/// each horizon the rise to the surface `radius` away, sampled at `spacing` or a quarter of the
/// radius, whichever is coarser. Costs kSkyVisibilitySamples evaluations; gpu/glsl/trace.glsl
/// repeats it.
float sky_visibility(Evaluator& evaluator, Vec3 position, float spacing, float radius);
inline constexpr int kSkyVisibilitySamples = 4;

/// A scene's water layer as pictures draw it: the water tree's surface where its weight is at
/// least 0.5, sampled at the centres of a size × size grid of cells over `area` (at their
/// spacing), kNoWaterSurface elsewhere. Every evaluator (render, the GPU tracer, the browser)
/// looks a point up in the same cell (water_surface_at), so that they draw the same water.
struct WaterRaster {
  Box2 area;
  int size = 0;
  std::vector<float> surface;  ///< size × size, row-major from area.lo
};
inline constexpr float kNoWaterSurface = -1e30f;
inline constexpr int kWaterRasterSize = 256;

/// The raster of a compiled water tree (compile_water) over `area`.
WaterRaster water_raster(const Program& water, const Box2& area, int size = kWaterRasterSize);

/// The surface in the cell under (x, y), or kNoWaterSurface outside the raster or its water.
float water_surface_at(const WaterRaster& raster, float x, float y);

/// A shaded picture: an analytic sky, aerial perspective, the material model, sun light from
/// exact gradients with soft shadows traced towards the sun, and sky light with occlusion.
struct Picture {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;
  std::vector<float> depth;  ///< ray distance, or -1 where the ray missed
  std::int64_t total_steps = 0;
  /// Why the picture is not complete: it ran out of step_budget, or was cancelled.
  enum class Stop { none, budget, cancelled } stopped = Stop::none;
};

struct RenderOptions {
  TraceOptions trace;
  float water_level = -1e9f;  ///< draw water below this elevation
  /// The scene's water layer (water_raster), drawn where its surface lies above the ground;
  /// null: none.
  const WaterRaster* water = nullptr;
  bool shadows = true;    ///< trace a shadow ray towards the sun from every sunlit hit
  bool occlusion = true;  ///< measure the sky each hit sees (sky_visibility)
  Material material;      ///< the scene's (Scene::material)
  int threads = 0;
  /// Called with the fraction done (0..1) from the calling thread; may be empty.
  std::function<void(float)> progress;
  /// At most this many sphere-tracing steps for the whole picture (0: no limit; shadow rays'
  /// steps and sky samples count too). A server's
  /// cost limit becomes a bound on the work, whatever the camera and the terrain's bounds.
  std::int64_t step_budget = 0;
  /// When set and true, the picture stops at the next pixel (its client has gone).
  const std::atomic<bool>* cancel = nullptr;
};

Picture render(const Program& program, const Box2& area, const Camera& camera,
               const RenderOptions& options = {});

/// A camera that frames `area` from the south-west at a pleasant height.
Camera default_camera(const Program& program, const Box2& area, int width, int height);

}  // namespace terrain
