// Planet mode's GLSL (WebGL2, GLSL ES 3.00): the terrain tiles with logarithmic depth, water
// from the mask and a sun glint, and the sky, both under one atmosphere approximation.
export const TERRAIN_VS = `#version 300 es
precision highp float;
layout(location = 0) in vec3 a_position;  // metres, relative to the tile's centre (ECEF axes)
layout(location = 1) in vec3 a_normal;    // the surface normal (octvertexnormals)
layout(location = 2) in vec3 a_up;        // the ellipsoid's up at the vertex
layout(location = 3) in vec2 a_uv;        // 0..1 across the tile, v north
layout(location = 4) in float a_height;   // metres above the reference surface, unclamped
uniform mat4 u_mvp;        // projection × rotation × translate(centre − eye), the last in double
uniform vec3 u_offset;     // centre − eye (float is plenty for fog and shading)
out vec3 v_rel;            // position relative to the eye
out vec3 v_normal;
out vec3 v_up;
out vec2 v_uv;
out float v_height;
out float v_w;
void main() {
  gl_Position = u_mvp * vec4(a_position, 1.0);
  v_rel = u_offset + a_position;
  v_normal = a_normal;
  v_up = a_up;
  v_uv = a_uv;
  v_height = a_height;
  v_w = 1.0 + gl_Position.w;
}`;

// Shared by the terrain and sky shaders: the length of a ray from the eye inside the
// atmosphere's shell, up to `t_max`. The quadratic's constant (|C|² − r², with C the planet's
// centre relative to the eye) comes from the CPU in double: in float it would cancel.
const ATMOSPHERE_GLSL = `
uniform vec3 u_centre;       // the planet's centre relative to the eye
uniform float u_c_atmosphere; // |C|² − (R + atmosphere)²
uniform float u_c_ground;     // |C|² − R²
float shell_length(vec3 d, float t_max) {
  float b = dot(d, u_centre);
  float disc = b * b - u_c_atmosphere;
  if (disc <= 0.0) return 0.0;
  float s = sqrt(disc);
  float t0 = max(b - s, 0.0);
  float t1 = min(b + s, t_max);
  return max(t1 - t0, 0.0);
}
// Distance along d to the reference sphere, or -1.
float ground_hit(vec3 d) {
  float b = dot(d, u_centre);
  float disc = b * b - u_c_ground;
  if (disc <= 0.0 || b <= 0.0) return -1.0;
  return b - sqrt(disc);
}
const vec3 HAZE = vec3(0.80, 0.86, 0.92);    // scene mode's fog and horizon colour
const vec3 ZENITH = vec3(0.33, 0.55, 0.85);  // scene mode's sky overhead
const vec3 SPACE = vec3(0.01, 0.012, 0.03);
`;

// The terrain's fragment shader around the server's material model and lighting (material.glsl
// and lighting.glsl, the GLSL twins of terrain/material.cpp and terrain/lighting.cpp): land takes
// the colours of scene pictures and colour tiles, water reflects the sky by Fresnel's weight with
// the sun's glint, and the air in front of both is the pictures' aerial perspective.
export function terrainFragmentShader(material) {
  return `#version 300 es
precision highp float;
in vec3 v_rel;
in vec3 v_normal;
in vec3 v_up;
in vec2 v_uv;
in float v_height;
in float v_w;
uniform sampler2D u_mask;     // the tile's water mask (R8), used when u_water < 0
uniform float u_water;        // the one-byte mask's value 0..1, or -1
uniform vec3 u_sun;
uniform float u_sea_level;
uniform vec2 u_relief;       // the heights the material's relief runs between (0 and 1), metres
uniform float u_shore_band;  // metres of beach above the sea
uniform float u_log_depth;    // 2 / log2(far + 1)
uniform float u_fog_scale;
${ATMOSPHERE_GLSL}
layout(location = 0) out vec4 out_colour;
layout(location = 1) out vec4 out_distance;
#define TERRAIN_PRECISE
${material}

void main() {
  vec3 up = normalize(v_up);
  vec3 n = normalize(v_normal);
  float distance = length(v_rel);
  vec3 view = v_rel / distance;
  float water = u_water >= 0.0 ? u_water : texture(u_mask, vec2(v_uv.x, 1.0 - v_uv.y)).r;
  if (v_height < u_sea_level - 1.0) water = 1.0;  // below the sea's surface, whatever the mask
  // Land: the material model, as colour tiles of planets take it: height within the relief of
  // the colour tiles, the slope, which way it faces (poleward along the axis, ECEF z), beaches
  // in the shore band above the sea, the snow line lower towards the poles.
  float along = max(dot(n, up), 1e-3);  // overhanging normals count as vertical
  float slope = sqrt(1.0 - min(1.0, along * along));
  float height = (v_height - u_relief.x) / (u_relief.y - u_relief.x);
  vec3 north = normalize(vec3(0.0, 0.0, 1.0) - up * up.z + vec3(1e-9, 0.0, 0.0));
  vec3 east = cross(north, up);
  float facing = material_northness(-dot(n, east) / along, -dot(n, north) / along);
  if (up.z < 0.0) facing = -facing;  // south of the equator the pole lies south
  float shore = 1.0 - material_ramp(v_height - u_sea_level, 0.0, u_shore_band);
  vec3 ground = material_albedo(height, slope, facing, shore, false, abs(up.z));
  // The sky's light fades through twilight into the night side.
  float daylight = smoothstep(-0.1, 0.2, dot(up, u_sun));
  vec3 land = lighting_lit_surface(ground, n, u_sun, 1.0, daylight);
  // Water: deeper is darker; its surface mirrors the sky and the sun in the local frame (east,
  // north, up), where lighting_water expects them.
  float depth = clamp((u_sea_level - v_height) / 3000.0, 0.0, 1.0);
  vec3 sea = mix(material_colour(MATERIAL_WATER), vec3(0.05, 0.16, 0.32), depth);
  sea = lighting_lit_surface(sea, up, u_sun, 1.0, daylight);
  vec3 local_view = vec3(dot(view, east), dot(view, north), dot(view, up));
  vec3 local_sun = vec3(dot(u_sun, east), dot(u_sun, north), dot(u_sun, up));
  sea = lighting_water(sea, local_view, local_sun, 1.0) * max(daylight, 0.05);
  vec3 colour = mix(land, sea, clamp(water, 0.0, 1.0));
  // The air between the eye and the surface: the pictures' aerial perspective over the path
  // inside the atmosphere's shell, dimmed on the night side.
  vec3 seen = lighting_aerial(colour, view, shell_length(view, distance), u_fog_scale, u_sun);
  out_colour = vec4(mix(colour, seen, max(daylight, 0.1)), 1.0);
  out_distance = vec4(distance, 0.0, 0.0, 1.0);
  gl_FragDepth = log2(v_w) * u_log_depth * 0.5;
}`;
}

export const SKY_VS = `#version 300 es
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);
}`;

export const SKY_FS = `#version 300 es
precision highp float;
uniform vec3 u_forward;
uniform vec3 u_right;
uniform vec3 u_up;
uniform vec2 u_tan;          // tan(fov/2)·aspect, tan(fov/2)
uniform vec2 u_size;
uniform float u_atmosphere;  // the shell's thickness, metres
${ATMOSPHERE_GLSL}
layout(location = 0) out vec4 out_colour;
layout(location = 1) out vec4 out_distance;
void main() {
  vec2 ndc = gl_FragCoord.xy / u_size * 2.0 - 1.0;
  vec3 d = normalize(u_forward + u_right * ndc.x * u_tan.x + u_up * ndc.y * u_tan.y);
  float ground = ground_hit(d);
  float path = shell_length(d, ground > 0.0 ? ground : 1e30);
  // Overhead the sky is deep blue, towards the horizon (long paths) hazy; from space the shell
  // glows where the path through it is long: the limb.
  vec3 sky = mix(ZENITH, HAZE, smoothstep(0.0, 1.0, (path - u_atmosphere) / (8.0 * u_atmosphere)));
  float opacity = 1.0 - exp(-path / (0.5 * u_atmosphere));
  vec3 colour = mix(SPACE, sky, opacity);
  // Where the ray meets the planet but no tile is drawn yet: a dull sea colour, not sky.
  if (ground > 0.0) colour = mix(vec3(0.10, 0.20, 0.30), HAZE, 1.0 - exp(-path / 350e3));
  out_colour = vec4(colour, 1.0);
  out_distance = vec4(-1.0, 0.0, 0.0, 1.0);
}`;
