// The material model of terrain/src/material.cpp (terrain/material.hpp), operation for operation:
// the ground's colour from its height within the relief, its slope and the way it faces, water
// and shores, and the sun's light on it. The GPU tracer and the browser viewer shade with it
// (trace.glsl, after it), the CPU renderer and colour tiles with the C++ original. GLSL ES 3.00
// compatible.

// a + (b − a)·t per channel, as terrain::mix writes it (GLSL's built-in may round differently).
vec3 colour_mix(vec3 a, vec3 b, float t) {
  TERRAIN_PRECISE vec3 r = vec3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t,
                                a.z + (b.z - a.z) * t);
  return r;
}

// terrain::ramp: clamp((x − lo) / (hi − lo), 0, 1).
float material_ramp(float x, float lo, float hi) {
  TERRAIN_PRECISE float r = (x - lo) / (hi - lo);
  return clamp(r, 0.0, 1.0);
}

// terrain::northness of a gradient (∂h/∂x, ∂h/∂y).
float material_northness(float east, float north) {
  TERRAIN_PRECISE float squared = east * east + north * north;
  float steepness = sqrt(squared);
  if (!(steepness > 0.0)) return 0.0;
  TERRAIN_PRECISE float faded = min(steepness * 2.0, 1.0);
  TERRAIN_PRECISE float n = -north / steepness * faded;
  return n;
}

// terrain::shore_band_for.
float material_shore_band(float z_lo, float z_hi) {
  TERRAIN_PRECISE float width = z_hi - z_lo;
  TERRAIN_PRECISE float band = 0.02 * width;
  return max(band, 1.0);
}

// terrain::material_albedo: height 0..1 within the relief, slope the sine of its angle,
// northness 1 facing north, shore 1 at a water's edge.
vec3 material_albedo(float height, float slope, float northness, float shore, bool water) {
  if (water) return vec3(0.12, 0.30, 0.45);
  vec3 ground = colour_mix(vec3(0.36, 0.49, 0.22), vec3(0.17, 0.31, 0.13),
                           material_ramp(height, 0.12, 0.30));
  ground = colour_mix(ground, vec3(0.48, 0.52, 0.31), material_ramp(height, 0.48, 0.60));
  ground = colour_mix(ground, vec3(0.55, 0.50, 0.40), material_ramp(height, 0.68, 0.85));
  TERRAIN_PRECISE float scree =
      material_ramp(slope, 0.45, 0.60) * material_ramp(height, 0.45, 0.65);
  ground = colour_mix(ground, vec3(0.60, 0.58, 0.54), scree);
  ground = colour_mix(ground, vec3(0.42, 0.40, 0.38), material_ramp(slope, 0.62, 0.82));
  TERRAIN_PRECISE float line = 0.80 - 0.10 * northness;
  TERRAIN_PRECISE float top = line + 0.08;
  TERRAIN_PRECISE float snow =
      material_ramp(height, line, top) * (1.0 - material_ramp(slope, 0.50, 0.70));
  ground = colour_mix(ground, vec3(0.95, 0.96, 0.98), snow);
  TERRAIN_PRECISE float sand = shore * (1.0 - material_ramp(slope, 0.25, 0.45));
  ground = colour_mix(ground, vec3(0.80, 0.74, 0.56), sand);
  return ground;
}

// terrain::sun_light: ambient 0.30 plus 0.75 of the sun's cosine.
float material_sun_light(vec3 n, vec3 sun) {
  TERRAIN_PRECISE float lit = n.x * sun.x + n.y * sun.y + n.z * sun.z;
  float diffuse = max(0.0, lit);
  TERRAIN_PRECISE float light = 0.30 + 0.75 * diffuse;
  return light;
}
