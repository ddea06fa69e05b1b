// Compute entry point: one invocation per sample. Positions are the exact float positions the CPU
// evaluator would use (scene metres, rounded once from double on the host), either one (x, y)
// pair per sample or, for grids, a column table followed by a row table.
layout(local_size_x = 64) in;

layout(std430, binding = 2) readonly buffer Positions { float positions[]; };
layout(std430, binding = 3) writeonly buffer Results { vec4 results[]; };  // f, ∂f/∂x, ∂f/∂y, α

uniform uint u_first;       // index of the first sample of this dispatch
uniform uint u_count;       // samples in all
uniform uint u_grid_width;  // 0: a list of (x, y) pairs; else columns of the grid
uniform float u_spacing;

void main() {
  uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  vec2 p;
  if (u_grid_width == 0u) {
    p = vec2(positions[2u * i], positions[2u * i + 1u]);
  } else {
    p = vec2(positions[i % u_grid_width], positions[u_grid_width + i / u_grid_width]);
  }
  Field r = evaluate_program(p, u_spacing);
  results[i] = vec4(r.f, r.fx, r.fy, r.a);
}
