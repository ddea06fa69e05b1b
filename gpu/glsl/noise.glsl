// Deterministic 2D noise and fractal sums: a line-by-line port of terrain/src/noise.cpp (the
// reference; docs/noise.md gives the formulas). Shared by the server's compute shader and the
// browser's fragment shader. Constants are written as bit patterns so every GLSL compiler reads
// the very floats the C++ uses. Needs from the prelude: fetch_pool(i), fetch_pool_uint(i),
// TERRAIN_PRECISE (the `precise` qualifier where the language has it, else empty).

// Field value and gradient of a 2D scalar function.
struct Sample2 {
  float value;
  float dx;
  float dy;
};

uint noise_hash(uint x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}
uint noise_hash2(uint a, uint b) { return noise_hash(a ^ noise_hash(b + 0x9e3779b9u)); }

const uint kNoiseCos1 = 0x3f7b14beu;  // cos(π/16)
const uint kNoiseSin1 = 0x3e47c5c2u;
const uint kNoiseCos3 = 0x3f54db31u;  // cos(3π/16)
const uint kNoiseSin3 = 0x3f0e39dau;
const uint kNoiseOne = 0x3f800000u;

float noise_positive_part(float x) {
  uint b = floatBitsToUint(x);
  return uintBitsToFloat(b & ~uint(int(b) >> 31));
}
float noise_clamp_magnitude(float x, float limit) {
  uint b = floatBitsToUint(x);
  return uintBitsToFloat((b & 0x80000000u) | min(b & 0x7fffffffu, floatBitsToUint(limit)));
}
float noise_clamp01(float x) {
  return uintBitsToFloat(min(floatBitsToUint(noise_positive_part(x)), kNoiseOne));
}
float noise_unit_if(uint bit) { return uintBitsToFloat((0u - bit) & kNoiseOne); }
float noise_clamp_coord(float x) { return noise_clamp_magnitude(x, uintBitsToFloat(0x4c800000u)); }
int noise_floor_to_int(float x) {
  int i = int(x);
  return i - int(x < float(i));
}
float noise_fade(float t) {
  TERRAIN_PRECISE float r = t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
  return r;
}
float noise_fade_slope(float t) {
  TERRAIN_PRECISE float r = 30.0 * t * t * (t * (t - 2.0) + 1.0);
  return r;
}

vec2 noise_gradient2(uint h) {
  uint wide = 0u - ((h >> 28) & 1u);
  uint swp = 0u - ((h >> 29) & 1u);
  uint a = kNoiseCos1 ^ ((kNoiseCos1 ^ kNoiseCos3) & wide);
  uint b = kNoiseSin1 ^ ((kNoiseSin1 ^ kNoiseSin3) & wide);
  uint exchange = (a ^ b) & swp;
  return vec2(uintBitsToFloat((a ^ exchange) ^ ((h << 1) & 0x80000000u)),
              uintBitsToFloat((b ^ exchange) ^ (h & 0x80000000u)));
}

// Per-octave lattice: hash key and sub-cell offset.
struct Lattice {
  uint key;
  float ox;
  float oy;
};

Lattice noise_lattice(uint seed) {
  const float kUnit = 1.0 / 65536.0;
  uint key = noise_hash(seed ^ 0xa511e9b3u);
  uint h = noise_hash(key ^ 0x68e31da4u);
  return Lattice(key, float(h & 0xffffu) * kUnit, float(h >> 16) * kUnit);
}

Sample2 noise_gradient2_kernel(float x, float y, uint key) {
  x = noise_clamp_coord(x);
  y = noise_clamp_coord(y);
  int ix = noise_floor_to_int(x);
  int iy = noise_floor_to_int(y);
  TERRAIN_PRECISE float fx = x - float(ix);
  TERRAIN_PRECISE float fy = y - float(iy);
  uint ux = uint(ix);
  uint uy = uint(iy);
  uint row0 = noise_hash(uy + key);
  uint row1 = noise_hash(uy + 1u + key);
  vec2 g00 = noise_gradient2(noise_hash(ux + row0));
  vec2 g10 = noise_gradient2(noise_hash(ux + 1u + row0));
  vec2 g01 = noise_gradient2(noise_hash(ux + row1));
  vec2 g11 = noise_gradient2(noise_hash(ux + 1u + row1));
  TERRAIN_PRECISE float fx1 = fx - 1.0;
  TERRAIN_PRECISE float fy1 = fy - 1.0;
  TERRAIN_PRECISE float n00 = g00.x * fx + g00.y * fy;
  TERRAIN_PRECISE float n10 = g10.x * fx1 + g10.y * fy;
  TERRAIN_PRECISE float n01 = g01.x * fx + g01.y * fy1;
  TERRAIN_PRECISE float n11 = g11.x * fx1 + g11.y * fy1;
  float u = noise_fade(fx);
  float v = noise_fade(fy);
  float du = noise_fade_slope(fx);
  float dv = noise_fade_slope(fy);
  TERRAIN_PRECISE float k1 = n10 - n00;
  TERRAIN_PRECISE float k2 = n01 - n00;
  TERRAIN_PRECISE float k3 = (n00 - n10) - (n01 - n11);
  TERRAIN_PRECISE float uv = u * v;
  TERRAIN_PRECISE float value = n00 + u * k1 + v * k2 + uv * k3;
  TERRAIN_PRECISE float gx = g00.x + u * (g10.x - g00.x) + v * (g01.x - g00.x) +
                             uv * ((g00.x - g10.x) - (g01.x - g11.x)) + du * (k1 + v * k3);
  TERRAIN_PRECISE float gy = g00.y + u * (g10.y - g00.y) + v * (g01.y - g00.y) +
                             uv * ((g00.y - g10.y) - (g01.y - g11.y)) + dv * (k2 + u * k3);
  const float kScale = uintBitsToFloat(0x3fb504f3u);  // √2
  return Sample2(kScale * value, kScale * gx, kScale * gy);
}

void noise_simplex_corner2(float x, float y, uint h, inout vec3 acc) {
  vec2 g = noise_gradient2(h);
  TERRAIN_PRECISE float t = noise_positive_part(0.5 - x * x - y * y);
  TERRAIN_PRECISE float t2 = t * t;
  TERRAIN_PRECISE float t4 = t2 * t2;
  TERRAIN_PRECISE float gd = g.x * x + g.y * y;
  TERRAIN_PRECISE float k = -8.0 * t2 * t * gd;
  TERRAIN_PRECISE float v = acc.x + t4 * gd;
  TERRAIN_PRECISE float dx = acc.y + (t4 * g.x + k * x);
  TERRAIN_PRECISE float dy = acc.z + (t4 * g.y + k * y);
  acc = vec3(v, dx, dy);
}

Sample2 noise_simplex2_kernel(float x, float y, uint key) {
  const float kSkew = uintBitsToFloat(0x3ebb67afu);
  const float kUnskew = uintBitsToFloat(0x3e58658cu);
  const float kUnskewTail = uintBitsToFloat(0xb8d3a2c8u);
  const float kUnskew2m1 = uintBitsToFloat(0xbf13cd3au);  // 2·G2 − 1
  x = noise_clamp_coord(x);
  y = noise_clamp_coord(y);
  TERRAIN_PRECISE float s = (x + y) * kSkew;
  TERRAIN_PRECISE float xs = x + s;
  TERRAIN_PRECISE float ys = y + s;
  int i = noise_floor_to_int(xs);
  int j = noise_floor_to_int(ys);
  int n = i + j;
  uint head = uint(n) * 433u;
  int whole = int(head) >> 11;
  float part = float(head & 2047u) * (1.0 / 2048.0);
  TERRAIN_PRECISE float tail = float(n) * kUnskewTail;
  TERRAIN_PRECISE float x0 = ((x - float(i - whole)) + part) + tail;
  TERRAIN_PRECISE float y0 = ((y - float(j - whole)) + part) + tail;
  uint i1 = uint(x0 > y0);
  TERRAIN_PRECISE float x1 = x0 - noise_unit_if(i1) + kUnskew;
  TERRAIN_PRECISE float y1 = y0 - noise_unit_if(1u - i1) + kUnskew;
  TERRAIN_PRECISE float x2 = x0 + kUnskew2m1;
  TERRAIN_PRECISE float y2 = y0 + kUnskew2m1;
  uint ui = uint(i);
  uint uj = uint(j);
  uint row0 = noise_hash(uj + key);
  uint row1 = noise_hash(uj + 1u + key);
  uint h0 = noise_hash(ui + row0);
  uint h1 = noise_hash(ui + i1 + (row1 ^ ((row0 ^ row1) & (0u - i1))));
  uint h2 = noise_hash(ui + 1u + row1);
  vec3 acc = vec3(0.0);
  noise_simplex_corner2(x0, y0, h0, acc);
  noise_simplex_corner2(x1, y1, h1, acc);
  noise_simplex_corner2(x2, y2, h2, acc);
  return Sample2(99.0 * acc.x, 99.0 * acc.y, 99.0 * acc.z);
}

// sin φ, cos φ and their derivatives from the periodic polynomials of noise.cpp.
struct Rotation {
  float s;
  float c;
  float ds;
  float dc;
};

Rotation noise_rotation(float phi) {
  const float kInvTau = uintBitsToFloat(0x3e22f983u);
  const float P0 = uintBitsToFloat(0x41c90fdbu), P1 = uintBitsToFloat(0xc281abf1u),
              P2 = uintBitsToFloat(0x4286273cu), P3 = uintBitsToFloat(0xc219fbc8u),
              P4 = uintBitsToFloat(0x4160cb6cu), P5 = uintBitsToFloat(0xc04a57b0u);
  const float R0 = uintBitsToFloat(0x42000000u), R1 = uintBitsToFloat(0xc26f4f30u),
              R2 = uintBitsToFloat(0x4241a50fu), R3 = uintBitsToFloat(0xc1b62dd6u),
              R4 = uintBitsToFloat(0x40e174a2u), R5 = uintBitsToFloat(0xbfb2530au);
  TERRAIN_PRECISE float x0 = phi * kInvTau;
  float x = noise_clamp_magnitude(x0, uintBitsToFloat(0x4a800000u));
  TERRAIN_PRECISE float xr = x - float(noise_floor_to_int(x + 0.5));
  x = xr;
  TERRAIN_PRECISE float y = x * x;
  TERRAIN_PRECISE float q = 0.25 - y;
  TERRAIN_PRECISE float p = ((((P5 * y + P4) * y + P3) * y + P2) * y + P1) * y + P0;
  TERRAIN_PRECISE float dp =
      (((5.0 * P5 * y + 4.0 * P4) * y + 3.0 * P3) * y + 2.0 * P2) * y + P1;
  TERRAIN_PRECISE float r = ((((R5 * y + R4) * y + R3) * y + R2) * y + R1) * y + R0;
  TERRAIN_PRECISE float dr =
      (((5.0 * R5 * y + 4.0 * R4) * y + 3.0 * R3) * y + 2.0 * R2) * y + R1;
  TERRAIN_PRECISE float sn = x * q * p;
  TERRAIN_PRECISE float cs = q * q * r - 1.0;
  TERRAIN_PRECISE float dsn = (q * p + 2.0 * y * (q * dp - p)) * kInvTau;
  TERRAIN_PRECISE float dcs = 2.0 * x * q * (q * dr - 2.0 * r) * kInvTau;
  return Rotation(sn, cs, dsn, dcs);
}

// Parameters of a fractal as packed by terrain::pack_fractal (16 floats).
struct Fractal {
  uint kind;  // 0 fbm, 1 ridged, 2 hybrid, 3 warped
  uint basis;  // 0 gradient, 1 simplex
  uint seed;
  int octaves;
  float frequency;
  float amplitude;
  float lacunarity;
  float hurst;
  float ridge_offset;
  float ridge_gain;
  float warp_c1;
  float warp_c2;
  vec2 warp_c3;
  float gain;  // r^−H: slot 14 when the loader filled it in (correctly rounded from double)
};

Fractal read_fractal(uint at) {
  return Fractal(fetch_pool_uint(at + kFractalKind), fetch_pool_uint(at + kFractalBasis),
                 fetch_pool_uint(at + kFractalSeed), int(fetch_pool_uint(at + kFractalOctaves)),
                 fetch_pool(at + kFractalFrequency), fetch_pool(at + kFractalAmplitude),
                 fetch_pool(at + kFractalLacunarity), fetch_pool(at + kFractalHurst),
                 fetch_pool(at + kFractalRidgeOffset), fetch_pool(at + kFractalRidgeGain),
                 fetch_pool(at + kFractalWarpC1), fetch_pool(at + kFractalWarpC2),
                 vec2(fetch_pool(at + kFractalWarpC3x), fetch_pool(at + kFractalWarpC3y)),
                 fetch_pool(at + kFractalGain));
}

// Schneider's LoD octave count (the CPU computes the logarithms in double; float here differs by
// a few ulps of the count, and octave weights are C1 in it).
float visible_octaves(Fractal p, float spacing) {
  float full = float(clamp(p.octaves, 0, 24));
  if (!(spacing > 0.0) || !(p.frequency > 0.0) || !(p.lacunarity > 1.0)) return full;
  float n = log(1.0 / (2.0 * spacing * p.frequency)) / log(p.lacunarity) + 1.0;
  return clamp(n, 0.0, full);
}

float octave_weight(int i, float octaves) {
  float fi = float(i);
  if (!(octaves > fi)) return 0.0;
  if (fi + 1.0 <= octaves) return 1.0;
  float t = octaves - fi;
  float u = 1.0 - t * t;
  return 1.0 - u * u * u;
}

// A prelude may leave out fractal kinds and noise bases its programs do not use by defining
// TERRAIN_USES_NOISE_<KIND> as 0 (gpu::node_type_defines), as interpreter.glsl does node types.
#ifndef TERRAIN_USES_NOISE_FBM
#define TERRAIN_USES_NOISE_FBM 1
#endif
#ifndef TERRAIN_USES_NOISE_RIDGED
#define TERRAIN_USES_NOISE_RIDGED 1
#endif
#ifndef TERRAIN_USES_NOISE_HYBRID
#define TERRAIN_USES_NOISE_HYBRID 1
#endif
#ifndef TERRAIN_USES_NOISE_WARPED
#define TERRAIN_USES_NOISE_WARPED 1
#endif
#ifndef TERRAIN_USES_NOISE_GRADIENT
#define TERRAIN_USES_NOISE_GRADIENT 1
#endif
#ifndef TERRAIN_USES_NOISE_SIMPLEX
#define TERRAIN_USES_NOISE_SIMPLEX 1
#endif

Sample2 noise_basis2(uint basis, Lattice l, float x, float y) {
  TERRAIN_PRECISE float px = x + l.ox;
  TERRAIN_PRECISE float py = y + l.oy;
#if TERRAIN_USES_NOISE_SIMPLEX && TERRAIN_USES_NOISE_GRADIENT
  if (basis == 1u) return noise_simplex2_kernel(px, py, l.key);
  return noise_gradient2_kernel(px, py, l.key);
#elif TERRAIN_USES_NOISE_SIMPLEX
  return noise_simplex2_kernel(px, py, l.key);
#else
  return noise_gradient2_kernel(px, py, l.key);
#endif
}

uint noise_free_mask(float x) {
  uint b = floatBitsToUint(x);
  uint outside = ((b - 1u) | (kNoiseOne - 1u - b)) >> 31;
  return outside - 1u;
}

// Value and gradient of the fractal at p (metres, relative to the feature's origin).
Sample2 fractal2(Fractal p, vec2 pt, float octaves) {
  // The CPU rounds a double pow; float pow can differ by an ulp, which the warped kind amplifies
  // without bound. Loaders store the CPU's value in the fractal's spare slot 14 (see
  // gpu::prepare_pool); pow is the fallback.
  float gain = p.gain != 0.0 ? p.gain : pow(p.lacunarity, -p.hurst);
  TERRAIN_PRECISE float rh = p.lacunarity * p.hurst;
  float twist = rh != 0.0 ? p.warp_c1 / rh : 0.0;
  TERRAIN_PRECISE float frequency = p.frequency;
  TERRAIN_PRECISE float amplitude = p.amplitude;
  TERRAIN_PRECISE float relative = 1.0;
  TERRAIN_PRECISE float v = 0.0;
  TERRAIN_PRECISE float dx = 0.0;
  TERRAIN_PRECISE float dy = 0.0;
  // Carried from octave to octave: ridged/hybrid weight W and ∇W, warped height sum T and ∇T.
  TERRAIN_PRECISE float sa = p.kind == 3u ? 0.0 : 1.0;
  TERRAIN_PRECISE float sx = 0.0;
  TERRAIN_PRECISE float sy = 0.0;
  int count = clamp(p.octaves, 0, 24);
  float x = pt.x;
  float y = pt.y;
  for (int i = 0; i < count; ++i) {
    float w = octave_weight(i, octaves);
    if (w <= 0.0) break;
    TERRAIN_PRECISE float oamp = (p.kind == 2u ? p.amplitude : amplitude) * w;
    TERRAIN_PRECISE float oslope = oamp * frequency;
    Lattice l = noise_lattice(noise_hash2(p.seed, uint(i)));
    // Where this octave samples the noise: one call shared by every kind, since a GPU (and a
    // software rasterizer even more) pays for each call site in every branch it cannot skip.
    TERRAIN_PRECISE float qx;
    TERRAIN_PRECISE float qy;
    TERRAIN_PRECISE float j11 = 0.0;
    TERRAIN_PRECISE float j12 = 0.0;
    TERRAIN_PRECISE float j21 = 0.0;
    TERRAIN_PRECISE float j22 = 0.0;
#if TERRAIN_USES_NOISE_WARPED
    if (p.kind == 3u) {
      // Warped: φ = twist·T + i·c2, q = f·Rot(φ)p + c3·T.
      TERRAIN_PRECISE float phase = float(i) * p.warp_c2;
      TERRAIN_PRECISE float phi = twist * sa + phase;
      TERRAIN_PRECISE float phix = twist * sx;
      TERRAIN_PRECISE float phiy = twist * sy;
      Rotation r = noise_rotation(phi);
      TERRAIN_PRECISE float f = frequency;
      qx = f * (r.c * x - r.s * y) + p.warp_c3.x * sa;
      qy = f * (r.s * x + r.c * y) + p.warp_c3.y * sa;
      TERRAIN_PRECISE float tx = f * (r.dc * x - r.ds * y);
      TERRAIN_PRECISE float ty = f * (r.ds * x + r.dc * y);
      TERRAIN_PRECISE float fc = f * r.c;
      TERRAIN_PRECISE float fs = f * r.s;
      j11 = fc + tx * phix + p.warp_c3.x * sx;
      j12 = (tx * phiy - fs) + p.warp_c3.x * sy;
      j21 = fs + ty * phix + p.warp_c3.y * sx;
      j22 = fc + ty * phiy + p.warp_c3.y * sy;
    } else
#endif
    {
      qx = x * frequency;
      qy = y * frequency;
    }
    Sample2 n = noise_basis2(p.basis, l, qx, qy);
    // Each kind's use of the sample; kind is one value, so at most one of these runs.
#if TERRAIN_USES_NOISE_FBM
    if (p.kind == 0u) {
      v += oamp * n.value;
      dx += oslope * n.dx;
      dy += oslope * n.dy;
    }
#endif
#if TERRAIN_USES_NOISE_RIDGED
    if (p.kind == 1u) {
      TERRAIN_PRECISE float nx = frequency * n.dx;
      TERRAIN_PRECISE float ny = frequency * n.dy;
      uint sign = floatBitsToUint(n.value) & 0x80000000u;
      TERRAIN_PRECISE float m = p.ridge_offset - uintBitsToFloat(floatBitsToUint(n.value) ^ sign);
      TERRAIN_PRECISE float s = m * m;
      TERRAIN_PRECISE float m2 = -2.0 * m;
      float ds = uintBitsToFloat(floatBitsToUint(m2) ^ sign);
      TERRAIN_PRECISE float gx = ds * nx;
      TERRAIN_PRECISE float gy = ds * ny;
      v += oamp * (s * sa);
      dx += oamp * (sa * gx + s * sx);
      dy += oamp * (sa * gy + s * sy);
      TERRAIN_PRECISE float raw = p.ridge_gain * s;
      uint fr = noise_free_mask(raw);
      sa = noise_clamp01(raw);
      TERRAIN_PRECISE float wx = p.ridge_gain * gx;
      TERRAIN_PRECISE float wy = p.ridge_gain * gy;
      sx = uintBitsToFloat(floatBitsToUint(wx) & fr);
      sy = uintBitsToFloat(floatBitsToUint(wy) & fr);
    }
#endif
#if TERRAIN_USES_NOISE_HYBRID
    if (p.kind == 2u) {
      TERRAIN_PRECISE float nx = frequency * n.dx;
      TERRAIN_PRECISE float ny = frequency * n.dy;
      TERRAIN_PRECISE float s = (n.value + p.ridge_offset) * relative;
      TERRAIN_PRECISE float gx = relative * nx;
      TERRAIN_PRECISE float gy = relative * ny;
      TERRAIN_PRECISE float px = sa * gx + s * sx;
      TERRAIN_PRECISE float py = sa * gy + s * sy;
      TERRAIN_PRECISE float raw = sa * s;
      v += oamp * raw;
      dx += oamp * px;
      dy += oamp * py;
      uint fr = noise_free_mask(raw);
      sa = noise_clamp01(raw);
      sx = uintBitsToFloat(floatBitsToUint(px) & fr);
      sy = uintBitsToFloat(floatBitsToUint(py) & fr);
    }
#endif
#if TERRAIN_USES_NOISE_WARPED
    if (p.kind == 3u) {
      v += oamp * n.value;
      dx += oamp * (n.dx * j11 + n.dy * j21);
      dy += oamp * (n.dx * j12 + n.dy * j22);
      sa += v;
      sx += dx;
      sy += dy;
    }
#endif
    frequency *= p.lacunarity;
    amplitude *= gain;
    relative *= gain;
  }
  return Sample2(v, dx, dy);
}
