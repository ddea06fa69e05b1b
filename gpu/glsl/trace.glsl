// Sphere tracing of the terrain h(p) = p_z − f(p_xy) and its shading: a port of
// terrain/src/sphere_trace.cpp (sphere_trace with the accelerated §7.2 algorithm of Génevaux et
// al. 2015 over a LipschitzGrid, Camera::ray, and render()'s sky, materials, sun and fog),
// operation for operation, so that a pixel's ray, steps and hit distance are the CPU's.
//
// Needs, before it: the shared GLSL (portable_math, noise, nodes, interpreter), material.glsl
// (the ground's colours, which trace_glsl() puts first) and from the prelude fetch_bounds(i), the
// floats of terrain::LipschitzGrid::pack() (a storage buffer on the server; a texture in the
// browser). It declares no uniform or buffer and no entry point: the
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
  float span;  // the larger side of the area (the fog's scale)
  vec3 sun;    // terrain::sun_direction()
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

// terrain::sphere_trace (accelerated or plain) inside the setup's domain, resumable: trace_start
// clips the ray, trace_advance takes up to `budget` steps, so that a caller can split a long
// trace over several dispatches (llvmpipe ends every loop of an invocation after 65 535
// iterations in all, counting the interpreter's). Splitting changes nothing in the result.
const int kTraceRunning = 0;
const int kTraceHit = 1;
const int kTraceMissed = 2;

struct TraceState {
  float t;
  float hi;  // end of the ray's interval inside the domain
  float delta;
  float last_lambda;
  int steps;
  int status;  // kTraceRunning, kTraceHit or kTraceMissed
};

TraceState trace_start(TraceSetup s, vec3 origin, vec3 direction) {
  const float kParallel = uintBitsToFloat(0x2b8cbcccu);  // 1e-12
  TraceState state = TraceState(0.0, s.t_max, s.initial_step, fetch_bounds(2u), 0, kTraceRunning);
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

void trace_advance(TraceSetup s, vec3 origin, vec3 direction, inout TraceState state,
                   int budget) {
  const float kInfinity = uintBitsToFloat(0x7f800000u);
  const float kTPrecision = uintBitsToFloat(0x34d6bf95u);  // 4e-7
  TERRAIN_PRECISE float horizontal =
      sqrt(direction.x * direction.x + direction.y * direction.y);
  float global_lambda = fetch_bounds(2u);
  for (int taken = 0; taken < budget && state.status == kTraceRunning; ++taken) {
    if (!(state.t <= state.hi && state.steps < s.max_steps)) {
      state.status = kTraceMissed;
      break;
    }
    ++state.steps;
    float t = state.t;
    vec3 p = trace_at(origin, direction, t);
    TERRAIN_PRECISE float spacing = s.lod_per_metre * t;
    TERRAIN_PRECISE float h = p.z - evaluate_program(p.xy, spacing).f;
    // A hit within ε, within half the level-of-detail spacing, or within what float precision
    // of t can still resolve (sphere_trace.cpp).
    TERRAIN_PRECISE float half_spacing = 0.5 * spacing;
    TERRAIN_PRECISE float resolvable = t * kTPrecision * (1.0 + state.last_lambda);
    float tolerance = max(max(s.epsilon, half_spacing), resolvable);
    if (h < tolerance) {
      state.status = kTraceHit;
      break;
    }
    float lambda = global_lambda;
    float limit = kInfinity;
    state.last_lambda = lambda;
    if (s.accelerated) {
      // Local bound over the candidate segment [t, t + δ] (its horizontal footprint).
      TERRAIN_PRECISE float ahead = t + state.delta;
      TERRAIN_PRECISE float far_spacing = s.lod_per_metre * ahead;
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
      break;
    }
    TERRAIN_PRECISE float next = t + step;
    state.t = next;
    TERRAIN_PRECISE float doubled = 2.0 * step;
    state.delta = max(s.initial_step, doubled);
  }
}

vec3 trace_sky(vec3 direction) {
  TERRAIN_PRECISE float u = direction.z * 2.0 + 0.3;
  float t = clamp(u, 0.0, 1.0);
  return colour_mix(vec3(0.80, 0.86, 0.92), vec3(0.33, 0.55, 0.85), t);
}

vec3 trace_shade(TraceSetup s, Field field, float z) {
  vec3 n = trace_normalise(vec3(-field.fx, -field.fy, 1.0));
  TERRAIN_PRECISE float nz2 = n.z * n.z;
  TERRAIN_PRECISE float slope = sqrt(1.0 - min(1.0, nz2));  // sine of the slope angle
  TERRAIN_PRECISE float width = s.z_hi - s.z_lo;
  TERRAIN_PRECISE float height = width > 0.0 ? (z - s.z_lo) / width : 0.5;
  float northness = material_northness(field.fx, field.fy);
  bool water = z < s.water_level;
  TERRAIN_PRECISE float above = z - s.water_level;
  float shore = water ? 0.0 : 1.0 - material_ramp(above, 0.0, material_shore_band(s.z_lo, s.z_hi));
  vec3 ground = material_albedo(height, slope, northness, shore, water);
  float light = material_sun_light(n, s.sun);
  TERRAIN_PRECISE vec3 colour = vec3(ground.x * light, ground.y * light, ground.z * light);
  return colour;
}

// The pixel's colour once its trace has ended: sky, or the shaded hit seen through fog.
TracePixel trace_finish(TraceSetup s, vec3 origin, vec3 direction, TraceState state) {
  TracePixel out_pixel = TracePixel(trace_sky(direction), -1.0, state.steps);
  if (state.status == kTraceHit) {
    // The sample render() shades: the same point and spacing as the step that hit.
    vec3 p = trace_at(origin, direction, state.t);
    TERRAIN_PRECISE float spacing = s.lod_per_metre * state.t;
    vec3 surface = trace_shade(s, evaluate_program(p.xy, spacing), p.z);
    TERRAIN_PRECISE float scale = 2.5 * s.span;
    TERRAIN_PRECISE float fog = 1.0 - exp(-state.t / scale);
    out_pixel.colour = colour_mix(surface, vec3(0.80, 0.86, 0.92), fog);
    out_pixel.depth = state.t;
  }
  return out_pixel;
}

// One pixel of terrain::render in one go: the ray through the pixel centre, traced and shaded.
TracePixel trace_pixel(TraceCamera camera, TraceSetup s, vec2 pixel) {
  vec3 direction = trace_ray_direction(camera, pixel);
  TraceState state = trace_start(s, camera.position, direction);
  trace_advance(s, camera.position, direction, state, s.max_steps);
  return trace_finish(s, camera.position, direction, state);
}

// to_byte() of sphere_trace.cpp: round(clamp(v, 0, 1) · 255), halves away from zero.
uvec3 trace_to_bytes(vec3 colour) {
  TERRAIN_PRECISE vec3 scaled = clamp(colour, 0.0, 1.0) * 255.0;
  TERRAIN_PRECISE vec3 rounded = floor(scaled + 0.5);
  return uvec3(rounded);
}
