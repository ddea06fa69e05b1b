// Sphere-traced pictures on the GPU (gpu/glsl/trace.glsl) against terrain::render on the CPU, for
// every example scene; batched grid evaluation against one grid at a time; the program upload
// cache; and the browser's half of the contract: the shared GLSL plus trace.glsl compile as a
// GLSL ES 3.00 fragment shader behind a texture prelude. These run (never skip) on llvmpipe.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "example_scenes.hpp"
#include "gpu/egl_context.hpp"
#include "gpu/evaluator.hpp"
#include "gpu/program_glsl.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"
#include "terrain/sphere_trace.hpp"

namespace gpu {
namespace {

// Agreement asked of every example picture, on pixels where it applies. Both tracers run the
// same float operations on the same heights, so nearly every pixel is bit-identical; the residual
// (a hit distance an ulp or two apart on < 0.1 % of pixels) comes from visible_octaves, whose
// logarithms the GPU takes in float and the CPU in double, at the continuously varying level of
// detail along a ray. Measured on llvmpipe: hit/miss and colour 100 %, depth exact ≥ 99.9 %.
constexpr double kAgreeingShare = 0.99;   // of pixels: same hit/miss, depth, colour
constexpr float kDepthTolerance = 1e-5f;  // relative to the CPU's hit distance
constexpr int kColourTolerance = 1;       // 8-bit codes per channel

GpuEvaluator& tracer() {
  static std::unique_ptr<GpuEvaluator> evaluator = [] {
    auto created = GpuEvaluator::create();
    if (!created) {
      ADD_FAILURE() << "no GPU evaluator: " << created.error().message;
      return std::unique_ptr<GpuEvaluator>();
    }
    return std::move(created).value();
  }();
  if (!evaluator) throw std::runtime_error("no GPU evaluator");
  return *evaluator;
}

using examples::scene_files;

struct Loaded {
  terrain::Scene scene;
  terrain::Program program;
};

Loaded load(const std::string& file) {
  terrain::Result<terrain::Scene> scene = terrain::load_scene_file(file);
  if (!scene) throw std::runtime_error(file + ": " + scene.error().message);
  terrain::Result<terrain::Program> program = terrain::compile(*scene);
  if (!program) throw std::runtime_error(file + ": " + program.error().message);
  return {std::move(scene).value(), std::move(program).value()};
}

class EveryExamplePictureOnGpu : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryExamplePictureOnGpu, MatchesTheCpuPicture) {
  const Loaded loaded = load(GetParam());
  const terrain::Box2 area = loaded.scene.area();
  const terrain::Camera camera = terrain::default_camera(loaded.program, area, 96, 64);
  terrain::RenderOptions options;
  options.threads = 2;
  options.water_level = loaded.program.base_elevation + 1.0f;  // water shading is compared too
  options.material = loaded.scene.material;
  std::optional<terrain::WaterRaster> water;  // the scene's water layer, where it has one
  if (loaded.scene.water) {
    water = terrain::water_raster(terrain::compile_water(loaded.scene).value(), area);
    options.water = &*water;
  }
  const terrain::Picture cpu = terrain::render(loaded.program, area, camera, options);
  terrain::Result<terrain::Picture> gpu = tracer().render(loaded.program, area, camera, options);
  ASSERT_TRUE(gpu.ok()) << gpu.error().message;
  ASSERT_EQ(gpu->width, cpu.width);
  ASSERT_EQ(gpu->height, cpu.height);
  const std::size_t pixels = cpu.depth.size();
  std::size_t same_hit = 0, hits = 0, same_depth = 0, exact_depth = 0, same_colour = 0,
              exact_colour = 0;
  float worst_depth = 0.0f;
  int worst_colour = 0;
  for (std::size_t i = 0; i < pixels; ++i) {
    const bool a = cpu.depth[i] >= 0.0f, b = gpu->depth[i] >= 0.0f;
    if (a == b) ++same_hit;
    if (a) ++hits;
    if (a && b) {
      const float d = std::abs(cpu.depth[i] - gpu->depth[i]) / cpu.depth[i];
      worst_depth = std::max(worst_depth, d);
      if (d <= kDepthTolerance) ++same_depth;
      if (cpu.depth[i] == gpu->depth[i]) ++exact_depth;
    } else if (!a && !b) {
      ++same_depth;
      ++exact_depth;
    }
    int channel = 0;
    for (std::size_t c = 0; c < 3; ++c) {
      channel = std::max(channel, std::abs(int{cpu.rgb[3 * i + c]} - int{gpu->rgb[3 * i + c]}));
    }
    worst_colour = std::max(worst_colour, channel);
    if (channel <= kColourTolerance) ++same_colour;
    if (channel == 0) ++exact_colour;
  }
  const auto share = [&](std::size_t n) {
    return static_cast<double>(n) / static_cast<double>(pixels);
  };
  std::printf(
      "%-16s %zu px, %zu hits: hit/miss agree %.2f %%, depth equal %.2f %% (within %.0e: %.2f "
      "%%, worst %.2g), colour equal %.2f %% (within %d: %.2f %%, worst %d); steps cpu %lld gpu "
      "%lld\n",
      std::filesystem::path(GetParam()).stem().string().c_str(), pixels, hits,
      100.0 * share(same_hit), 100.0 * share(exact_depth), static_cast<double>(kDepthTolerance),
      100.0 * share(same_depth), static_cast<double>(worst_depth), 100.0 * share(exact_colour),
      kColourTolerance, 100.0 * share(same_colour), worst_colour,
      static_cast<long long>(cpu.total_steps), static_cast<long long>(gpu->total_steps));
  EXPECT_GT(hits, pixels / 4) << "the default camera should see terrain";
  EXPECT_GE(share(same_hit), kAgreeingShare);
  EXPECT_GE(share(same_depth), kAgreeingShare);
  EXPECT_GE(share(same_colour), kAgreeingShare);
}

INSTANTIATE_TEST_SUITE_P(ConfigScenes, EveryExamplePictureOnGpu, ::testing::ValuesIn(scene_files()),
                         [](const auto& entry) { return examples::test_name(entry.param); });

TEST(GpuPicture, UsesTheCallersLipschitzGridAndPlainTracing) {
  const Loaded loaded = load(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/hills-river.json");
  const terrain::Box2 area = loaded.scene.area();
  const terrain::Camera camera = terrain::default_camera(loaded.program, area, 32, 20);
  for (const bool accelerated : {true, false}) {
    terrain::Evaluator evaluator(loaded.program);
    const terrain::LipschitzGrid grid(evaluator, area, 16);
    terrain::RenderOptions options;
    options.threads = 1;
    options.trace.accelerated = accelerated;
    options.trace.bounds = &grid;
    const terrain::Picture cpu = terrain::render(loaded.program, area, camera, options);
    terrain::Result<terrain::Picture> gpu = tracer().render(loaded.program, area, camera, options);
    ASSERT_TRUE(gpu.ok()) << gpu.error().message;
    std::size_t agree = 0;
    for (std::size_t i = 0; i < cpu.depth.size(); ++i) {
      if ((cpu.depth[i] < 0.0f) == (gpu->depth[i] < 0.0f) &&
          std::abs(cpu.depth[i] - gpu->depth[i]) <= kDepthTolerance * std::abs(cpu.depth[i])) {
        ++agree;
      }
    }
    EXPECT_GE(static_cast<double>(agree), kAgreeingShare * static_cast<double>(cpu.depth.size()))
        << (accelerated ? "accelerated" : "plain");
    // The two algorithms take different numbers of steps: matching the CPU's count for each shows
    // that the option and the caller's grid reached the shader.
    EXPECT_NEAR(static_cast<double>(gpu->total_steps), static_cast<double>(cpu.total_steps),
                0.01 * static_cast<double>(cpu.total_steps));
  }
}

// Shadows and sky occlusion each switched off reach the shader: the GPU's colours and step counts
// follow the CPU's, which change with them.
TEST(GpuPicture, HonoursTheLightingOptions) {
  const Loaded loaded = load(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/butte.json");
  const terrain::Box2 area = loaded.scene.area();
  const terrain::Camera camera = terrain::default_camera(loaded.program, area, 48, 30);
  std::vector<std::int64_t> steps;
  for (const auto& [shadows, occlusion] : {std::pair{true, true}, std::pair{false, true},
                                           std::pair{true, false}, std::pair{false, false}}) {
    terrain::RenderOptions options;
    options.threads = 1;
    options.shadows = shadows;
    options.occlusion = occlusion;
    const terrain::Picture cpu = terrain::render(loaded.program, area, camera, options);
    terrain::Result<terrain::Picture> gpu = tracer().render(loaded.program, area, camera, options);
    ASSERT_TRUE(gpu.ok()) << gpu.error().message;
    std::size_t same = 0;
    for (std::size_t i = 0; i < cpu.rgb.size(); ++i) {
      if (std::abs(int{cpu.rgb[i]} - int{gpu->rgb[i]}) <= kColourTolerance) ++same;
    }
    EXPECT_GE(static_cast<double>(same), kAgreeingShare * static_cast<double>(cpu.rgb.size()))
        << "shadows " << shadows << ", occlusion " << occlusion;
    EXPECT_EQ(gpu->total_steps, cpu.total_steps)
        << "shadows " << shadows << ", occlusion " << occlusion;
    steps.push_back(cpu.total_steps);
  }
  // Each option changes the work: shadow rays and sky samples are steps of their own.
  EXPECT_GT(steps[0], steps[1]);
  EXPECT_GT(steps[0], steps[2]);
  EXPECT_GT(steps[1], steps[3]);
  EXPECT_GT(steps[2], steps[3]);
}

TEST(GpuPicture, TakesTheMaterialOfItsOptions) {
  const Loaded loaded =
      load(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/alpine-valleys.json");
  const terrain::Box2 area = loaded.scene.area();
  const terrain::Camera camera = terrain::default_camera(loaded.program, area, 48, 30);
  terrain::RenderOptions options;
  options.threads = 1;
  const terrain::Picture plain = terrain::render(loaded.program, area, camera, options);
  // Every parameter off its default: colours, bands, slopes and the snow line.
  const terrain::Result<terrain::Material> odd = terrain::parse_material(
      nlohmann::json::parse(R"({"grass": "#a04020", "forest": "#203090", "meadow": "#c0c000",
        "rock": "#ff00ff", "snow": "#00ffff", "tree_line": [0.3, 0.4], "rock_slope": [25, 40],
        "snow_line": 0.5, "snow_aspect": 0.3, "snow_slope": [35, 50]})"),
      "/material");
  ASSERT_TRUE(odd.ok()) << odd.error().message;
  options.material = *odd;
  const terrain::Picture cpu = terrain::render(loaded.program, area, camera, options);
  terrain::Result<terrain::Picture> gpu = tracer().render(loaded.program, area, camera, options);
  ASSERT_TRUE(gpu.ok()) << gpu.error().message;
  std::size_t same = 0, changed = 0;
  for (std::size_t i = 0; i < cpu.rgb.size(); ++i) {
    if (std::abs(int{cpu.rgb[i]} - int{gpu->rgb[i]}) <= kColourTolerance) ++same;
    if (cpu.rgb[i] != plain.rgb[i]) ++changed;
  }
  EXPECT_GE(static_cast<double>(same), kAgreeingShare * static_cast<double>(cpu.rgb.size()));
  EXPECT_GT(changed, cpu.rgb.size() / 4) << "the material changed the picture";
}

TEST(GpuPicture, DrawsTheScenesWaterLayerAsTheCpuDoes) {
  // A plain with a pond in its water layer (tests/terrain/lighting_test.cpp's RenderWater).
  const terrain::Scene scene = terrain::parse_scene_text(R"({"root": {"type": "disc",
    "center": [0, 0], "radius": 2000, "elevation": 0}, "water": {"type": "disc",
    "center": [0, 0], "radius": 1200, "elevation": 10}})")
                                   .value();
  const terrain::Program program = terrain::compile(scene).value();
  const terrain::WaterRaster water =
      terrain::water_raster(terrain::compile_water(scene).value(), scene.area(), 128);
  terrain::Camera camera;
  camera.width = 64;
  camera.height = 48;
  camera.position = {0.0f, -1500.0f, 2500.0f};
  camera.target = {0.0f, 0.0f, 0.0f};
  camera.vertical_fov_degrees = 60.0f;
  terrain::RenderOptions options;
  options.threads = 1;
  const terrain::Picture dry = terrain::render(program, scene.area(), camera, options);
  options.water = &water;
  const terrain::Picture cpu = terrain::render(program, scene.area(), camera, options);
  terrain::Result<terrain::Picture> gpu = tracer().render(program, scene.area(), camera, options);
  ASSERT_TRUE(gpu.ok()) << gpu.error().message;
  std::size_t same = 0, wet = 0;
  for (std::size_t i = 0; i < cpu.rgb.size(); ++i) {
    if (std::abs(int{cpu.rgb[i]} - int{gpu->rgb[i]}) <= kColourTolerance) ++same;
    if (cpu.rgb[i] != dry.rgb[i]) ++wet;
  }
  EXPECT_GE(static_cast<double>(same), kAgreeingShare * static_cast<double>(cpu.rgb.size()));
  EXPECT_GT(wet, cpu.rgb.size() / 20) << "the pond shows";
}

TEST(GpuPicture, IsRefusedForAnEmptyPicture) {
  const Loaded loaded = load(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/craters.json");
  terrain::Camera camera = terrain::default_camera(loaded.program, loaded.scene.area(), 16, 16);
  camera.width = 0;
  EXPECT_FALSE(tracer().render(loaded.program, loaded.scene.area(), camera).ok());
}

// ---------------------------------------------------------------------------------------------

TEST(GpuBatch, SeveralGridsInOneDispatchEqualOneGridAtATimeBitForBit) {
  const Loaded loaded = load(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/winding-road.json");
  const terrain::Box2 area = loaded.scene.area();
  // 3 × 3 tiles of 33² samples with different steps and levels of detail.
  std::vector<terrain::GridSpec> grids;
  for (int k = 0; k < 9; ++k) {
    terrain::GridSpec g;
    g.width = g.height = 33;
    g.step = static_cast<double>(area.size().x) / (96.0 * (1 + k % 3));
    g.origin_x = area.lo.x + (k % 3) * 32.0 * g.step;
    g.origin_y = area.lo.y + (k / 3) * 32.0 * g.step;
    g.lod_spacing = k == 4 ? 0.0f : -1.0f;
    grids.push_back(g);
  }
  terrain::Result<std::vector<terrain::GridResult>> batched =
      tracer().evaluate_grids(loaded.program, grids);
  ASSERT_TRUE(batched.ok()) << batched.error().message;
  ASSERT_EQ(batched->size(), grids.size());
  for (std::size_t k = 0; k < grids.size(); ++k) {
    terrain::Result<terrain::GridResult> alone = tracer().evaluate_grid(loaded.program, grids[k]);
    ASSERT_TRUE(alone.ok()) << alone.error().message;
    const terrain::GridResult& b = (*batched)[k];
    ASSERT_EQ(b.elevation.size(), alone->elevation.size());
    // Bit for bit: memcmp-equal floats (NaN-safe, unlike ==).
    EXPECT_EQ(0, std::memcmp(b.elevation.data(), alone->elevation.data(),
                             b.elevation.size() * sizeof(float)))
        << "grid " << k;
    EXPECT_EQ(0, std::memcmp(b.gradient_x.data(), alone->gradient_x.data(),
                             b.gradient_x.size() * sizeof(float)))
        << "grid " << k;
    EXPECT_EQ(0, std::memcmp(b.gradient_y.data(), alone->gradient_y.data(),
                             b.gradient_y.size() * sizeof(float)))
        << "grid " << k;
  }
  // Different grids really were different work (a batch returning grid 0 nine times fails).
  EXPECT_NE((*batched)[0].elevation, (*batched)[8].elevation);
}

TEST(GpuBatch, RefusesGridsOfDifferentSizes) {
  const Loaded loaded = load(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/craters.json");
  terrain::GridSpec a, b;
  a.width = a.height = 8;
  b.width = b.height = 9;
  a.step = b.step = 10.0;
  const std::vector<terrain::GridSpec> grids{a, b};
  terrain::Result<std::vector<terrain::GridResult>> r =
      tracer().evaluate_grids(loaded.program, grids);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("one size"), std::string::npos) << r.error().message;
}

TEST(GpuUploadCache, UploadsAProgramOncePerVersion) {
  const Loaded loaded = load(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/lake-dunes.json");
  terrain::GridSpec grid;
  grid.width = grid.height = 8;
  grid.step = 50.0;
  ASSERT_TRUE(tracer().evaluate_grid(loaded.program, grid).ok());
  const std::size_t before = tracer().program_uploads();
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(tracer().evaluate_grid(loaded.program, grid).ok());
  EXPECT_EQ(tracer().program_uploads(), before);
  // A changed program (another version) is uploaded anew.
  terrain::Program changed = loaded.program;
  changed.pool.back() += 1.0f;
  ASSERT_TRUE(tracer().evaluate_grid(changed, grid).ok());
  EXPECT_EQ(tracer().program_uploads(), before + 1);
}

// ---------------------------------------------------------------------------------------------

// What the browser will do: its own prelude (program in textures, no SSBOs, no `precise`), then
// the very same shared GLSL and trace.glsl, then a fragment main.
TEST(GpuShader, SharedGlslAndTracerCompileAsGlslEs300FragmentShader) {
  const std::string prelude = R"glsl(#version 300 es
precision highp float;
precision highp int;
precision highp usampler2D;
precision highp sampler2D;
#define TERRAIN_PRECISE
#define TERRAIN_MAX_FIELDS 8
#define TERRAIN_MAX_FRAMES 4
uniform highp usampler2D u_code;
uniform highp usampler2D u_pool;
uniform highp sampler2D u_bounds;
uniform uint u_program_size;
ivec2 texel(uint i, int width) { return ivec2(int(i) % width, int(i) / width); }
uvec4 fetch_code(uint pc) { return texelFetch(u_code, texel(pc, 1024), 0); }
uint fetch_pool_uint(uint i) { return texelFetch(u_pool, texel(i, 4096), 0).r; }
float fetch_pool(uint i) { return uintBitsToFloat(fetch_pool_uint(i)); }
uint program_size() { return u_program_size; }
float fetch_bounds(uint i) { return texelFetch(u_bounds, texel(i, 4096), 0).r; }
uniform highp sampler2D u_water;
float fetch_water(uint i) { return texelFetch(u_water, texel(i, 4096), 0).r; }
)glsl";
  const std::string main = R"glsl(
uniform vec3 u_eye;
out vec4 colour;
void main() {
  TraceCamera camera = TraceCamera(u_eye, vec3(0.0, 1.0, 0.0), vec3(1.0, 0.0, 0.0),
                                   vec3(0.0, 0.0, 1.0), 0.5, 1.5, vec2(640.0, 400.0));
  TraceSetup setup = TraceSetup(vec2(-1000.0), vec2(1000.0), 0.0, 500.0, 0.01, 4096, 10.0,
                                0.001, 1e5, true, -1e9, 2000.0, vec3(0.0, 0.0, 1.0), true,
                                true, vec4(-1000.0, -1000.0, 1000.0, 1000.0), 256);
  TracePixel p = trace_pixel(camera, setup, gl_FragCoord.xy);
  colour = vec4(p.colour, 1.0);
}
)glsl";
  auto context = EglContext::create();
  ASSERT_TRUE(context.ok()) << context.error().message;
  EglContext::Scope scope(*context.value());
  ASSERT_TRUE(scope.ok());
  const std::string source =
      prelude + std::string(shared_glsl()) + "\n" + std::string(trace_glsl()) + main;
  const terrain::Status compiled = context.value()->check_fragment_shader(source);
  EXPECT_TRUE(compiled.ok()) << compiled.error().message;
  // And the check can fail: the same source without the prelude's fetch_bounds does not compile.
  std::string broken = source;
  broken.replace(broken.find("float fetch_bounds"), 5, "int  ");
  EXPECT_FALSE(context.value()->check_fragment_shader(broken).ok());

  // The browser's other shader modes (js/scene_view.js): the pruned interpreter (the bundle's
  // glsl_defines before the shared GLSL) and the unrolled program (TERRAIN_SPECIALISED, and the
  // bundle's program_glsl after main).
  terrain::Result<terrain::Scene> scene =
      terrain::load_scene_file(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/lake-dunes.json");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  terrain::Result<terrain::Program> program = terrain::compile(*scene);
  ASSERT_TRUE(program.ok()) << program.error().message;
  const std::string shared = std::string(shared_glsl()) + "\n" + std::string(trace_glsl());
  const std::string defines = node_type_defines(*program);
  const terrain::Status pruned =
      context.value()->check_fragment_shader(prelude + defines + shared + main);
  EXPECT_TRUE(pruned.ok()) << pruned.error().message;
  terrain::Result<std::string> unrolled = specialised_program_glsl(*program);
  ASSERT_TRUE(unrolled.ok()) << unrolled.error().message;
  const terrain::Status specialised = context.value()->check_fragment_shader(
      prelude + "#define TERRAIN_SPECIALISED\n" + defines + shared + main + *unrolled);
  EXPECT_TRUE(specialised.ok()) << specialised.error().message;
  // Without TERRAIN_SPECIALISED the interpreter's definition clashes with the unrolled one.
  EXPECT_FALSE(context.value()->check_fragment_shader(prelude + shared + main + *unrolled).ok());
}

}  // namespace
}  // namespace gpu
