// Node kernels: ports of terrain/src/nodes/*.cpp and of the geometry they read
// (terrain/src/{profile,polyline,contour,heightfield}.cpp), one point at a time. Parameters are read
// from the pool at the node's offset, in the layouts those files document. Needs noise.glsl and
// portable_math.glsl.

// f, α and both gradients at one point (a FieldBlock lane).
struct Field {
  float f;
  float a;
  float fx;
  float fy;
  float ax;
  float ay;
};

Field field_zero() { return Field(0.0, 0.0, 0.0, 0.0, 0.0, 0.0); }

// Wyvill's fall-off g(d) = (1 − (d/r)²)³ and dg/dd (terrain::Falloff::eval).
vec2 falloff_eval(float d, float r) {
  TERRAIN_PRECISE float t = d / r;
  TERRAIN_PRECISE float s = t < 1.0 ? 1.0 - t * t : 0.0;
  TERRAIN_PRECISE float g = s * s * s;
  TERRAIN_PRECISE float dg = -6.0 * t * s * s / r;
  return vec2(g, dg);
}

// ---------------------------------------------------------------------------------------------
// disc (type 1): centre, radius, elevation, fractal.

Field disc_leaf(uint at, vec2 p, float spacing) {
  vec2 c = vec2(fetch_pool(at), fetch_pool(at + 1u));
  float radius = fetch_pool(at + 2u);
  float elevation = fetch_pool(at + 3u);
  Fractal fr = read_fractal(at + kDiscFractal);
  TERRAIN_PRECISE float lx = p.x - c.x;
  TERRAIN_PRECISE float ly = p.y - c.y;
  TERRAIN_PRECISE float d = sqrt(lx * lx + ly * ly);
  vec2 g = falloff_eval(d, radius);
  TERRAIN_PRECISE float inv = d > 0.0 ? g.y / d : 0.0;
  Field out_field = Field(elevation, g.x, 0.0, 0.0, inv * lx, inv * ly);
  if (fr.amplitude == 0.0) return out_field;
  float octaves = visible_octaves(fr, spacing);
  if (fr.kind != 3u) {
    Sample2 n = fractal2(fr, vec2(lx, ly), octaves);
    out_field.f = n.value + elevation;
    out_field.fx = n.dx;
    out_field.fy = n.dy;
    return out_field;
  }
  // The warped fractal is extended radially outside the disc (see disc.cpp).
  TERRAIN_PRECISE float scale = d > radius ? radius / d : 1.0;
  TERRAIN_PRECISE float sx = lx * scale;
  TERRAIN_PRECISE float sy = ly * scale;
  Sample2 n = fractal2(fr, vec2(sx, sy), octaves);
  TERRAIN_PRECISE float fx = n.dx;
  TERRAIN_PRECISE float fy = n.dy;
  if (scale < 1.0) {
    TERRAIN_PRECISE float ux = sx / radius;
    TERRAIN_PRECISE float uy = sy / radius;
    TERRAIN_PRECISE float radial = fx * ux + fy * uy;
    fx = scale * (n.dx - radial * ux);
    fy = scale * (n.dy - radial * uy);
  }
  out_field.f = n.value + elevation;
  out_field.fx = fx;
  out_field.fy = fy;
  return out_field;
}

// ---------------------------------------------------------------------------------------------
// Profiles: block [n, (d, h, m) × n] (terrain::profile_eval). Returns (value, slope).

vec2 profile_eval(uint at, float d) {
  int n = int(fetch_pool(at));
  uint node = at + 1u;
  float first = fetch_pool(node);
  float last = fetch_pool(node + 3u * uint(n - 1));
  float x = min(max(d, first), last);
  int lo = 0;
  int hi = n - 1;
  while (hi - lo > 1) {
    int mid = (lo + hi) / 2;
    if (fetch_pool(node + 3u * uint(mid)) <= x)
      lo = mid;
    else
      hi = mid;
  }
  uint a = node + 3u * uint(lo);
  float a0 = fetch_pool(a), a1 = fetch_pool(a + 1u), a2 = fetch_pool(a + 2u);
  float b0 = fetch_pool(a + 3u), b1 = fetch_pool(a + 4u), b2 = fetch_pool(a + 5u);
  TERRAIN_PRECISE float big_h = b0 - a0;
  TERRAIN_PRECISE float mb = 2.0 * (b1 - a1) / big_h - 0.5 * (a2 + b2);
  TERRAIN_PRECISE float half_h = 0.5 * big_h;
  TERRAIN_PRECISE float xa = x - a0;
  bool right = xa > half_h;
  float y = right ? b1 : a1;
  float s0 = right ? b2 : a2;
  TERRAIN_PRECISE float q = right ? (b2 - mb) / big_h : (mb - a2) / big_h;
  TERRAIN_PRECISE float w = right ? x - b0 : x - a0;
  TERRAIN_PRECISE float value = y + (s0 + q * w) * w;
  TERRAIN_PRECISE float slope = s0 + 2.0 * q * w;
  return vec2(value, (d < first || d > last) ? 0.0 : slope);
}

// ---------------------------------------------------------------------------------------------
// Polylines: block [segments, chunks, (x, y, z, s) × (segments + 1), chunk boxes × chunks]
// (terrain::polyline_eval with chunk culling; chunks of 16 segments).

struct PolylineHit {
  bool found;
  float distance;
  float signed_distance;
  float s;
  float z;
  vec2 grad_d;
  vec2 grad_s;
  vec2 grad_z;
};

vec2 pool_vec2(uint at) { return vec2(fetch_pool(at), fetch_pool(at + 1u)); }

PolylineHit polyline_eval(uint at, vec2 p, float cutoff) {
  int segments = int(fetch_pool(at));
  int chunks = int(fetch_pool(at + 1u));
  uint vtx = at + 2u;
  uint box = vtx + 4u * uint(segments + 1);
  TERRAIN_PRECISE float limit2 = cutoff * cutoff;
  float best2 = uintBitsToFloat(0x7f800000u);
  int best = -1;
  float best_h = 0.0;
  for (int c = 0; c < chunks; ++c) {
    uint b = box + 4u * uint(c);
    TERRAIN_PRECISE float bdx = max(max(fetch_pool(b) - p.x, 0.0), p.x - fetch_pool(b + 2u));
    TERRAIN_PRECISE float bdy = max(max(fetch_pool(b + 1u) - p.y, 0.0), p.y - fetch_pool(b + 3u));
    TERRAIN_PRECISE float bd2 = bdx * bdx + bdy * bdy;
    if (bd2 > min(best2, limit2)) continue;
    for (int k = 0; k < 16; ++k) {
      int i = c * 16 + k;
      if (i >= segments) break;
      uint va = vtx + 4u * uint(i);
      vec2 a = pool_vec2(va);
      TERRAIN_PRECISE vec2 e = pool_vec2(va + 4u) - a;
      TERRAIN_PRECISE vec2 w = p - a;
      TERRAIN_PRECISE float h = clamp((w.x * e.x + w.y * e.y) / (e.x * e.x + e.y * e.y), 0.0, 1.0);
      TERRAIN_PRECISE vec2 r = w - e * h;
      TERRAIN_PRECISE float d2 = r.x * r.x + r.y * r.y;
      if (d2 < best2) {
        best2 = d2;
        best = i;
        best_h = h;
      }
    }
  }
  PolylineHit out_hit =
      PolylineHit(false, cutoff, cutoff, 0.0, 0.0, vec2(0.0), vec2(0.0), vec2(0.0));
  if (best < 0 || best2 > limit2) return out_hit;
  out_hit.found = true;
  uint va = vtx + 4u * uint(best);
  uint vb = va + 4u;
  vec2 a = pool_vec2(va);
  float az = fetch_pool(va + 2u), as_ = fetch_pool(va + 3u);
  float bz = fetch_pool(vb + 2u), bs = fetch_pool(vb + 3u);
  TERRAIN_PRECISE vec2 e = pool_vec2(vb) - a;
  TERRAIN_PRECISE float ee = e.x * e.x + e.y * e.y;
  if (best_h > 0.0 && best_h < 1.0) {
    TERRAIN_PRECISE float len = sqrt(ee);
    TERRAIN_PRECISE vec2 t = e * (1.0 / len);
    vec2 n = vec2(-t.y, t.x);
    TERRAIN_PRECISE vec2 pa = p - a;
    TERRAIN_PRECISE float sd = pa.x * n.x + pa.y * n.y;
    out_hit.signed_distance = sd;
    out_hit.distance = abs(sd);
    out_hit.grad_d = n;
    TERRAIN_PRECISE float s = as_ + best_h * (bs - as_);
    TERRAIN_PRECISE float z = az + best_h * (bz - az);
    out_hit.s = s;
    out_hit.z = z;
    TERRAIN_PRECISE vec2 gs = e * ((bs - as_) / ee);
    TERRAIN_PRECISE vec2 gz = e * ((bz - az) / ee);
    out_hit.grad_s = gs;
    out_hit.grad_z = gz;
    return out_hit;
  }
  int v = best_h <= 0.0 ? best : best + 1;
  uint vq = vtx + 4u * uint(v);
  vec2 q = pool_vec2(vq);
  out_hit.z = fetch_pool(vq + 2u);
  out_hit.s = fetch_pool(vq + 3u);
  int i0 = max(v - 1, 0);
  int i1 = min(v, segments - 1);
  TERRAIN_PRECISE vec2 e0 = pool_vec2(vtx + 4u * uint(i0) + 4u) - pool_vec2(vtx + 4u * uint(i0));
  TERRAIN_PRECISE vec2 e1 = pool_vec2(vtx + 4u * uint(i1) + 4u) - pool_vec2(vtx + 4u * uint(i1));
  TERRAIN_PRECISE vec2 n0 = vec2(-e0.y, e0.x) * (1.0 / sqrt(e0.x * e0.x + e0.y * e0.y));
  TERRAIN_PRECISE vec2 n1 = vec2(-e1.y, e1.x) * (1.0 / sqrt(e1.x * e1.x + e1.y * e1.y));
  TERRAIN_PRECISE vec2 bisector = n0 + n1;
  TERRAIN_PRECISE float bb = bisector.x * bisector.x + bisector.y * bisector.y;
  if (bb < 1e-12) bisector = n0;
  TERRAIN_PRECISE vec2 w = p - q;
  TERRAIN_PRECISE float d = sqrt(w.x * w.x + w.y * w.y);
  TERRAIN_PRECISE float side = w.x * bisector.x + w.y * bisector.y;
  float sign_ = side >= 0.0 ? 1.0 : -1.0;
  out_hit.distance = d;
  out_hit.signed_distance = sign_ * d;
  TERRAIN_PRECISE vec2 gd = d > 0.0 ? w * (sign_ / d) : vec2(0.0);
  out_hit.grad_d = gd;
  return out_hit;
}

// ---------------------------------------------------------------------------------------------
// curve (type 2): 0 falloff, 1 length, 2 profile count, 3 polyline offset, 9 core, 10.. table of
// (at, profile offset); offsets are relative to the node's first float.

Field curve_leaf(uint at, vec2 p, float cutoff) {
  float falloff = fetch_pool(at);
  float len = fetch_pool(at + 1u);
  uint count = uint(fetch_pool(at + 2u));
  uint polyline = at + uint(fetch_pool(at + 3u));
  float core = fetch_pool(at + 9u);
  uint table = at + 10u;
  PolylineHit q = polyline_eval(polyline, p, cutoff);
  if (!q.found) return field_zero();
  TERRAIN_PRECISE float u = len > 0.0 ? q.s / len : 0.0;
  uint k = 0u;
  while (k + 2u < count && fetch_pool(table + 2u * (k + 1u)) <= u) ++k;
  float value;
  float slope;
  TERRAIN_PRECISE float dvalue_ds = 0.0;
  if (count == 1u || u <= fetch_pool(table)) {
    vec2 c = profile_eval(at + uint(fetch_pool(table + 1u)), q.signed_distance);
    value = c.x;
    slope = c.y;
  } else {
    uint k1 = min(k + 1u, count - 1u);
    float a0 = fetch_pool(table + 2u * k), a1 = fetch_pool(table + 2u * k1);
    TERRAIN_PRECISE float x = a1 > a0 ? clamp((u - a0) / (a1 - a0), 0.0, 1.0) : 1.0;
    TERRAIN_PRECISE float t = x * x * (3.0 - 2.0 * x);
    TERRAIN_PRECISE float dt_dx = (x > 0.0 && x < 1.0) ? 6.0 * x * (1.0 - x) : 0.0;
    vec2 ca = profile_eval(at + uint(fetch_pool(table + 2u * k + 1u)), q.signed_distance);
    vec2 cb = profile_eval(at + uint(fetch_pool(table + 2u * k1 + 1u)), q.signed_distance);
    TERRAIN_PRECISE float dt = cb.x - ca.x;
    TERRAIN_PRECISE float bv = ca.x + t * dt;
    TERRAIN_PRECISE float bs = ca.y + t * (cb.y - ca.y);
    value = bv;
    slope = bs;
    if (a1 > a0) dvalue_ds = dt * dt_dx / ((a1 - a0) * len);
  }
  TERRAIN_PRECISE float f = q.z + value;
  TERRAIN_PRECISE float fx = q.grad_z.x + slope * q.grad_d.x + dvalue_ds * q.grad_s.x;
  TERRAIN_PRECISE float fy = q.grad_z.y + slope * q.grad_d.y + dvalue_ds * q.grad_s.y;
  TERRAIN_PRECISE float dist = max(0.0, q.distance - core);
  vec2 g = falloff_eval(dist, falloff);
  float sign_ = q.signed_distance < 0.0 ? -1.0 : 1.0;
  TERRAIN_PRECISE float ax = g.y * sign_ * q.grad_d.x;
  TERRAIN_PRECISE float ay = g.y * sign_ * q.grad_d.y;
  return Field(f, g.x, fx, fy, ax, ay);
}

// A curve leaf; where the parent ignores f outside the weight's support, far points stop early.
Field curve_leaf_field(uint at, vec2 p, bool weighted_only) {
  float cutoff = weighted_only ? (fetch_pool(at + 9u) + fetch_pool(at)) * 1.001
                               : uintBitsToFloat(0x7f800000u);
  return curve_leaf(at, p, cutoff);
}

// ---------------------------------------------------------------------------------------------
// contour (type 3): 0 elevation, 1 falloff (in ρ), 10.. the contour block
// [cx, cy, cos, sin, K, sectors, (R, m) × K, profile offsets × sectors] (terrain::contour_eval).

Field contour_leaf(uint at, vec2 p) {
  const float kTwoPi = uintBitsToFloat(0x40c90fdbu);
  float elevation = fetch_pool(at);
  float falloff = fetch_pool(at + 1u);
  uint block = at + 10u;
  vec2 centre = pool_vec2(block);
  float cs = fetch_pool(block + 2u), sn = fetch_pool(block + 3u);
  int count = int(fetch_pool(block + 4u));
  int sectors = int(fetch_pool(block + 5u));
  uint node = block + 6u;
  uint offsets = node + 2u * uint(count);
  TERRAIN_PRECISE vec2 l = p - centre;
  TERRAIN_PRECISE float r = sqrt(l.x * l.x + l.y * l.y);
  TERRAIN_PRECISE float ly = -sn * l.x + cs * l.y;
  TERRAIN_PRECISE float lx = cs * l.x + sn * l.y;
  float theta = portable_atan2(ly, lx);  // bit for bit the CPU's angle
  if (theta < 0.0) theta += kTwoPi;
  if (theta >= kTwoPi) theta = 0.0;
  // Radius spline (radius_eval).
  TERRAIN_PRECISE float scale = float(count) / kTwoPi;
  TERRAIN_PRECISE float u = theta * scale;
  u -= float(count) * floor(u / float(count));
  int k = min(int(u), count - 1);
  int k1 = k + 1 == count ? 0 : k + 1;
  TERRAIN_PRECISE float fk = u - float(k);
  float r0 = fetch_pool(node + 2u * uint(k)), m0 = fetch_pool(node + 2u * uint(k) + 1u);
  float r1 = fetch_pool(node + 2u * uint(k1)), m1 = fetch_pool(node + 2u * uint(k1) + 1u);
  TERRAIN_PRECISE float mb = 2.0 * (r1 - r0) - 0.5 * (m0 + m1);
  bool right = fk > 0.5;
  float y = right ? r1 : r0;
  float s0 = right ? m1 : m0;
  TERRAIN_PRECISE float q = right ? m1 - mb : mb - m0;
  TERRAIN_PRECISE float w = right ? fk - 1.0 : fk;
  TERRAIN_PRECISE float radius = y + (s0 + q * w) * w;
  TERRAIN_PRECISE float radius_slope = (s0 + 2.0 * q * w) * scale;
  TERRAIN_PRECISE float rho = r / radius;
  // Sector blend.
  TERRAIN_PRECISE float sector_scale = float(sectors) / kTwoPi;
  TERRAIN_PRECISE float v = theta * sector_scale;
  int j = min(int(v), sectors - 1);
  int j1 = j + 1 == sectors ? 0 : j + 1;
  TERRAIN_PRECISE float t = v - float(j);
  TERRAIN_PRECISE float weight = t * t * (3.0 - 2.0 * t);
  TERRAIN_PRECISE float weight_slope = 6.0 * t * (1.0 - t) * sector_scale;
  vec2 a = profile_eval(block + uint(fetch_pool(offsets + uint(j))), rho);
  vec2 b = profile_eval(block + uint(fetch_pool(offsets + uint(j1))), rho);
  TERRAIN_PRECISE float diff = b.x - a.x;
  TERRAIN_PRECISE float value = a.x + weight * diff;
  TERRAIN_PRECISE float d_rho = a.y + weight * (b.y - a.y);
  TERRAIN_PRECISE float d_theta = sectors > 1 ? weight_slope * diff : 0.0;
  TERRAIN_PRECISE vec2 grad = vec2(0.0);
  if (r > 0.0) {
    TERRAIN_PRECISE vec2 er = l * (1.0 / r);
    vec2 et = vec2(-er.y, er.x);
    TERRAIN_PRECISE float inv_r = 1.0 / radius;
    TERRAIN_PRECISE float radial = d_rho * inv_r;
    TERRAIN_PRECISE float tangential = d_theta / r - d_rho * radius_slope * inv_r * inv_r;
    grad = er * radial + et * tangential;
  }
  // Weight: fall-off of ρ (contour_leaf in nodes/contour.cpp).
  vec2 g = falloff_eval(rho, falloff);
  TERRAIN_PRECISE float gx = 0.0;
  TERRAIN_PRECISE float gy = 0.0;
  if (r > 0.0) {
    TERRAIN_PRECISE float inv_r = 1.0 / r;
    TERRAIN_PRECISE float kk = radius_slope / (radius * radius) * inv_r;
    gx = l.x * inv_r / radius + kk * l.y;
    gy = l.y * inv_r / radius - kk * l.x;
  }
  TERRAIN_PRECISE float f = elevation + value;
  TERRAIN_PRECISE float ax = g.y * gx;
  TERRAIN_PRECISE float ay = g.y * gy;
  return Field(f, g.x, grad.x, grad.y, ax, ay);
}

// ---------------------------------------------------------------------------------------------
// image (type 4): 0 λ_f, 1 λ_α, 2 h_lo, 3 h_hi, 4..7 box, 8 mapping record, 9 heightfield record
// (offsets relative to the node), 10 mapping (0 quad, 1 curve, 2 the box), 11 width, 12 curve length
// (nodes/image.cpp). The heightfield and quad functions are line-by-line ports of
// terrain/src/heightfield.cpp. Image samples are read through fetch_image(i), i being the
// sample's pool index: a prelude that keeps images apart (a WebGL2 texture) defines
// TERRAIN_HAS_FETCH_IMAGE and its own fetch_image; otherwise they are read from the pool, where
// Heightfield::pack stores them.

#ifndef TERRAIN_HAS_FETCH_IMAGE
float fetch_image(uint i) { return fetch_pool(i); }
#endif

// A scalar and its derivatives with respect to (u, v) (terrain::UvSample).
struct UvSample {
  float value;
  float du;
  float dv;
};

// (u, v) of a point and their gradients (terrain::UvMap).
struct UvMap {
  float u;
  float v;
  vec2 du;
  vec2 dv;
};

float hf_clamp01(float x) { return x > 0.0 ? (x < 1.0 ? x : 1.0) : 0.0; }

float hf_dot(vec2 a, vec2 b) {
  TERRAIN_PRECISE float r = a.x * b.x + a.y * b.y;
  return r;
}

float hf_cross(vec2 a, vec2 b) {
  TERRAIN_PRECISE float r = a.x * b.y - a.y * b.x;
  return r;
}

UvSample hf_bilinear(uint grid, int n, int m, float u, float v) {
  TERRAIN_PRECISE float x = hf_clamp01(u) * float(n - 1);
  TERRAIN_PRECISE float y = hf_clamp01(v) * float(m - 1);
  int i = min(int(x), n - 2);
  int j = min(int(y), m - 2);
  TERRAIN_PRECISE float fx = x - float(i);
  TERRAIN_PRECISE float fy = y - float(j);
  uint k00 = grid + uint(j) * uint(n) + uint(i);
  uint k01 = k00 + uint(n);
  float h00 = fetch_image(k00);
  float h10 = fetch_image(k00 + 1u);
  float h01 = fetch_image(k01);
  float h11 = fetch_image(k01 + 1u);
  TERRAIN_PRECISE float top = (1.0 - fx) * h00 + fx * h10;
  TERRAIN_PRECISE float bottom = (1.0 - fx) * h01 + fx * h11;
  TERRAIN_PRECISE float value = (1.0 - fy) * top + fy * bottom;
  UvSample s = UvSample(value, 0.0, 0.0);
  if (u >= 0.0 && u <= 1.0) {
    TERRAIN_PRECISE float du = float(n - 1) * ((1.0 - fy) * (h10 - h00) + fy * (h11 - h01));
    s.du = du;
  }
  if (v >= 0.0 && v <= 1.0) {
    TERRAIN_PRECISE float dv = float(m - 1) * (bottom - top);
    s.dv = dv;
  }
  return s;
}

// Catmull-Rom weights (w) and their derivatives (d) of the four samples around t in [0, 1]
// (heightfield.cpp cubic_weights).
void hf_cubic_weights(float t, out vec4 w, out vec4 d) {
  TERRAIN_PRECISE float t2 = t * t;
  TERRAIN_PRECISE float t3 = t2 * t;
  TERRAIN_PRECISE float w0 = (2.0 * t2 - t3 - t) * 0.5;
  TERRAIN_PRECISE float w1 = (3.0 * t3 - 5.0 * t2 + 2.0) * 0.5;
  TERRAIN_PRECISE float w2 = (4.0 * t2 - 3.0 * t3 + t) * 0.5;
  TERRAIN_PRECISE float w3 = (t3 - t2) * 0.5;
  TERRAIN_PRECISE float d0 = (4.0 * t - 3.0 * t2 - 1.0) * 0.5;
  TERRAIN_PRECISE float d1 = (9.0 * t2 - 10.0 * t) * 0.5;
  TERRAIN_PRECISE float d2 = (8.0 * t - 9.0 * t2 + 1.0) * 0.5;
  TERRAIN_PRECISE float d3 = (3.0 * t2 - 2.0 * t) * 0.5;
  w = vec4(w0, w1, w2, w3);
  d = vec4(d0, d1, d2, d3);
}

// Catmull-Rom bicubic (heightfield.cpp bicubic), indices clamped to the grid.
UvSample hf_bicubic(uint grid, int n, int m, float u, float v) {
  TERRAIN_PRECISE float x = hf_clamp01(u) * float(n - 1);
  TERRAIN_PRECISE float y = hf_clamp01(v) * float(m - 1);
  int i = min(int(x), n - 2);
  int j = min(int(y), m - 2);
  TERRAIN_PRECISE float fx = x - float(i);
  TERRAIN_PRECISE float fy = y - float(j);
  vec4 wx;
  vec4 dx;
  vec4 wy;
  vec4 dy;
  hf_cubic_weights(fx, wx, dx);
  hf_cubic_weights(fy, wy, dy);
  TERRAIN_PRECISE float value = 0.0;
  TERRAIN_PRECISE float along_u = 0.0;
  TERRAIN_PRECISE float along_v = 0.0;
  for (int r = 0; r < 4; ++r) {
    int row = clamp(j - 1 + r, 0, m - 1);
    uint at = grid + uint(row) * uint(n);
    TERRAIN_PRECISE float row_value = 0.0;
    TERRAIN_PRECISE float row_slope = 0.0;
    for (int c = 0; c < 4; ++c) {
      float h = fetch_image(at + uint(clamp(i - 1 + c, 0, n - 1)));
      row_value = row_value + wx[c] * h;
      row_slope = row_slope + dx[c] * h;
    }
    value = value + wy[r] * row_value;
    along_u = along_u + wy[r] * row_slope;
    along_v = along_v + dy[r] * row_value;
  }
  UvSample s = UvSample(value, 0.0, 0.0);
  if (u >= 0.0 && u <= 1.0) {
    TERRAIN_PRECISE float du = float(n - 1) * along_u;
    s.du = du;
  }
  if (v >= 0.0 && v <= 1.0) {
    TERRAIN_PRECISE float dv = float(m - 1) * along_v;
    s.dv = dv;
  }
  return s;
}

// The Wyvill-type ramp w(t) = 1 − (1 − t²)³ on [0, 1] and its slope (heightfield.cpp ramp()).
vec2 hf_ramp(float t) {
  if (!(t > 0.0)) return vec2(0.0);
  if (t >= 1.0) return vec2(1.0, 0.0);
  TERRAIN_PRECISE float q = 1.0 - t * t;
  TERRAIN_PRECISE float value = 1.0 - q * q * q;
  TERRAIN_PRECISE float slope = 6.0 * t * q * q;
  return vec2(value, slope);
}

vec2 hf_border_ramp(float x, float margin) {
  bool low = x < 0.5;
  TERRAIN_PRECISE float mirrored = 1.0 - x;
  TERRAIN_PRECISE float s = (low ? x : mirrored) / margin;
  vec2 r = hf_ramp(s);
  TERRAIN_PRECISE float slope = (low ? r.y : -r.y) / margin;
  return vec2(r.x, slope);
}

UvSample heightfield_height(uint base, float u, float v) {
  int n = int(fetch_pool(base));
  int m = int(fetch_pool(base + 1u));
  float offset = fetch_pool(base + 2u);
  float scale = fetch_pool(base + 3u);
  // (No ?: between structures: WebGL refuses it.)
  UvSample s;
  if (fetch_pool(base + 7u) > 0.5) {
    s = hf_bicubic(base + 8u, n, m, u, v);
  } else {
    s = hf_bilinear(base + 8u, n, m, u, v);
  }
  TERRAIN_PRECISE float value = offset + scale * s.value;
  TERRAIN_PRECISE float du = scale * s.du;
  TERRAIN_PRECISE float dv = scale * s.dv;
  return UvSample(value, du, dv);
}

UvSample heightfield_weight(uint base, float u, float v) {
  int n = int(fetch_pool(base));
  int m = int(fetch_pool(base + 1u));
  vec2 bu = hf_border_ramp(u, fetch_pool(base + 4u));
  vec2 bv = hf_border_ramp(v, fetch_pool(base + 5u));
  TERRAIN_PRECISE float bvalue = bu.x * bv.x;
  TERRAIN_PRECISE float bdu = bu.y * bv.x;
  TERRAIN_PRECISE float bdv = bu.x * bv.y;
  if (!(fetch_pool(base + 6u) > 0.5)) return UvSample(bvalue, bdu, bdv);
  uint grid = base + 8u + uint(n) * uint(m);
  UvSample omega = hf_bilinear(grid, n, m, u, v);
  vec2 a = hf_ramp(omega.value);
  TERRAIN_PRECISE float value = a.x * bvalue;
  TERRAIN_PRECISE float du = a.x * bdu + bvalue * a.y * omega.du;
  TERRAIN_PRECISE float dv = a.x * bdv + bvalue * a.y * omega.dv;
  return UvSample(value, du, dv);
}

// terrain::quad_inverse: (u, v) of p inside the quad (closed-form root, two Newton steps), or of
// the nearest boundary point outside.
UvMap quad_inverse(uint base, vec2 p) {
  vec2 corner[4];
  for (int k = 0; k < 4; ++k) corner[k] = pool_vec2(base + 2u * uint(k));
  float sigma = fetch_pool(base + 8u);
  bool inside = true;
  for (int k = 0; k < 4; ++k) {
    TERRAIN_PRECISE vec2 edge = corner[(k + 1) & 3] - corner[k];
    TERRAIN_PRECISE vec2 rel = p - corner[k];
    TERRAIN_PRECISE float side = sigma * hf_cross(edge, rel);
    if (side < 0.0) inside = false;
  }
  UvMap map = UvMap(0.0, 0.0, vec2(0.0), vec2(0.0));
  if (inside) {
    vec2 a = corner[0];
    TERRAIN_PRECISE vec2 e = corner[1] - a;
    TERRAIN_PRECISE vec2 f = corner[3] - a;
    TERRAIN_PRECISE vec2 g = (corner[2] - corner[3]) - e;
    TERRAIN_PRECISE vec2 h = p - a;
    TERRAIN_PRECISE float k2 = hf_cross(g, f);
    TERRAIN_PRECISE float k1 = hf_cross(e, f) + hf_cross(h, g);
    TERRAIN_PRECISE float k0 = hf_cross(h, e);
    TERRAIN_PRECISE float disc = k1 * k1 - 4.0 * k0 * k2;
    TERRAIN_PRECISE float root = sqrt(max(disc, 0.0));
    TERRAIN_PRECISE float v = 0.0;
    TERRAIN_PRECISE float sk1 = sigma * k1;
    if (sk1 > 0.0) {
      v = 2.0 * k0 / (-k1 - sigma * root);
    } else if (k2 != 0.0) {
      v = (-k1 + sigma * root) / (2.0 * k2);
    }
    v = hf_clamp01(v);
    TERRAIN_PRECISE vec2 ev = e + g * v;
    TERRAIN_PRECISE vec2 hv = h - f * v;
    TERRAIN_PRECISE float u = hf_clamp01(hf_dot(hv, ev) / hf_dot(ev, ev));
    TERRAIN_PRECISE vec2 fu = f + g * u;
    for (int iteration = 0; iteration < 2; ++iteration) {
      TERRAIN_PRECISE vec2 residual = (e * u + fu * v) - h;
      TERRAIN_PRECISE float inv_det = 1.0 / hf_cross(ev, fu);
      TERRAIN_PRECISE float nu = u - hf_cross(residual, fu) * inv_det;
      TERRAIN_PRECISE float nv = v - hf_cross(ev, residual) * inv_det;
      u = hf_clamp01(nu);
      v = hf_clamp01(nv);
      ev = e + g * v;
      fu = f + g * u;
    }
    TERRAIN_PRECISE float inv = 1.0 / hf_cross(ev, fu);
    map.u = u;
    map.v = v;
    TERRAIN_PRECISE vec2 du = vec2(fu.y, -fu.x) * inv;
    TERRAIN_PRECISE vec2 dv = vec2(-ev.y, ev.x) * inv;
    map.du = du;
    map.dv = dv;
    return map;
  }
  float best = uintBitsToFloat(0x7f800000u);
  for (int k = 0; k < 4; ++k) {
    vec2 start = corner[k];
    TERRAIN_PRECISE vec2 edge = corner[(k + 1) & 3] - start;
    TERRAIN_PRECISE float inv_len2 = 1.0 / hf_dot(edge, edge);
    TERRAIN_PRECISE vec2 rel = p - start;
    TERRAIN_PRECISE float t_raw = hf_dot(rel, edge) * inv_len2;
    float t = hf_clamp01(t_raw);
    TERRAIN_PRECISE vec2 foot = start + edge * t;
    TERRAIN_PRECISE vec2 off = p - foot;
    float dist2 = hf_dot(off, off);
    if (dist2 < best) {
      best = dist2;
      TERRAIN_PRECISE vec2 grad = (t_raw > 0.0 && t_raw < 1.0) ? edge * inv_len2 : vec2(0.0);
      TERRAIN_PRECISE float rest = 1.0 - t;
      map.u = k == 0 ? t : (k == 1 ? 1.0 : (k == 2 ? rest : 0.0));
      map.v = k == 0 ? 0.0 : (k == 1 ? t : (k == 2 ? 1.0 : rest));
      map.du = k == 0 ? grad : (k == 2 ? -grad : vec2(0.0));
      map.dv = k == 1 ? grad : (k == 3 ? -grad : vec2(0.0));
    }
  }
  return map;
}

Field image_leaf(uint at, vec2 p) {
  uint mapping = at + uint(fetch_pool(at + 8u));
  uint field = at + uint(fetch_pool(at + 9u));
  float mode = fetch_pool(at + 10u);
  UvMap m;
  if (mode == 1.0) {
    // u along the curve, v across it: row 0 (v = 0) on the left of the direction of travel.
    float width = fetch_pool(at + 11u);
    float len = fetch_pool(at + 12u);
    TERRAIN_PRECISE float inv_width = 1.0 / width;
    TERRAIN_PRECISE float inv_length = len > 0.0 ? 1.0 / len : 0.0;
    PolylineHit q = polyline_eval(mapping, p, uintBitsToFloat(0x7f800000u));
    TERRAIN_PRECISE float u = q.s * inv_length;
    TERRAIN_PRECISE float v = 0.5 - q.signed_distance * inv_width;
    TERRAIN_PRECISE vec2 du = q.grad_s * inv_length;
    TERRAIN_PRECISE vec2 dv = q.grad_d * -inv_width;
    m = UvMap(u, v, du, dv);
  } else if (mode == 2.0) {
    // The support box itself (nodes/image.cpp box_map): v = 0 on its north edge.
    vec4 box = vec4(fetch_pool(at + 4u), fetch_pool(at + 5u), fetch_pool(at + 6u),
                    fetch_pool(at + 7u));
    TERRAIN_PRECISE float inv_width = 1.0 / (box.z - box.x);
    TERRAIN_PRECISE float inv_height = 1.0 / (box.w - box.y);
    TERRAIN_PRECISE float u = (p.x - box.x) * inv_width;
    TERRAIN_PRECISE float v = (box.w - p.y) * inv_height;
    m = UvMap(u, v, vec2(inv_width, 0.0), vec2(0.0, -inv_height));
  } else {
    m = quad_inverse(mapping, p);
  }
  UvSample h = heightfield_height(field, m.u, m.v);
  UvSample w = heightfield_weight(field, m.u, m.v);
  TERRAIN_PRECISE vec2 gh = m.du * h.du + m.dv * h.dv;
  TERRAIN_PRECISE vec2 gw = m.du * w.du + m.dv * w.dv;
  return Field(h.value, w.value, gh.x, gh.y, gw.x, gw.y);
}

// ---------------------------------------------------------------------------------------------
// blend (type 16): the accumulator holds Σαf, Σα, Σ∇(αf), Σ∇α (nodes/blend.cpp).

Field blend_accumulate(Field acc, Field c) {
  TERRAIN_PRECISE float f = acc.f + c.a * c.f;
  TERRAIN_PRECISE float a = acc.a + c.a;
  TERRAIN_PRECISE float fx = acc.fx + (c.ax * c.f + c.a * c.fx);
  TERRAIN_PRECISE float fy = acc.fy + (c.ay * c.f + c.a * c.fy);
  TERRAIN_PRECISE float ax = acc.ax + c.ax;
  TERRAIN_PRECISE float ay = acc.ay + c.ay;
  return Field(f, a, fx, fy, ax, ay);
}

Field blend_finish(uint at, Field acc) {
  float threshold = fetch_pool(at);
  float base = fetch_pool(at + 1u);
  float sum = acc.a;
  Field out_field = acc;
  if (sum >= threshold) {
    TERRAIN_PRECISE float f = acc.f / sum;
    TERRAIN_PRECISE float fx = (acc.fx - f * acc.ax) / sum;
    TERRAIN_PRECISE float fy = (acc.fy - f * acc.ay) / sum;
    out_field.f = f;
    out_field.fx = fx;
    out_field.fy = fy;
  } else {
    TERRAIN_PRECISE float f = (acc.f + (threshold - sum) * base) / threshold;
    TERRAIN_PRECISE float fx = (acc.fx - base * acc.ax) / threshold;
    TERRAIN_PRECISE float fy = (acc.fy - base * acc.ay) / threshold;
    out_field.f = f;
    out_field.fx = fx;
    out_field.fy = fy;
  }
  return out_field;
}

// ---------------------------------------------------------------------------------------------
// Binary operators: replace (17), add (18), lod (19).

Field replace_combine(uint at, Field a, Field b) {
  bool progressive = fetch_pool(at) != 0.0;
  bool inside = b.a < 1.0;
  float w = inside ? b.a : 1.0;
  float wx = inside ? b.ax : 0.0;
  float wy = inside ? b.ay : 0.0;
  TERRAIN_PRECISE float diff = b.f - a.f;
  TERRAIN_PRECISE float fx = a.fx + w * (b.fx - a.fx) + wx * diff;
  TERRAIN_PRECISE float fy = a.fy + w * (b.fy - a.fy) + wy * diff;
  TERRAIN_PRECISE float f = a.f + w * diff;
  Field out_field = Field(f, a.a, fx, fy, a.ax, a.ay);
  if (progressive) {
    TERRAIN_PRECISE float alpha = (1.0 - w) * a.a + w * w;
    TERRAIN_PRECISE float alpha_x = (1.0 - w) * a.ax - wx * a.a + 2.0 * w * wx;
    TERRAIN_PRECISE float alpha_y = (1.0 - w) * a.ay - wy * a.a + 2.0 * w * wy;
    out_field.a = alpha;
    out_field.ax = alpha_x;
    out_field.ay = alpha_y;
  }
  return out_field;
}

Field add_combine(uint at, Field a, Field b) {
  bool sum = fetch_pool(at) != 0.0;
  bool inside = b.a < 1.0;
  float w = inside ? b.a : 1.0;
  float wx = inside ? b.ax : 0.0;
  float wy = inside ? b.ay : 0.0;
  TERRAIN_PRECISE float f = a.f + w * b.f;
  TERRAIN_PRECISE float fx = a.fx + w * b.fx + wx * b.f;
  TERRAIN_PRECISE float fy = a.fy + w * b.fy + wy * b.f;
  Field out_field = Field(f, a.a, fx, fy, a.ax, a.ay);
  if (sum) {
    TERRAIN_PRECISE float alpha = a.a + w * w;
    TERRAIN_PRECISE float alpha_x = a.ax + 2.0 * w * wx;
    TERRAIN_PRECISE float alpha_y = a.ay + 2.0 * w * wy;
    out_field.a = alpha;
    out_field.ax = alpha_x;
    out_field.ay = alpha_y;
  }
  return out_field;
}

float lod_blend_factor(uint at, float spacing) {
  if (spacing <= 0.0) return 1.0;
  float coarse = fetch_pool(at);
  float fine = fetch_pool(at + 1u);
  float x = (coarse - log(spacing)) / (coarse - fine);
  float t = clamp(x, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

Field lod_combine(uint at, float spacing, Field a, Field b) {
  float t = lod_blend_factor(at, spacing);
  float s = 1.0 - t;
  TERRAIN_PRECISE float f = s * a.f + t * b.f;
  TERRAIN_PRECISE float fx = s * a.fx + t * b.fx;
  TERRAIN_PRECISE float fy = s * a.fy + t * b.fy;
  TERRAIN_PRECISE float al = s * a.a + t * b.a;
  TERRAIN_PRECISE float ax = s * a.ax + t * b.ax;
  TERRAIN_PRECISE float ay = s * a.ay + t * b.ay;
  return Field(f, al, fx, fy, ax, ay);
}

// ---------------------------------------------------------------------------------------------
// Warps: transform (32, affine: inverse a00 a01 a10 a11 b0 b1, forward ×6, elevation scale and
// offset, spacing factor) and warp (33, a fractal displacement; its Jacobian is kept while the
// child runs). A frame is (point, spacing); the Jacobian (∂q/∂p, row-major) is a vec4.

// A transform's child sample spacing.
float transform_spacing(uint at, float spacing) { return spacing * fetch_pool(at + 14u); }

vec2 transform_point(uint at, vec2 p) {
  TERRAIN_PRECISE float x = fetch_pool(at) * p.x + fetch_pool(at + 1u) * p.y + fetch_pool(at + 4u);
  TERRAIN_PRECISE float y =
      fetch_pool(at + 2u) * p.x + fetch_pool(at + 3u) * p.y + fetch_pool(at + 5u);
  return vec2(x, y);
}

Field transform_field(uint at, Field c) {
  float a0 = fetch_pool(at), a1 = fetch_pool(at + 1u), a2 = fetch_pool(at + 2u),
        a3 = fetch_pool(at + 3u);
  float zs = fetch_pool(at + 12u), zo = fetch_pool(at + 13u);
  TERRAIN_PRECISE float fx = zs * (a0 * c.fx + a2 * c.fy);
  TERRAIN_PRECISE float fy = zs * (a1 * c.fx + a3 * c.fy);
  TERRAIN_PRECISE float ax = a0 * c.ax + a2 * c.ay;
  TERRAIN_PRECISE float ay = a1 * c.ax + a3 * c.ay;
  TERRAIN_PRECISE float f = zs * c.f + zo;
  return Field(f, c.a, fx, fy, ax, ay);
}

// Displaced point q = p + (dx, dy); jacobian = ∂q/∂p (xx, xy, yx, yy).
vec2 warp_point(uint at, vec2 p, float spacing, out vec4 jacobian) {
  Fractal px = read_fractal(at + kWarpFractal);
  Fractal py = px;
  px.seed = noise_hash2(px.seed, 1u);
  py.seed = noise_hash2(py.seed, 2u);
  float octaves = visible_octaves(px, spacing);
  Sample2 dx = fractal2(px, p, octaves);
  Sample2 dy = fractal2(py, p, octaves);
  TERRAIN_PRECISE float qx = p.x + dx.value;
  TERRAIN_PRECISE float qy = p.y + dy.value;
  TERRAIN_PRECISE float jxx = dx.dx + 1.0;
  TERRAIN_PRECISE float jyy = dy.dy + 1.0;
  jacobian = vec4(jxx, dx.dy, dy.dx, jyy);
  return vec2(qx, qy);
}

Field warp_field(vec4 j, Field c) {
  TERRAIN_PRECISE float fx = j.x * c.fx + j.z * c.fy;
  TERRAIN_PRECISE float fy = j.y * c.fx + j.w * c.fy;
  TERRAIN_PRECISE float ax = j.x * c.ax + j.z * c.ay;
  TERRAIN_PRECISE float ay = j.y * c.ax + j.w * c.ay;
  return Field(c.f, c.a, fx, fy, ax, ay);
}
