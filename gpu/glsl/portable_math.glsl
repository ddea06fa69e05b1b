// Transcendentals computed bit for bit like terrain/src/portable_math.cpp (same operations in the
// same order, constants as bit patterns, TERRAIN_PRECISE against fused multiply-adds): GLSL's
// built-in atan differs from libm's atan2f by an ulp here and there, which is enough to move a
// contour's height across a tile's quantisation step. GLSL ES 3.00 compatible.

// atan2(y, x) in [−π, π]; (0, 0) gives 0. See terrain::portable_atan2 for the error bound.
float portable_atan2(float y, float x) {
  const float kTanPi8 = uintBitsToFloat(0x3ed413cdu);
  const float kPi4 = uintBitsToFloat(0x3f490fdbu);
  const float kPi2 = uintBitsToFloat(0x3fc90fdbu);
  const float kPi = uintBitsToFloat(0x40490fdbu);
  const float kAtanP3 = uintBitsToFloat(0x3da4f0d1u);
  const float kAtanP2 = uintBitsToFloat(0x3e0e1b85u);
  const float kAtanP1 = uintBitsToFloat(0x3e4c925fu);
  const float kAtanP0 = uintBitsToFloat(0x3eaaaa2au);
  float ax = abs(x);
  float ay = abs(y);
  float mx = ax > ay ? ax : ay;
  float mn = ax > ay ? ay : ax;
  if (!(mx > 0.0)) return 0.0;
  TERRAIN_PRECISE float t = 0.0;
  float base = 0.0;
  TERRAIN_PRECISE float threshold = kTanPi8 * mx;
  if (mn > threshold) {
    t = (mn - mx) / (mn + mx);
    base = kPi4;
  } else {
    t = mn / mx;
  }
  TERRAIN_PRECISE float z = t * t;
  TERRAIN_PRECISE float r = ((((kAtanP3 * z - kAtanP2) * z + kAtanP1) * z - kAtanP0) * z) * t + t;
  r = base + r;
  if (ay > ax) r = kPi2 - r;
  if (x < 0.0) r = kPi - r;
  if (y < 0.0) r = -r;
  return r;
}
