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

// A colour and a band of the packed material (u_material, declared with the offsets before this
// file: terrain::material_glsl_declarations).
vec3 material_colour(int at) {
  return vec3(u_material[at], u_material[at + 1], u_material[at + 2]);
}
float material_band(float x, int at) {
  return material_ramp(x, u_material[at], u_material[at + 1]);
}

// terrain::material_albedo: height 0..1 within the relief, slope the sine of its angle,
// northness 1 facing the pole, shore 1 at a water's edge, polar |sin latitude| (planets).
vec3 material_albedo(float height, float slope, float northness, float shore, bool water,
                     float polar) {
  if (water) return material_colour(MATERIAL_WATER);
  vec3 ground = colour_mix(material_colour(MATERIAL_GRASS), material_colour(MATERIAL_FOREST),
                           material_band(height, MATERIAL_FOREST_HEIGHT));
  ground = colour_mix(ground, material_colour(MATERIAL_MEADOW),
                      material_band(height, MATERIAL_TREE_LINE));
  ground = colour_mix(ground, material_colour(MATERIAL_BARE_GROUND),
                      material_band(height, MATERIAL_BARE_GROUND_HEIGHT));
  TERRAIN_PRECISE float scree = material_band(slope, MATERIAL_SCREE_SLOPE) *
                                material_band(height, MATERIAL_SCREE_HEIGHT);
  ground = colour_mix(ground, material_colour(MATERIAL_SCREE), scree);
  ground = colour_mix(ground, material_colour(MATERIAL_ROCK),
                      material_band(slope, MATERIAL_ROCK_SLOPE));
  TERRAIN_PRECISE float line = u_material[MATERIAL_SNOW_LINE] -
                               u_material[MATERIAL_SNOW_ASPECT] * northness -
                               u_material[MATERIAL_SNOW_POLAR] * polar;
  TERRAIN_PRECISE float top = line + u_material[MATERIAL_SNOW_BLEND];
  TERRAIN_PRECISE float snow =
      material_ramp(height, line, top) * (1.0 - material_band(slope, MATERIAL_SNOW_SLOPE));
  ground = colour_mix(ground, material_colour(MATERIAL_SNOW), snow);
  TERRAIN_PRECISE float sand = shore * (1.0 - material_band(slope, MATERIAL_SAND_SLOPE));
  ground = colour_mix(ground, material_colour(MATERIAL_SAND), sand);
  return ground;
}
