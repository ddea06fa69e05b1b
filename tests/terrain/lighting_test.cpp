// The lighting of pictures (terrain/lighting.hpp and render()'s shadow rays and sky occlusion):
// what each term does to the colour, checked on its own and in whole pictures.
#include "terrain/lighting.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "field_checks.hpp"
#include "terrain/program.hpp"
#include "terrain/sphere_trace.hpp"

namespace terrain {
namespace {

// A flat plain with one steep dome in the middle: 600 m high (the blend's mean of the plain and
// the disc), falling to the plain within 300 m.
const char* kHill = R"({"root": {"type": "blend", "children": [
  {"type": "disc", "center": [0, 0], "radius": 2000, "elevation": 0},
  {"type": "disc", "center": [0, 0], "radius": 300, "elevation": 1200}]}})";
const char* kPlain = R"({"root": {"type": "disc", "center": [0, 0], "radius": 2000,
  "elevation": 50}})";

float brightness(Rgb c) {
  return c.r + c.g + c.b;
}

Vec3 unit(Vec3 v) {
  return normalise(v);
}

TEST(SkyRadiance, IsBluerOverheadAndWhiterAtTheHorizon) {
  const Vec3 sun = sun_direction();
  const Rgb zenith = sky_radiance({0.0f, 0.0f, 1.0f}, sun);
  const Rgb horizon = sky_radiance(unit({0.3f, 1.0f, 0.0f}), sun);
  EXPECT_GT(zenith.b / zenith.r, horizon.b / horizon.r);
  EXPECT_GT(zenith.b, zenith.g);
  EXPECT_GT(zenith.g, zenith.r);
  EXPECT_GT(brightness(horizon), brightness(zenith));
}

TEST(SkyRadiance, GlowsAroundTheSun) {
  const Vec3 sun = sun_direction();
  const Vec3 away{-sun.x, -sun.y, sun.z};
  EXPECT_GT(brightness(sky_radiance(sun, sun)), 1.5f * brightness(sky_radiance(away, sun)));
}

TEST(AerialPerspective, KeepsNearColoursAndFadesFarOnesIntoTheHorizonBlueFirst) {
  const Vec3 sun = sun_direction();
  const Vec3 look{0.0f, 1.0f, 0.0f};  // level: the sky scattered in is this direction's
  const Rgb ground{0.2f, 0.3f, 0.1f};
  const Rgb near = aerial_perspective(ground, look, 0.0f, 1000.0f, sun);
  EXPECT_FLOAT_EQ(near.r, ground.r);
  EXPECT_FLOAT_EQ(near.b, ground.b);
  const Rgb horizon = sky_radiance(look, sun);
  const Rgb far = aerial_perspective(ground, look, 1e6f, 1000.0f, sun);
  EXPECT_NEAR(far.r, horizon.r, 1e-3f);
  EXPECT_NEAR(far.b, horizon.b, 1e-3f);
  // Halfway, blue has moved further towards the sky than red.
  const Rgb mid = aerial_perspective(ground, look, 1000.0f, 1000.0f, sun);
  EXPECT_GT((mid.b - ground.b) / (horizon.b - ground.b),
            (mid.r - ground.r) / (horizon.r - ground.r));
}

TEST(SunVisibility, IsASmoothPenumbraFromNoneToAll) {
  const Vec3 sun = sun_direction();
  EXPECT_EQ(sun_visibility(0.0f, sun), 0.0f);
  EXPECT_EQ(sun_visibility(1.0f, sun), 1.0f);
  EXPECT_EQ(sun_visibility(std::numeric_limits<float>::infinity(), sun), 1.0f);
  float last = 0.0f;
  for (float c = 0.0f; c < 0.1f; c += 0.002f) {
    const float v = sun_visibility(c, sun);
    EXPECT_GE(v, last);
    last = v;
  }
}

TEST(LitSurface, ShadowAndOcclusionOnlyTakeLightAway) {
  const Rgb grass{0.36f, 0.49f, 0.22f};
  const Vec3 sun = sun_direction();
  const Vec3 up{0.0f, 0.0f, 1.0f};
  const float full = brightness(lit_surface(grass, up, sun, 1.0f, 1.0f));
  EXPECT_LT(brightness(lit_surface(grass, up, sun, 0.0f, 1.0f)), full);
  EXPECT_LT(brightness(lit_surface(grass, up, sun, 1.0f, 0.5f)), full);
  // In full shadow, the sky's light remains.
  EXPECT_GT(brightness(lit_surface(grass, up, sun, 0.0f, 1.0f)), 0.1f);
  // Facing away from the sun, shadows change nothing.
  const Vec3 away = unit({-sun.x, -sun.y, 0.2f});
  EXPECT_EQ(brightness(lit_surface(grass, away, sun, 0.0f, 1.0f)),
            brightness(lit_surface(grass, away, sun, 1.0f, 1.0f)));
}

TEST(WaterSurface, ShowsItsBodyLookingDownAndMirrorsTheSkyAtGrazingAngles) {
  const Vec3 sun = sun_direction();
  const Rgb body{0.05f, 0.12f, 0.18f};
  const Vec3 down = unit({0.0f, 0.01f, -1.0f});
  const Rgb below = water_surface(body, down, sun, 1.0f);
  EXPECT_NEAR(below.b, body.b, 0.03f);
  const Vec3 grazing = unit({0.0f, 1.0f, -0.02f});
  const Rgb mirrored = water_surface(body, grazing, sun, 1.0f);
  const Rgb sky = sky_radiance({grazing.x, grazing.y, -grazing.z}, sun);
  EXPECT_NEAR(mirrored.b, sky.b, 0.15f);
  // The sun's glint, where the mirrored ray meets the sun, goes in shadow.
  const Vec3 glint{sun.x, sun.y, -sun.z};
  EXPECT_GT(brightness(water_surface(body, glint, sun, 1.0f)),
            brightness(water_surface(body, glint, sun, 0.0f)) + 1.0f);
}

TEST(SkyVisibility, IsWholeOnAPlainAndLessAtTheFootOfACliff) {
  const Program plain = testing::compile_or_die(testing::parse_or_die(kPlain));
  Evaluator flat(plain);
  EXPECT_EQ(sky_visibility(flat, {100.0f, -200.0f, 50.0f}, 1.0f, 100.0f), 1.0f);
  const Program hill = testing::compile_or_die(testing::parse_or_die(kHill));
  Evaluator e(hill);
  const Vec2 foot{-320.0f, 0.0f};  // west of the dome, at the foot of its flank
  const float z = e.sample(foot, 1.0f).elevation;
  const float open =
      sky_visibility(e, {-1500.0f, 0.0f, e.sample({-1500.0f, 0.0f}, 1.0f).elevation}, 1.0f, 200.0f);
  EXPECT_EQ(open, 1.0f);
  EXPECT_LT(sky_visibility(e, {foot.x, foot.y, z}, 1.0f, 200.0f), 0.9f);
}

// Shadows of a hill under the sun from the west-south-west: pictures with shadows are nowhere
// brighter than without, and darker east of the hill, where its shadow falls.
TEST(RenderLighting, ShadowsFallBehindTheHillAndOnlyDarken) {
  const Scene scene = testing::parse_or_die(kHill);
  const Program program = testing::compile_or_die(scene);
  Camera camera;
  camera.width = 96;
  camera.height = 64;
  camera.position = {0.0f, -100.0f, 3000.0f};  // from high above, looking down
  camera.target = {0.0f, 0.0f, 0.0f};
  camera.vertical_fov_degrees = 40.0f;
  RenderOptions without;
  without.shadows = false;
  without.occlusion = false;
  without.threads = 1;
  RenderOptions with = without;
  with.shadows = true;
  const Picture lit = render(program, scene.area(), camera, without);
  const Picture shadowed = render(program, scene.area(), camera, with);
  int darker_east = 0, darker_west = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const std::size_t at = static_cast<std::size_t>(y * camera.width + x) * 3;
      for (int c = 0; c < 3; ++c) ASSERT_LE(shadowed.rgb[at + c], lit.rgb[at + c]);
      if (shadowed.rgb[at + 1] + 10 < lit.rgb[at + 1])
        ++(x > camera.width / 2 ? darker_east : darker_west);
    }
  }
  EXPECT_GT(darker_east, 20);
  EXPECT_GT(darker_east, 4 * darker_west);
  EXPECT_GT(shadowed.total_steps, lit.total_steps);  // shadow rays are counted
}

TEST(WaterRaster, LooksAPointUpInTheCellUnderIt) {
  WaterRaster raster;
  raster.area = {{0.0f, 0.0f}, {4.0f, 4.0f}};
  raster.size = 2;
  raster.surface = {1.0f, 2.0f, 3.0f, kNoWaterSurface};
  EXPECT_EQ(water_surface_at(raster, 0.5f, 0.5f), 1.0f);
  EXPECT_EQ(water_surface_at(raster, 3.9f, 0.1f), 2.0f);
  EXPECT_EQ(water_surface_at(raster, 1.0f, 2.0f), 3.0f);  // a cell's lower edge is in it
  EXPECT_EQ(water_surface_at(raster, 3.0f, 3.0f), kNoWaterSurface);
  EXPECT_EQ(water_surface_at(raster, 4.0f, 1.0f), kNoWaterSurface);  // outside
  EXPECT_EQ(water_surface_at(raster, -0.1f, 1.0f), kNoWaterSurface);
  EXPECT_EQ(water_surface_at(WaterRaster{}, 1.0f, 1.0f), kNoWaterSurface);
}

TEST(RenderWater, DrawsTheScenesWaterLayerWhereItStandsAboveTheGround) {
  // A plain at 0 m with a pond 10 m deep in its water layer: a disc whose weight (Wyvill's
  // fall-off over 1200 m) is at least 0.5 within 545 m of the origin.
  const Scene scene = testing::parse_or_die(R"({"root": {"type": "disc", "center": [0, 0],
    "radius": 2000, "elevation": 0}, "water": {"type": "disc", "center": [0, 0],
    "radius": 1200, "elevation": 10}})");
  const Program program = testing::compile_or_die(scene);
  const Program water_program = compile_water(scene).value();
  const WaterRaster water = water_raster(water_program, scene.area(), 128);
  Camera camera;
  camera.width = 80;
  camera.height = 60;
  camera.position = {0.0f, -1500.0f, 2500.0f};
  camera.target = {0.0f, 0.0f, 0.0f};
  camera.vertical_fov_degrees = 60.0f;
  RenderOptions options;
  options.threads = 1;
  const Picture dry = render(program, scene.area(), camera, options);
  options.water = &water;
  const Picture wet = render(program, scene.area(), camera, options);
  int pond = 0, shore = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const auto at = static_cast<std::size_t>(y * camera.width + x);
      if (dry.depth[at] < 0.0f) continue;
      const Ray ray = camera.ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
      const float px = ray.origin.x + dry.depth[at] * ray.direction.x;
      const float py = ray.origin.y + dry.depth[at] * ray.direction.y;
      const float r = std::hypot(px, py);
      const bool changed = wet.rgb[3 * at] != dry.rgb[3 * at] ||
                           wet.rgb[3 * at + 1] != dry.rgb[3 * at + 1] ||
                           wet.rgb[3 * at + 2] != dry.rgb[3 * at + 2];
      if (r < 450.0f) {
        ++pond;
        EXPECT_TRUE(changed) << "in the pond at " << px << ", " << py;
        EXPECT_GT(wet.rgb[3 * at + 2], wet.rgb[3 * at]) << "water is blue";
      } else if (r > 700.0f) {
        ++shore;
        EXPECT_FALSE(changed) << "beyond the pond and its beach at " << px << ", " << py;
      }
    }
  }
  EXPECT_GT(pond, 50);
  EXPECT_GT(shore, 50);
}

}  // namespace
}  // namespace terrain
