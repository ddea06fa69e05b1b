// Sphere tracing of the terrain h(p) = p_z − f(p_xy) and its shading: a port of
// terrain/src/sphere_trace.cpp (sphere_trace with the accelerated §7.2 algorithm of Génevaux et
// al. 2015 over a LipschitzGrid, Camera::ray, and render()'s materials, shadow rays, sky
// visibility, sky and aerial perspective), operation for operation, so that a pixel's rays,
// steps and hit distance are the CPU's.
//
// Needs, before it: the shared GLSL (portable_math, noise, nodes, interpreter), material.glsl
// and lighting.glsl (which trace_glsl() puts first) and from the prelude fetch_bounds(i), the
// floats of terrain::LipschitzGrid::pack(), and fetch_water(i), those of
// terrain::WaterRaster::surface (storage buffers on the server; textures in the browser). It declares no uniform or buffer and no entry point: the
// caller fills TraceCamera and TraceSetup (from uniforms) and calls trace_pixel. GLSL ES 3.00
// compatible (TERRAIN_PRECISE may be empty there; the browser then rounds like its GPU does).

// What Camera::basis() gives, plus the picture size in pixels.
struct TraceCamera {
  vec3 position;
  vec3 forward;
  vec3 right;
  vec3 up;
  float tan_half;
  float aspect;
  vec2 size;
};

// The traced domain and the options of terrain::TraceOptions / RenderOptions.
struct TraceSetup {
  vec2 area_lo;  // TraceDomain::area
  vec2 area_hi;
  float z_lo;  // TraceDomain::elevation
  float z_hi;
  float epsilon;
  int max_steps;
  float initial_step;
  float lod_per_metre;
  float t_max;
  bool accelerated;
  float water_level;
  float span;  // the larger side of the area (the scale of the air and of sky visibility)
  vec3 sun;    // terrain::sun_direction()
  bool shadows;    // RenderOptions::shadows
  bool occlusion;  // RenderOptions::occlusion
  vec4 water_area;  // the water raster's area (lo.x, lo.y, hi.x, hi.y) and cells per side (0:
  int water_size;   // no water layer)
};

struct TracePixel {
  vec3 colour;  // linear 0..1, before quantisation
  float depth;  // ray distance, or −1 where the ray missed
  int steps;
};

vec3 trace_normalise(vec3 v) {
  TERRAIN_PRECISE float l = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  TERRAIN_PRECISE vec3 n = vec3(v.x / l, v.y / l, v.z / l);
  return n;
}

vec3 trace_at(vec3 origin, vec3 direction, float t) {
  TERRAIN_PRECISE vec3 p = vec3(origin.x + t * direction.x, origin.y + t * direction.y,
                                origin.z + t * direction.z);
  return p;
}

// Camera::ray through the pixel centre `pixel` (y = 0 at the top).
vec3 trace_ray_direction(TraceCamera c, vec2 pixel) {
  TERRAIN_PRECISE float sx = (2.0 * (pixel.x / c.size.x) - 1.0) * c.tan_half * c.aspect;
  TERRAIN_PRECISE float sy = (1.0 - 2.0 * (pixel.y / c.size.y)) * c.tan_half;
  TERRAIN_PRECISE vec3 d = vec3(c.forward.x + sx * c.right.x + sy * c.up.x,
                                c.forward.y + sx * c.right.y + sy * c.up.y,
                                c.forward.z + sx * c.right.z + sy * c.up.z);
  return trace_normalise(d);
}

// LipschitzGrid::bound over the box [lo, hi] at sample spacings `spacing` to `far_spacing`.
float trace_bound(vec2 lo, vec2 hi, float spacing, float far_spacing) {
  int cells = int(fetch_bounds(0u));
  int levels = int(fetch_bounds(1u));
  float global_bound = fetch_bounds(2u);
  vec2 area_lo = vec2(fetch_bounds(3u), fetch_bounds(4u));
  vec2 area_hi = vec2(fetch_bounds(5u), fetch_bounds(6u));
  if (!(area_lo.x <= hi.x && lo.x <= area_hi.x && area_lo.y <= hi.y && lo.y <= area_hi.y)) {
    return 0.0;  // outside the traced area nothing is hit
  }
  int level = 0;
  while (level + 1 < levels && fetch_bounds(7u + uint(level + 1)) <= spacing) ++level;
  int last_level = level;
  while (last_level + 1 < levels && fetch_bounds(7u + uint(last_level + 1)) < far_spacing) {
    ++last_level;
  }
  TERRAIN_PRECISE vec2 size = area_hi - area_lo;
  float last = float(cells - 1);
  // floor, then clamp to the grid; clamping before the int conversion keeps far boxes defined
  // (the CPU's conversion of such values saturates to the same cells within int range).
  TERRAIN_PRECISE vec2 c0 = (lo - area_lo) / size * float(cells);
  TERRAIN_PRECISE vec2 c1 = (hi - area_lo) / size * float(cells);
  int i0 = int(clamp(floor(c0.x), 0.0, last));
  int i1 = int(clamp(floor(c1.x), 0.0, last));
  int j0 = int(clamp(floor(c0.y), 0.0, last));
  int j1 = int(clamp(floor(c1.y), 0.0, last));
  if ((i1 - i0 + 1) * (j1 - j0 + 1) * (last_level - level + 1) > cells * cells / 4) {
    return global_bound;
  }
  float worst = 0.0;
  for (int k = level; k <= last_level; ++k) {
    uint grid = 7u + uint(levels) + uint(k * cells * cells);
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) worst = max(worst, fetch_bounds(grid + uint(j * cells + i)));
    }
  }
  return worst;
}

// terrain::sphere_trace (accelerated or plain) inside the setup's domain, a step at a time:
// trace_start clips the ray, trace_step takes one step given the program's elevation at its
// point (pixel_advance, below, evaluates it).
const int kTraceRunning = 0;
const int kTraceHit = 1;
const int kTraceMissed = 2;
const int kTraceSkipped = 3;  // a shadow ray never traced (shadows off, or facing away)

struct TraceState {
  float t;
  float hi;  // end of the ray's interval inside the domain
  float delta;
  float last_lambda;
  int steps;
  int status;        // kTraceRunning, kTraceHit, kTraceMissed or kTraceSkipped
  float closest;     // TraceResult::closest: the least h / t so far
  float lod_offset;  // TraceOptions::lod_offset
};

TraceState trace_start(TraceSetup s, vec3 origin, vec3 direction) {
  const float kParallel = uintBitsToFloat(0x2b8cbcccu);  // 1e-12
  const float kInfinity = uintBitsToFloat(0x7f800000u);
  TraceState state = TraceState(0.0, s.t_max, s.initial_step, fetch_bounds(2u), 0, kTraceRunning,
                                kInfinity, 0.0);
  // clip(): the ray's interval inside area × elevation (slab method).
  float lo = 0.0;
  float hi = s.t_max;
  vec3 mins = vec3(s.area_lo, s.z_lo);
  vec3 maxs = vec3(s.area_hi, s.z_hi);
  for (int k = 0; k < 3; ++k) {
    if (abs(direction[k]) < kParallel) {
      if (origin[k] < mins[k] || origin[k] > maxs[k]) state.status = kTraceMissed;
      continue;
    }
    TERRAIN_PRECISE float t0 = (mins[k] - origin[k]) / direction[k];
    TERRAIN_PRECISE float t1 = (maxs[k] - origin[k]) / direction[k];
    if (t0 > t1) {
      float swap = t0;
      t0 = t1;
      t1 = swap;
    }
    lo = max(lo, t0);
    hi = min(hi, t1);
  }
  if (lo > hi) state.status = kTraceMissed;
  state.t = lo;
  state.hi = hi;
  return state;
}

// Whether the trace takes another step; ends it (missed) past its interval or step limit.
bool trace_wants_step(TraceSetup s, inout TraceState state) {
  if (state.status != kTraceRunning) return false;
  if (!(state.t <= state.hi && state.steps < s.max_steps)) {
    state.status = kTraceMissed;
    return false;
  }
  return true;
}

// Sample spacing at ray parameter t: the level of detail of the light's whole path.
float trace_spacing(TraceSetup s, TraceState state, float t) {
  TERRAIN_PRECISE float travelled = state.lod_offset + t;
  TERRAIN_PRECISE float spacing = s.lod_per_metre * travelled;
  return spacing;
}

// One step of sphere_trace's loop, given f, the program's elevation at the step's point
// trace_at(origin, direction, state.t) and spacing trace_spacing(s, state, state.t).
void trace_step(TraceSetup s, vec3 origin, vec3 direction, inout TraceState state, float f) {
  const float kInfinity = uintBitsToFloat(0x7f800000u);
  const float kTPrecision = uintBitsToFloat(0x34d6bf95u);  // 4e-7
  TERRAIN_PRECISE float horizontal = sqrt(direction.x * direction.x + direction.y * direction.y);
  ++state.steps;
  float t = state.t;
  vec3 p = trace_at(origin, direction, t);
  float spacing = trace_spacing(s, state, t);
  TERRAIN_PRECISE float h = p.z - f;
  // A hit within ε, within half the level-of-detail spacing, or within what float precision
  // of t can still resolve (sphere_trace.cpp).
  TERRAIN_PRECISE float half_spacing = 0.5 * spacing;
  TERRAIN_PRECISE float resolvable = t * kTPrecision * (1.0 + state.last_lambda);
  float tolerance = max(max(s.epsilon, half_spacing), resolvable);
  if (h < tolerance) {
    state.status = kTraceHit;
    return;
  }
  if (t > 0.0) {
    TERRAIN_PRECISE float ratio = h / t;
    state.closest = min(state.closest, ratio);
  }
  float lambda = fetch_bounds(2u);  // the global bound
  float limit = kInfinity;
  state.last_lambda = lambda;
  if (s.accelerated) {
    // Local bound over the candidate segment [t, t + δ] (its horizontal footprint).
    TERRAIN_PRECISE float ahead = t + state.delta;
    float far_spacing = trace_spacing(s, state, ahead);
    vec3 q = trace_at(origin, direction, ahead);
    lambda = trace_bound(min(p.xy, q.xy), max(p.xy, q.xy), spacing, far_spacing);
    state.last_lambda = lambda;
    limit = state.delta;
  }
  TERRAIN_PRECISE float approach = horizontal * lambda - direction.z;
  TERRAIN_PRECISE float step = approach > 0.0 ? h / approach : kInfinity;
  step = min(step, limit);
  if (isinf(step) || isnan(step)) {  // moving away everywhere: no hit in the domain
    state.status = kTraceMissed;
    return;
  }
  TERRAIN_PRECISE float next = t + step;
  state.t = next;
  TERRAIN_PRECISE float doubled = 2.0 * step;
  state.delta = max(s.initial_step, doubled);
}

// render()'s constants (sphere_trace.cpp): sky-visibility radius and samples, the shadow ray's
// lift above the surface in units of the hit's tolerance, and the air's visibility length.
const float kSkyVisibilityRadius = 0.03;  // of the traced area's larger side
const int kSkyVisibilitySamples = 4;
const float kShadowLift = 2.0;
const float kVisibility = 2.5;  // of the traced area's larger side

// The colour of a hit (shade() in sphere_trace.cpp): material, sun and sky light, water, air.
// terrain::water_surface_at: the water raster's cell under (x, y), or kNoWaterSurface.
float trace_water_surface(TraceSetup s, float x, float y) {
  const float kNoWaterSurface = -1e30;
  if (s.water_size == 0) return kNoWaterSurface;
  float n = float(s.water_size);
  TERRAIN_PRECISE float u = (x - s.water_area.x) / (s.water_area.z - s.water_area.x) * n;
  TERRAIN_PRECISE float v = (y - s.water_area.y) / (s.water_area.w - s.water_area.y) * n;
  if (!(u >= 0.0 && u < n && v >= 0.0 && v < n)) return kNoWaterSurface;
  return fetch_water(uint(int(v) * s.water_size + int(u)));
}

vec3 trace_shade(TraceSetup s, Field field, vec3 p, vec3 direction, float t, float sun_visible,
                 float sky_visible) {
  float z = p.z;
  vec3 n = trace_normalise(vec3(-field.fx, -field.fy, 1.0));
  TERRAIN_PRECISE float nz2 = n.z * n.z;
  TERRAIN_PRECISE float slope = sqrt(1.0 - min(1.0, nz2));  // sine of the slope angle
  TERRAIN_PRECISE float width = s.z_hi - s.z_lo;
  TERRAIN_PRECISE float height = width > 0.0 ? (z - s.z_lo) / width : 0.5;
  float northness = material_northness(field.fx, field.fy);
  // The picture's water level, or the scene's water layer above it.
  float water_top = max(s.water_level, trace_water_surface(s, p.x, p.y));
  bool water = z < water_top;
  TERRAIN_PRECISE float above = z - water_top;
  float shore = water ? 0.0 : 1.0 - material_ramp(above, 0.0, material_shore_band(s.z_lo, s.z_hi));
  vec3 ground = material_albedo(height, slope, northness, shore, water, 0.0);
  vec3 colour = lighting_lit_surface(ground, n, s.sun, sun_visible, sky_visible);
  if (water) colour = lighting_water(colour, direction, s.sun, sun_visible);
  TERRAIN_PRECISE float visibility = kVisibility * s.span;
  return lighting_aerial(colour, direction, t, visibility, s.sun);
}

// One pixel's work, resumable: the primary ray, then (where it hit) the sample under the hit,
// the shadow ray towards the sun (where that surface is sunlit), then the sky-visibility
// samples. pixel_advance spends at most `budget` evaluations of the program and carries on
// where it stopped, so that a caller can split a pixel over several dispatches (llvmpipe ends
// every loop of an invocation after 65 535 iterations in all, counting the interpreter's);
// splitting changes nothing in the result. Every stage evaluates the program at the same one
// call site, since each call site inlines the whole interpreter into the shader.
const int kStagePrimary = 0;
const int kStageSurface = 1;
const int kStageShadow = 2;
const int kStageOcclusion = 3;
const int kStageDone = 4;

struct PixelTrace {
  TraceState primary;
  TraceState shadow;
  int stage;
  int samples;        // sky-visibility samples taken
  float horizon_sum;  // sines of their horizons
  Field surface;      // the program under the hit, at the hit's spacing
};

PixelTrace pixel_start(TraceSetup s, vec3 origin, vec3 direction) {
  const float kInfinity = uintBitsToFloat(0x7f800000u);
  TraceState skipped = TraceState(0.0, 0.0, 0.0, 0.0, 0, kTraceSkipped, kInfinity, 0.0);
  Field none = Field(0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  return PixelTrace(trace_start(s, origin, direction), skipped, kStagePrimary, 0, 0.0, none);
}

// Where the hit's shadow ray starts: just above the surface under it.
vec3 pixel_shadow_origin(TraceSetup s, vec3 origin, vec3 direction, PixelTrace px) {
  vec3 p = trace_at(origin, direction, px.primary.t);
  TERRAIN_PRECISE float spacing = s.lod_per_metre * px.primary.t;
  TERRAIN_PRECISE float lift = kShadowLift * max(s.epsilon, spacing);
  TERRAIN_PRECISE float z = px.surface.f + lift;
  return vec3(p.x, p.y, z);
}

// terrain::sky_visibility's radius, and its sample i: east, north, west or south of the hit.
float pixel_sky_radius(TraceSetup s) {
  TERRAIN_PRECISE float radius = kSkyVisibilityRadius * s.span;
  return radius;
}

vec2 pixel_sky_sample(TraceSetup s, vec3 hit, int i) {
  vec2 d = i == 0 ? vec2(1.0, 0.0) : i == 1 ? vec2(0.0, 1.0) : i == 2 ? vec2(-1.0, 0.0)
                                                                      : vec2(0.0, -1.0);
  float r = pixel_sky_radius(s);
  TERRAIN_PRECISE vec2 q = vec2(hit.x + d.x * r, hit.y + d.y * r);
  return q;
}

void pixel_advance(TraceSetup s, vec3 origin, vec3 direction, inout PixelTrace px, int budget) {
  int left = budget;
  while (left > 0 && px.stage != kStageDone) {
    // Moves between stages, which evaluate nothing.
    if (px.stage == kStagePrimary && !trace_wants_step(s, px.primary)) {
      px.stage = px.primary.status == kTraceHit ? kStageSurface : kStageDone;
      continue;
    }
    if (px.stage == kStageShadow && !trace_wants_step(s, px.shadow)) {
      px.stage = kStageOcclusion;
      continue;
    }
    if (px.stage == kStageOcclusion && (!s.occlusion || px.samples == kSkyVisibilitySamples)) {
      px.stage = kStageDone;
      continue;
    }
    // The point and spacing of this iteration's one evaluation.
    bool tracing = px.stage == kStagePrimary || px.stage == kStageShadow;
    bool shadow = px.stage == kStageShadow;
    vec3 hit = trace_at(origin, direction, px.primary.t);
    vec3 ray_origin = shadow ? pixel_shadow_origin(s, origin, direction, px) : origin;
    vec3 ray_direction = shadow ? s.sun : direction;
    TraceState ray = px.primary;  // (WebGL allows no ?: between structures)
    if (shadow) ray = px.shadow;
    vec2 at = hit.xy;
    float spacing = trace_spacing(s, px.primary, px.primary.t);
    if (tracing) {
      at = trace_at(ray_origin, ray_direction, ray.t).xy;
      spacing = trace_spacing(s, ray, ray.t);
    } else if (px.stage == kStageOcclusion) {
      at = pixel_sky_sample(s, hit, px.samples);
      TERRAIN_PRECISE float quarter = 0.25 * pixel_sky_radius(s);
      spacing = max(spacing, quarter);
    }
    Field field = evaluate_program(at, spacing);
    --left;
    if (tracing) {
      trace_step(s, ray_origin, ray_direction, ray, field.f);
      if (shadow) {
        px.shadow = ray;
      } else {
        px.primary = ray;
      }
    } else if (px.stage == kStageSurface) {
      px.surface = field;
      vec3 n = trace_normalise(vec3(-field.fx, -field.fy, 1.0));
      px.stage = kStageOcclusion;
      if (s.shadows && lighting_dot(n, s.sun) > 0.0) {
        px.shadow = trace_start(s, pixel_shadow_origin(s, origin, direction, px), s.sun);
        px.shadow.lod_offset = px.primary.t;
        px.stage = kStageShadow;
      }
    } else {
      TERRAIN_PRECISE float above = field.f - px.surface.f;
      TERRAIN_PRECISE float rise = max(0.0, above / pixel_sky_radius(s));
      TERRAIN_PRECISE float sine = rise / sqrt(1.0 + rise * rise);  // of the horizon's elevation
      px.horizon_sum = px.horizon_sum + sine;
      ++px.samples;
    }
  }
}

// The pixel's colour once its work is done: sky, or the lit hit seen through the air.
TracePixel pixel_finish(TraceSetup s, vec3 origin, vec3 direction, PixelTrace px) {
  int steps = px.primary.steps + px.shadow.steps + px.samples;
  TracePixel out_pixel = TracePixel(lighting_sky(direction, s.sun), -1.0, steps);
  if (px.primary.status == kTraceHit) {
    vec3 p = trace_at(origin, direction, px.primary.t);
    float sun_visible = 1.0;
    if (px.shadow.status == kTraceHit) {
      sun_visible = 0.0;
    } else if (px.shadow.status == kTraceMissed) {
      sun_visible = lighting_sun_visibility(px.shadow.closest, s.sun);
    }
    TERRAIN_PRECISE float sky_visible = s.occlusion ? 1.0 - px.horizon_sum / 4.0 : 1.0;
    out_pixel.colour =
        trace_shade(s, px.surface, p, direction, px.primary.t, sun_visible, sky_visible);
    out_pixel.depth = px.primary.t;
  }
  return out_pixel;
}

// One pixel of terrain::render in one go.
TracePixel trace_pixel(TraceCamera camera, TraceSetup s, vec2 pixel) {
  const int kUnlimited = 0x7fffffff;
  vec3 direction = trace_ray_direction(camera, pixel);
  PixelTrace px = pixel_start(s, camera.position, direction);
  pixel_advance(s, camera.position, direction, px, kUnlimited);
  return pixel_finish(s, camera.position, direction, px);
}

// to_byte() of sphere_trace.cpp: round(clamp(v, 0, 1) · 255), halves away from zero.
uvec3 trace_to_bytes(vec3 colour) {
  TERRAIN_PRECISE vec3 scaled = clamp(colour, 0.0, 1.0) * 255.0;
  TERRAIN_PRECISE vec3 rounded = floor(scaled + 0.5);
  return uvec3(rounded);
}
