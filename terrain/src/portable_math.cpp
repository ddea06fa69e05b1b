// Keep every operation and its order identical to gpu/glsl/portable_math.glsl: the GPU tiles are
// byte-identical to the CPU's only while both round the same sequence of float operations.
#include "terrain/portable_math.hpp"

#include <bit>
#include <cmath>
#include <cstdint>

namespace terrain {
namespace {

constexpr float bits(std::uint32_t b) {
  return std::bit_cast<float>(b);
}

constexpr float kTanPi8 = bits(0x3ed413cdu);  // tan(π/8)
constexpr float kPi4 = bits(0x3f490fdbu);     // π/4
constexpr float kPi2 = bits(0x3fc90fdbu);     // π/2
constexpr float kPi = bits(0x40490fdbu);      // π
constexpr float kAtanP3 = bits(0x3da4f0d1u);  //  8.05374449538e-2
constexpr float kAtanP2 = bits(0x3e0e1b85u);  // −1.38776856032e-1 (magnitude)
constexpr float kAtanP1 = bits(0x3e4c925fu);  //  1.99777106478e-1
constexpr float kAtanP0 = bits(0x3eaaaa2au);  // −3.33329491539e-1 (magnitude)

}  // namespace

float portable_atan2(float y, float x) {
  const float ax = std::abs(x);
  const float ay = std::abs(y);
  const float mx = ax > ay ? ax : ay;
  const float mn = ax > ay ? ay : ax;
  if (!(mx > 0.0f)) return 0.0f;
  float t = 0.0f;
  float base = 0.0f;
  if (mn > kTanPi8 * mx) {
    // (mn − mx)/(mn + mx) = tan(atan(mn/mx) − π/4), without rounding mn/mx first.
    t = (mn - mx) / (mn + mx);
    base = kPi4;
  } else {
    t = mn / mx;
  }
  const float z = t * t;
  float r = ((((kAtanP3 * z - kAtanP2) * z + kAtanP1) * z - kAtanP0) * z) * t + t;
  r = base + r;
  if (ay > ax) r = kPi2 - r;
  if (x < 0.0f) r = kPi - r;
  if (y < 0.0f) r = -r;
  return r;
}

}  // namespace terrain
