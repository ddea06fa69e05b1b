// Light and air of terrain/src/lighting.cpp (terrain/lighting.hpp), operation for operation: the
// analytic Rayleigh and Mie sky, aerial perspective, soft sun visibility, sun and sky light on a
// surface, and water's Fresnel reflection. Needs material.glsl before it. GLSL ES 3.00
// compatible.

float lighting_dot(vec3 a, vec3 b) {
  TERRAIN_PRECISE float d = a.x * b.x + a.y * b.y + a.z * b.z;
  return d;
}

// The sky towards a direction rising `rise` (sine of its elevation), at cosine `towards_sun`
// with the sun (sky_at in lighting.cpp).
vec3 lighting_sky_at(float rise, float towards_sun) {
  const vec3 kRayleigh = vec3(0.20, 0.38, 0.90);
  const float kMie = 0.5;
  const float g = 0.8;
  TERRAIN_PRECISE float air_mass = 1.0 / (max(rise, 0.0) + 0.2);
  TERRAIN_PRECISE float rayleigh_phase = 0.8 + 0.2 * (towards_sun * towards_sun);
  TERRAIN_PRECISE float lobe_base = 1.0 + g * g - 2.0 * g * towards_sun;
  TERRAIN_PRECISE float mie_phase = (1.0 - g * g) / (lobe_base * sqrt(lobe_base));
  TERRAIN_PRECISE float mie_weight = 1.0 - exp(-kMie * air_mass);
  TERRAIN_PRECISE float mie = (0.05 * mie_phase + 0.2) * mie_weight;
  TERRAIN_PRECISE vec3 scattered = vec3(1.0 - exp(-kRayleigh.x * air_mass),
                                        1.0 - exp(-kRayleigh.y * air_mass),
                                        1.0 - exp(-kRayleigh.z * air_mass));
  TERRAIN_PRECISE vec3 sky = vec3(scattered.x * rayleigh_phase + mie,
                                  scattered.y * rayleigh_phase + mie,
                                  scattered.z * rayleigh_phase + mie);
  return sky;
}

// terrain::sky_radiance.
vec3 lighting_sky(vec3 direction, vec3 sun) {
  return lighting_sky_at(direction.z, lighting_dot(direction, sun));
}

// terrain::aerial_perspective.
vec3 lighting_aerial(vec3 surface, vec3 direction, float distance, float visibility, vec3 sun) {
  const vec3 kHaze = vec3(0.55, 0.75, 1.0);
  vec3 horizon = lighting_sky_at(0.0, lighting_dot(direction, sun));
  TERRAIN_PRECISE float depth = distance / visibility;
  TERRAIN_PRECISE vec3 kept =
      vec3(exp(-kHaze.x * depth), exp(-kHaze.y * depth), exp(-kHaze.z * depth));
  TERRAIN_PRECISE vec3 seen = vec3(surface.x * kept.x + horizon.x * (1.0 - kept.x),
                                   surface.y * kept.y + horizon.y * (1.0 - kept.y),
                                   surface.z * kept.z + horizon.z * (1.0 - kept.z));
  return seen;
}

// terrain::sun_visibility.
float lighting_sun_visibility(float closest, vec3 sun) {
  TERRAIN_PRECISE float level = sqrt(sun.x * sun.x + sun.y * sun.y);
  TERRAIN_PRECISE float cleared = closest * level;
  float s = material_ramp(cleared, 0.0, 0.04);
  TERRAIN_PRECISE float smooth_s = s * s * (3.0 - 2.0 * s);
  return smooth_s;
}

// terrain::lit_surface.
vec3 lighting_lit_surface(vec3 albedo, vec3 normal, vec3 sun, float sun_visible,
                          float sky_visible) {
  const vec3 kSunLight = vec3(0.80, 0.77, 0.72);
  const vec3 kSkyLight = vec3(0.27, 0.30, 0.36);
  TERRAIN_PRECISE float direct = max(0.0, lighting_dot(normal, sun)) * sun_visible;
  TERRAIN_PRECISE vec3 lit =
      vec3(albedo.x * (kSkyLight.x * sky_visible + kSunLight.x * direct),
           albedo.y * (kSkyLight.y * sky_visible + kSunLight.y * direct),
           albedo.z * (kSkyLight.z * sky_visible + kSunLight.z * direct));
  return lit;
}

// terrain::water_surface.
vec3 lighting_water(vec3 lit_body, vec3 direction, vec3 sun, float sun_visible) {
  const vec3 kGlint = vec3(1.0, 0.95, 0.85);
  float facing = clamp(-direction.z, 0.0, 1.0);
  TERRAIN_PRECISE float grazing = 1.0 - facing;
  TERRAIN_PRECISE float grazing2 = grazing * grazing;
  TERRAIN_PRECISE float fresnel = 0.02 + 0.98 * (grazing2 * grazing2 * grazing);
  vec3 mirrored = vec3(direction.x, direction.y, -direction.z);
  vec3 sky = lighting_sky(mirrored, sun);
  TERRAIN_PRECISE float lobe = max(0.0, lighting_dot(mirrored, sun));
  for (int k = 0; k < 8; ++k) lobe = lobe * lobe;
  TERRAIN_PRECISE float glint = 8.0 * fresnel * lobe * sun_visible;
  TERRAIN_PRECISE vec3 seen =
      vec3(lit_body.x * (1.0 - fresnel) + sky.x * fresnel + kGlint.x * glint,
           lit_body.y * (1.0 - fresnel) + sky.y * fresnel + kGlint.y * glint,
           lit_body.z * (1.0 - fresnel) + sky.z * fresnel + kGlint.z * glint);
  return seen;
}
