#include "terrain/lighting.hpp"

#include <algorithm>
#include <cmath>

#include "material_model.hpp"

namespace terrain {

namespace {

// Rayleigh extinction per unit air mass, red to blue (∝ λ⁻⁴ at about 680, 550 and 440 nm,
// scaled so that the zenith is a clear day's blue), and Mie's, which is grey.
constexpr Rgb kRayleigh{0.20f, 0.38f, 0.90f};
constexpr float kMie = 0.5f;
constexpr float kMieAsymmetry = 0.8f;  // Henyey–Greenstein g: haze scatters forward
// Aerial perspective: extinction per visibility length, red to blue.
constexpr Rgb kHaze{0.55f, 0.75f, 1.0f};
// Light from the sun (warm) and from the sky (blue), on a surface facing it.
constexpr Rgb kSunLight{0.80f, 0.77f, 0.72f};
constexpr Rgb kSkyLight{0.27f, 0.30f, 0.36f};
constexpr Rgb kGlint{1.0f, 0.95f, 0.85f};
constexpr float kPenumbra = 0.04f;  // radians of the shadow's soft edge

// The sky towards a direction that rises `rise` (sine of its elevation) and makes cosine
// `towards_sun` with the sun.
Rgb sky_at(float rise, float towards_sun) {
  const float air_mass = 1.0f / (std::max(rise, 0.0f) + 0.2f);
  const float rayleigh_phase = 0.8f + 0.2f * (towards_sun * towards_sun);
  const float g = kMieAsymmetry;
  const float lobe_base = 1.0f + g * g - 2.0f * g * towards_sun;
  const float mie_phase = (1.0f - g * g) / (lobe_base * std::sqrt(lobe_base));
  // Haze scatters some light whatever the angle (the grey 0.2) and most of it forwards.
  const float mie = (0.05f * mie_phase + 0.2f) * (1.0f - std::exp(-kMie * air_mass));
  auto channel = [&](float beta) {
    return (1.0f - std::exp(-beta * air_mass)) * rayleigh_phase + mie;
  };
  return {channel(kRayleigh.r), channel(kRayleigh.g), channel(kRayleigh.b)};
}

}  // namespace

float dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

Rgb sky_radiance(Vec3 direction, Vec3 sun) {
  return sky_at(direction.z, dot(direction, sun));
}

Rgb aerial_perspective(Rgb surface, Vec3 direction, float distance, float visibility, Vec3 sun) {
  const Rgb horizon = sky_at(0.0f, dot(direction, sun));
  const float depth = distance / visibility;
  auto channel = [&](float colour, float sky, float sigma) {
    const float kept = std::exp(-sigma * depth);
    return colour * kept + sky * (1.0f - kept);
  };
  return {channel(surface.r, horizon.r, kHaze.r), channel(surface.g, horizon.g, kHaze.g),
          channel(surface.b, horizon.b, kHaze.b)};
}

float sun_visibility(float closest, Vec3 sun) {
  // Height over distance, times the cosine of the sun's elevation, is the angle by which the ray
  // cleared the terrain (for small angles).
  const float level = std::sqrt(sun.x * sun.x + sun.y * sun.y);
  const float s = material_model::ramp(closest * level, 0.0f, kPenumbra);
  return s * s * (3.0f - 2.0f * s);
}

Rgb lit_surface(Rgb albedo, Vec3 normal, Vec3 sun, float sun_visible, float sky_visible) {
  const float direct = std::max(0.0f, dot(normal, sun)) * sun_visible;
  auto channel = [&](float colour, float sky, float sunlight) {
    return colour * (sky * sky_visible + sunlight * direct);
  };
  return {channel(albedo.r, kSkyLight.r, kSunLight.r), channel(albedo.g, kSkyLight.g, kSunLight.g),
          channel(albedo.b, kSkyLight.b, kSunLight.b)};
}

Rgb water_surface(Rgb lit_body, Vec3 direction, Vec3 sun, float sun_visible) {
  const float facing = std::clamp(-direction.z, 0.0f, 1.0f);
  const float grazing = 1.0f - facing;
  const float grazing2 = grazing * grazing;
  const float fresnel = 0.02f + 0.98f * (grazing2 * grazing2 * grazing);
  const Vec3 mirrored{direction.x, direction.y, -direction.z};
  const Rgb sky = sky_radiance(mirrored, sun);
  // A sharp lobe, cos²⁵⁶, by eight squarings (exact in every evaluator, unlike pow).
  float lobe = std::max(0.0f, dot(mirrored, sun));
  for (int k = 0; k < 8; ++k) lobe = lobe * lobe;
  const float glint = 8.0f * fresnel * lobe * sun_visible;
  auto channel = [&](float body, float reflected, float sun_colour) {
    return body * (1.0f - fresnel) + reflected * fresnel + sun_colour * glint;
  };
  return {channel(lit_body.r, sky.r, kGlint.r), channel(lit_body.g, sky.g, kGlint.g),
          channel(lit_body.b, sky.b, kGlint.b)};
}

}  // namespace terrain
