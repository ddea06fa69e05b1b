// The material model of terrain/src/material.cpp (terrain/material.hpp), operation for operation:
// the ground's colour from its height within the relief, its slope and water, and the sun's
// light on it. The GPU tracer and the browser viewer shade with it (trace.glsl, after it), the
// CPU renderer and colour tiles with the C++ original. GLSL ES 3.00 compatible.

// a + (b − a)·t per channel, as terrain::mix writes it (GLSL's built-in may round differently).
vec3 colour_mix(vec3 a, vec3 b, float t) {
  TERRAIN_PRECISE vec3 r = vec3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t,
                                a.z + (b.z - a.z) * t);
  return r;
}

// terrain::material_albedo: height 0..1 within the relief, slope the sine of its angle.
vec3 material_albedo(float height, float slope, bool water) {
  if (water) return vec3(0.12, 0.30, 0.45);
  TERRAIN_PRECISE float by_height = height * 1.4;
  vec3 ground = colour_mix(vec3(0.32, 0.45, 0.20), vec3(0.55, 0.50, 0.38),
                           clamp(by_height, 0.0, 1.0));
  TERRAIN_PRECISE float by_slope = (slope - 0.45) * 4.0;
  ground = colour_mix(ground, vec3(0.45, 0.42, 0.40), clamp(by_slope, 0.0, 1.0));
  if (height > 0.8 && slope < 0.6) {
    TERRAIN_PRECISE float snow = (height - 0.8) * 5.0;
    ground = colour_mix(ground, vec3(0.95, 0.96, 0.98), min(snow, 1.0));
  }
  return ground;
}

// terrain::sun_light: ambient 0.30 plus 0.75 of the sun's cosine.
float material_sun_light(vec3 n, vec3 sun) {
  TERRAIN_PRECISE float lit = n.x * sun.x + n.y * sun.y + n.z * sun.z;
  float diffuse = max(0.0, lit);
  TERRAIN_PRECISE float light = 0.30 + 0.75 * diffuse;
  return light;
}
