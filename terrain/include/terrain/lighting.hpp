// Light and air for pictures of the terrain: the sun's and the sky's light on a surface (with the
// shadow and sky-occlusion factors the tracer measures), an analytic sky of Rayleigh and Mie
// scattering, aerial perspective, and water that reflects the sky with Fresnel's weight. The CPU
// renderer (sphere_trace.cpp) lights with these; gpu/glsl/lighting.glsl is their twin, which
// computes the same floats in the same order for the GPU tracer and the browser viewer.
#pragma once

#include "terrain/material.hpp"

namespace terrain {

/// a · b, summed x, y, z in that order (what the GLSL twin, lighting_dot, writes out too).
float dot(Vec3 a, Vec3 b);

/// The sky's radiance towards unit direction `direction` with the sun in unit direction `sun`:
/// Rayleigh scattering (∝ λ⁻⁴, so the zenith is blue and the long air path at the horizon
/// whitens) and a Mie forward lobe (Henyey–Greenstein, g = 0.8) around the sun, each weighted by
/// 1 − exp(−β·m) for the air mass m along the direction (below the horizon: the horizon's).
Rgb sky_radiance(Vec3 direction, Vec3 sun);

/// What the air between the eye and a surface `distance` away along unit `direction` does to its
/// colour: each channel dims by exp(−σ·distance / visibility) with σ larger for blue, and the
/// horizon sky of that direction scatters in what it takes away.
Rgb aerial_perspective(Rgb surface, Vec3 direction, float distance, float visibility, Vec3 sun);

/// How much of the sun a point sees when its shadow ray escaped: from the ray's closest approach
/// to the terrain (the least height-over-distance ratio along it), a smooth penumbra 0.04 rad
/// wide. A shadow ray that hit sees none of it.
float sun_visibility(float closest, Vec3 sun);

/// `albedo` lit by the sun (its cosine with `normal`, times `sun_visible`) and by the sky
/// (ambient light times `sky_visible`, the share of the sky above the horizon).
Rgb lit_surface(Rgb albedo, Vec3 normal, Vec3 sun, float sun_visible, float sky_visible);

/// Water seen along unit `direction`: the lit body below, and the sky and the sun's glint
/// mirrored in a level surface, weighted by Schlick's Fresnel term (2 % head-on, all of it at
/// grazing angles).
Rgb water_surface(Rgb lit_body, Vec3 direction, Vec3 sun, float sun_visible);

}  // namespace terrain
