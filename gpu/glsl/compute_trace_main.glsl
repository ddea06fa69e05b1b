// Compute entry point of the sphere tracer: one invocation per pixel, row-major from the top-left
// pixel; a dispatch covers pixels [u_first, u_first + groups × 64). A picture takes three
// phases, each of which may be several dispatches: start (clip and first u_budget steps),
// continue (u_budget more steps for pixels still running; counts them), finish (shade). The
// trace state lives in TraceStates between dispatches, so no invocation runs long enough to meet
// llvmpipe's loop limit; on other devices one start with the whole step budget suffices.
layout(local_size_x = 64) in;

// Per pixel: the picture's RGBA8 packed little-endian (r in the low byte), depth bits, steps.
layout(std430, binding = 3) writeonly buffer TraceResults { uvec4 trace_results[]; };
// Per pixel two words: (t, hi, delta, last λ) as bits, then (steps, status).
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

void store_state(uint i, TraceState s) {
  trace_states[2u * i] = uvec4(floatBitsToUint(s.t), floatBitsToUint(s.hi),
                               floatBitsToUint(s.delta), floatBitsToUint(s.last_lambda));
  trace_states[2u * i + 1u] = uvec4(uint(s.steps), uint(s.status), 0u, 0u);
}

TraceState load_state(uint i) {
  uvec4 a = trace_states[2u * i];
  uvec4 b = trace_states[2u * i + 1u];
  return TraceState(uintBitsToFloat(a.x), uintBitsToFloat(a.y), uintBitsToFloat(a.z),
                    uintBitsToFloat(a.w), int(b.x), int(b.y));
}

void main() {
  uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  uint width = uint(u_size.x);
  TraceCamera camera = TraceCamera(u_eye, u_forward, u_right, u_up, u_tan_half, u_aspect, u_size);
  TraceSetup setup = TraceSetup(u_area.xy, u_area.zw, u_elevation.x, u_elevation.y, u_epsilon,
                                u_max_steps, u_initial_step, u_lod_per_metre, u_t_max,
                                u_accelerated != 0, u_water_level, u_span, u_sun);
  vec2 pixel = vec2(float(i % width) + 0.5, float(i / width) + 0.5);
  vec3 direction = trace_ray_direction(camera, pixel);
  if (u_phase == 0) {
    TraceState state = trace_start(setup, camera.position, direction);
    trace_advance(setup, camera.position, direction, state, u_budget);
    store_state(i, state);
    if (state.status == kTraceRunning) atomicAdd(trace_active, 1u);
  } else if (u_phase == 1) {
    TraceState state = load_state(i);
    if (state.status != kTraceRunning) return;
    trace_advance(setup, camera.position, direction, state, u_budget);
    store_state(i, state);
    if (state.status == kTraceRunning) atomicAdd(trace_active, 1u);
  } else {
    TracePixel result = trace_finish(setup, camera.position, direction, load_state(i));
    uvec3 rgb = trace_to_bytes(result.colour);
    uint packed_rgba = rgb.r | (rgb.g << 8) | (rgb.b << 16) | (255u << 24);
    trace_results[i] = uvec4(packed_rgba, floatBitsToUint(result.depth), uint(result.steps), 0u);
  }
}
