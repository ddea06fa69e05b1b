// Compute-shader prelude (server, OpenGL ES 3.1+): program words and pool floats come from SSBOs.
// The browser's prelude defines the same functions over textures.
#ifdef GL_ES
precision highp float;
precision highp int;
#endif
#if __VERSION__ >= 320
#define TERRAIN_PRECISE precise
#else
#define TERRAIN_PRECISE
#endif

layout(std430, binding = 0) readonly buffer ProgramCode { uvec4 program_code[]; };
// Pool words as bits, so seeds stored as float bit patterns (possibly NaN) pass untouched.
layout(std430, binding = 1) readonly buffer ProgramPool { uint program_pool[]; };

uniform uint u_program_size;

uvec4 fetch_code(uint pc) { return program_code[pc]; }
uint fetch_pool_uint(uint i) { return program_pool[i]; }
float fetch_pool(uint i) { return uintBitsToFloat(program_pool[i]); }
uint program_size() { return u_program_size; }

// The sphere tracer's Lipschitz grid (terrain::LipschitzGrid::pack()); bound only when tracing.
layout(std430, binding = 4) readonly buffer TraceBounds { float trace_bounds[]; };
float fetch_bounds(uint i) { return trace_bounds[i]; }
// The scene's water raster (terrain::WaterRaster::surface); bound only when tracing.
layout(std430, binding = 7) readonly buffer TraceWater { float trace_water[]; };
float fetch_water(uint i) { return trace_water[i]; }
