// Compute entry point of the sphere tracer: one invocation per pixel, row-major from the top-left
// pixel; a dispatch covers pixels [u_first, u_first + groups × 64). A picture takes three
// phases, each of which may be several dispatches: start (clip and the first u_budget
// evaluations), continue (u_budget more for pixels still working: the primary ray, the shadow
// ray, the sky samples; counts them), finish (shade). A pixel's PixelTrace lives in TraceStates
// between dispatches, so no invocation runs long enough to meet llvmpipe's loop limit; on other
// devices one start with the whole step budget suffices.
layout(local_size_x = 64) in;

// Per pixel: the picture's RGBA8 packed little-endian (r in the low byte), depth bits, steps.
layout(std430, binding = 3) writeonly buffer TraceResults { uvec4 trace_results[]; };
// Per pixel six words: the primary and the shadow ray's TraceState, two words each ((t, hi,
// delta, last λ) as bits, then (steps, status, closest, lod offset)), then (stage, samples,
// horizon sum, 0) and the surface's Field (f, fx, fy, 0): a PixelTrace.
layout(std430, binding = 5) buffer TraceStates { uvec4 trace_states[]; };
layout(std430, binding = 6) buffer TraceActive { uint trace_active; };

uniform uint u_first;
uniform uint u_count;  // pixels in all
uniform int u_phase;   // 0 start, 1 continue, 2 finish
uniform int u_budget;  // steps per pixel in this dispatch
uniform vec3 u_eye;
uniform vec3 u_forward;
uniform vec3 u_right;
uniform vec3 u_up;
uniform float u_tan_half;
uniform float u_aspect;
uniform vec2 u_size;  // width, height in pixels
uniform vec4 u_area;  // lo.x, lo.y, hi.x, hi.y
uniform vec2 u_elevation;
uniform float u_epsilon;
uniform int u_max_steps;
uniform float u_initial_step;
uniform float u_lod_per_metre;
uniform float u_t_max;
uniform int u_accelerated;
uniform float u_water_level;
uniform float u_span;
uniform vec3 u_sun;
uniform int u_shadows;
uniform int u_occlusion;
uniform vec4 u_water_area;
uniform int u_water_size;

void store_trace(uint at, TraceState s) {
  trace_states[at] = uvec4(floatBitsToUint(s.t), floatBitsToUint(s.hi), floatBitsToUint(s.delta),
                           floatBitsToUint(s.last_lambda));
  trace_states[at + 1u] = uvec4(uint(s.steps), uint(s.status), floatBitsToUint(s.closest),
                                floatBitsToUint(s.lod_offset));
}

TraceState load_trace(uint at) {
  uvec4 a = trace_states[at];
  uvec4 b = trace_states[at + 1u];
  return TraceState(uintBitsToFloat(a.x), uintBitsToFloat(a.y), uintBitsToFloat(a.z),
                    uintBitsToFloat(a.w), int(b.x), int(b.y), uintBitsToFloat(b.z),
                    uintBitsToFloat(b.w));
}

void store_pixel(uint i, PixelTrace px) {
  store_trace(6u * i, px.primary);
  store_trace(6u * i + 2u, px.shadow);
  trace_states[6u * i + 4u] =
      uvec4(uint(px.stage), uint(px.samples), floatBitsToUint(px.horizon_sum), 0u);
  trace_states[6u * i + 5u] = uvec4(floatBitsToUint(px.surface.f), floatBitsToUint(px.surface.fx),
                                    floatBitsToUint(px.surface.fy), 0u);
}

PixelTrace load_pixel(uint i) {
  uvec4 c = trace_states[6u * i + 4u];
  uvec4 f = trace_states[6u * i + 5u];
  Field surface = Field(uintBitsToFloat(f.x), 0.0, uintBitsToFloat(f.y), uintBitsToFloat(f.z), 0.0,
                        0.0);
  return PixelTrace(load_trace(6u * i), load_trace(6u * i + 2u), int(c.x), int(c.y),
                    uintBitsToFloat(c.z), surface);
}

void main() {
  uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  uint width = uint(u_size.x);
  TraceCamera camera = TraceCamera(u_eye, u_forward, u_right, u_up, u_tan_half, u_aspect, u_size);
  TraceSetup setup = TraceSetup(u_area.xy, u_area.zw, u_elevation.x, u_elevation.y, u_epsilon,
                                u_max_steps, u_initial_step, u_lod_per_metre, u_t_max,
                                u_accelerated != 0, u_water_level, u_span, u_sun,
                                u_shadows != 0, u_occlusion != 0, u_water_area, u_water_size);
  vec2 pixel = vec2(float(i % width) + 0.5, float(i / width) + 0.5);
  vec3 direction = trace_ray_direction(camera, pixel);
  if (u_phase == 0) {
    PixelTrace px = pixel_start(setup, camera.position, direction);
    pixel_advance(setup, camera.position, direction, px, u_budget);
    store_pixel(i, px);
    if (px.stage != kStageDone) atomicAdd(trace_active, 1u);
  } else if (u_phase == 1) {
    PixelTrace px = load_pixel(i);
    if (px.stage == kStageDone) return;
    pixel_advance(setup, camera.position, direction, px, u_budget);
    store_pixel(i, px);
    if (px.stage != kStageDone) atomicAdd(trace_active, 1u);
  } else {
    TracePixel result = pixel_finish(setup, camera.position, direction, load_pixel(i));
    uvec3 rgb = trace_to_bytes(result.colour);
    uint packed_rgba = rgb.r | (rgb.g << 8) | (rgb.b << 16) | (255u << 24);
    trace_results[i] = uvec4(packed_rgba, floatBitsToUint(result.depth), uint(result.steps), 0u);
  }
}
