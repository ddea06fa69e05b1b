#include "terrain/sphere_trace.hpp"

#include <gtest/gtest.h>

#include "field_checks.hpp"

namespace terrain {
namespace {

const char* kHills = R"({"root": {"type": "blend", "children": [
  {"type": "disc", "center": [0, 0], "radius": 1500, "elevation": 200,
   "noise": {"kind": "ridged", "amplitude": 180, "wavelength": 700, "octaves": 6, "seed": 1}},
  {"type": "disc", "center": [900, 300], "radius": 900, "elevation": 120,
   "noise": {"kind": "fbm", "amplitude": 60, "wavelength": 300, "octaves": 5, "seed": 2}}]}})";

std::vector<Ray> rays_over(const Box2& area, int count) {
  std::mt19937 rng(4);
  std::vector<Ray> rays;
  for (int k = 0; k < count; ++k) {
    const Vec2 target = testing::random_point(rng, area);
    const Vec3 origin{area.lo.x - 500.0f, area.lo.y - 800.0f, 900.0f};
    Vec3 d{target.x - origin.x, target.y - origin.y, 150.0f - origin.z};
    const float l = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    rays.push_back({origin, {d.x / l, d.y / l, d.z / l}});
  }
  return rays;
}

TEST(SphereTracing, AcceleratedNeverMissesAHitThatDenseMarchingFinds) {
  const Scene scene = testing::parse_or_die(kHills);
  const Program program = testing::compile_or_die(scene);
  Evaluator e(program);
  const TraceDomain domain = trace_domain(program, scene.area());
  int hits = 0;
  for (const Ray& ray : rays_over(scene.area(), 150)) {
    const TraceResult dense = march_dense(e, domain, ray, 0.5f, 1e5f);
    TraceOptions options;
    options.epsilon = 0.01f;
    const TraceResult fast = sphere_trace(e, domain, ray, options);
    if (dense.hit) {
      ++hits;
      ASSERT_TRUE(fast.hit);
      // The tracer stops within ε above the surface, so at or just before the dense crossing.
      EXPECT_LE(fast.t, dense.t + 0.05f);
      EXPECT_GE(fast.t, dense.t - 5.0f);
    }
  }
  EXPECT_GT(hits, 50);
}

TEST(SphereTracing, PlainAndAcceleratedAgreeAndAcceleratedTakesFewerSteps) {
  const Scene scene = testing::parse_or_die(kHills);
  const Program program = testing::compile_or_die(scene);
  Evaluator e(program);
  const TraceDomain domain = trace_domain(program, scene.area());
  long plain_steps = 0, fast_steps = 0;
  for (const Ray& ray : rays_over(scene.area(), 80)) {
    TraceOptions plain;
    plain.accelerated = false;
    plain.max_steps = 100000;
    const TraceResult a = sphere_trace(e, domain, ray, plain);
    const TraceResult b = sphere_trace(e, domain, ray, {});
    ASSERT_EQ(a.hit, b.hit);
    if (a.hit) {
      EXPECT_NEAR(a.t, b.t, 2.0f);
    }
    plain_steps += a.steps;
    fast_steps += b.steps;
  }
  EXPECT_LT(fast_steps, plain_steps);
}

TEST(SphereTracing, RayPointingUpwardsMisses) {
  const Scene scene = testing::parse_or_die(kHills);
  const Program program = testing::compile_or_die(scene);
  Evaluator e(program);
  const TraceResult r =
      sphere_trace(e, trace_domain(program, scene.area()), {{0, 0, 2000}, {0, 0.6f, 0.8f}});
  EXPECT_FALSE(r.hit);
}

}  // namespace
}  // namespace terrain
