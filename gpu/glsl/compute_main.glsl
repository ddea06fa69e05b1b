// Compute entry point: one invocation per sample. Positions are the exact float positions the CPU
// evaluator would use (scene metres, rounded once from double on the host): either one (x, y)
// pair per sample, or for grids, per grid a column table followed by a row table, then one
// level-of-detail spacing per grid (several tiles of one size in one dispatch).
layout(local_size_x = 64) in;

layout(std430, binding = 2) readonly buffer Positions { float positions[]; };
layout(std430, binding = 3) writeonly buffer Results { vec4 results[]; };  // f, ∂f/∂x, ∂f/∂y, α

uniform uint u_first;         // index of the first sample of this dispatch
uniform uint u_count;         // samples in all
uniform uint u_grid_width;    // 0: a list of (x, y) pairs; else columns of each grid
uniform uint u_grid_samples;  // grids: samples per grid (width × height)
uniform float u_spacing;      // pairs: the level of detail of every sample

void main() {
  uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  vec2 p;
  float spacing = u_spacing;
  if (u_grid_width == 0u) {
    p = vec2(positions[2u * i], positions[2u * i + 1u]);
  } else {
    uint grid = i / u_grid_samples;
    uint k = i - grid * u_grid_samples;
    uint rows = u_grid_samples / u_grid_width;
    uint table = grid * (u_grid_width + rows);
    p = vec2(positions[table + k % u_grid_width], positions[table + u_grid_width + k / u_grid_width]);
    spacing = positions[(u_count / u_grid_samples) * (u_grid_width + rows) + grid];
  }
  Field r = evaluate_program(p, spacing);
  results[i] = vec4(r.f, r.fx, r.fy, r.a);
}
