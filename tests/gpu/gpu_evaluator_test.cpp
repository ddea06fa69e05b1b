// The GPU backend against the CPU reference: every registered node type (through its example)
// and every example scene, on llvmpipe or whatever EGL device the machine has. These tests run
// (they never skip): a machine without a working headless EGL fails them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include "example_scenes.hpp"
#include "gpu/egl_context.hpp"
#include "gpu/evaluator.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/node.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"

namespace gpu {
namespace {

constexpr float kHeightTolerance = 0.01f;  // metres, on every sample
constexpr double kNormalTolerance = 0.5;   // degrees, on every sample

// One context per process: the first creation costs seconds on llvmpipe.
GpuEvaluator& shared_evaluator() {
  static std::unique_ptr<GpuEvaluator> evaluator = [] {
    auto created = GpuEvaluator::create();
    if (!created) {
      ADD_FAILURE() << "no GPU evaluator: " << created.error().message;
      return std::unique_ptr<GpuEvaluator>();
    }
    std::printf("GPU device: %s\n", created.value()->device_name().c_str());
    return std::move(created).value();
  }();
  if (!evaluator) throw std::runtime_error("no GPU evaluator");
  return *evaluator;
}

// Image nodes get a synthetic heightfield, as in tests/terrain/node_types_test.cpp.
terrain::Result<terrain::Raster> synthetic_image(std::string_view) {
  terrain::Raster r;
  r.width = 48;
  r.height = 40;
  for (int y = 0; y < r.height; ++y) {
    for (int x = 0; x < r.width; ++x) {
      const float u = static_cast<float>(x) / 47.0f, v = static_cast<float>(y) / 39.0f;
      r.samples.push_back(0.5f + 0.3f * std::sin(6.0f * u) * std::cos(5.0f * v) +
                          0.2f * std::max(0.0f, 1.0f - 8.0f * std::abs(u - v)));
    }
  }
  return r;
}

terrain::Scene example_scene(const terrain::NodeType& type) {
  const std::string text = R"({"format": "terrain-scene/1", "name": ")" + std::string(type.name) +
                           R"(", "seed": 3, "root": )" + std::string(type.example_json) + "}";
  terrain::ParseOptions options;
  options.images = synthetic_image;
  terrain::Result<terrain::Scene> scene = terrain::parse_scene_text(text, options);
  if (!scene) throw std::runtime_error("example did not parse: " + scene.error().message);
  return std::move(scene).value();
}

terrain::Program compile_or_throw(const terrain::Scene& scene) {
  terrain::Result<terrain::Program> program = terrain::compile(scene);
  if (!program) throw std::runtime_error("scene did not compile: " + program.error().message);
  return std::move(program).value();
}

double normal_angle_degrees(float ax, float ay, float bx, float by) {
  // Normals (−fx, −fy, 1) of the two surfaces.
  const double dot = static_cast<double>(ax) * bx + static_cast<double>(ay) * by + 1.0;
  const double na = std::sqrt(static_cast<double>(ax) * ax + static_cast<double>(ay) * ay + 1.0);
  const double nb = std::sqrt(static_cast<double>(bx) * bx + static_cast<double>(by) * by + 1.0);
  return std::acos(std::clamp(dot / (na * nb), -1.0, 1.0)) * 180.0 / 3.14159265358979323846;
}

struct Difference {
  float height = 0.0f;
  double normal = 0.0;
  float gradient = 0.0f;
  int samples = 0;
};

// Evaluates the grid on both backends and checks every sample.
Difference expect_grid_matches(const terrain::Program& program, const terrain::GridSpec& grid,
                               const std::string& label) {
  const terrain::GridResult cpu = terrain::evaluate_grid(program, grid, 2);
  terrain::Result<terrain::GridResult> gpu = shared_evaluator().evaluate_grid(program, grid);
  EXPECT_TRUE(gpu.ok()) << label << ": " << (gpu.ok() ? "" : gpu.error().message);
  Difference d;
  if (!gpu) return d;
  int bad = 0;
  for (std::size_t i = 0; i < cpu.elevation.size(); ++i) {
    const float dh = std::abs(cpu.elevation[i] - gpu->elevation[i]);
    const double dn = normal_angle_degrees(cpu.gradient_x[i], cpu.gradient_y[i], gpu->gradient_x[i],
                                           gpu->gradient_y[i]);
    const float dg = std::max(std::abs(cpu.gradient_x[i] - gpu->gradient_x[i]),
                              std::abs(cpu.gradient_y[i] - gpu->gradient_y[i]));
    // NaN differences must fail: compare so that NaN is "bad".
    if (!(dh <= kHeightTolerance) || !(dn <= kNormalTolerance)) {
      if (++bad <= 5) {
        ADD_FAILURE() << label << ": sample " << i << " (col " << i % std::size_t(grid.width)
                      << ", row " << i / std::size_t(grid.width) << ") cpu f=" << cpu.elevation[i]
                      << " ∇=(" << cpu.gradient_x[i] << ", " << cpu.gradient_y[i]
                      << ") gpu f=" << gpu->elevation[i] << " ∇=(" << gpu->gradient_x[i] << ", "
                      << gpu->gradient_y[i] << ")";
      }
    }
    d.height = std::max(d.height, std::isnan(dh) ? INFINITY : dh);
    d.normal = std::max(d.normal, std::isnan(dn) ? INFINITY : dn);
    d.gradient = std::max(d.gradient, std::isnan(dg) ? INFINITY : dg);
    ++d.samples;
  }
  EXPECT_EQ(bad, 0) << label << ": " << bad << " of " << d.samples << " samples differ";
  std::printf("%-34s %5d samples  max |Δf| %.3g m  max |Δ∇f| %.3g  max normal angle %.3g°\n",
              label.c_str(), d.samples, static_cast<double>(d.height),
              static_cast<double>(d.gradient), d.normal);
  return d;
}

// A 64×64 grid over the scene's sampling box (its area widened by 15 %) at that grid's spacing,
// and a finer 64×64 grid at 1/16 of the step around the area's centre, at full detail.
void expect_scene_matches(const terrain::Scene& scene, const terrain::Program& program,
                          const std::string& name) {
  const terrain::Box2 area = scene.area();
  const terrain::Vec2 size = area.size();
  const terrain::Box2 box = area.expanded(0.15f * std::max(size.x, size.y));
  terrain::GridSpec coarse;
  coarse.width = coarse.height = 64;
  coarse.step = std::max(box.size().x, box.size().y) / 63.0;
  coarse.origin_x = box.lo.x;
  coarse.origin_y = box.lo.y;
  expect_grid_matches(program, coarse, name + " coarse");
  terrain::GridSpec fine = coarse;
  fine.step = coarse.step / 16.0;
  const terrain::Vec2 c = area.center();
  fine.origin_x = c.x - 32.0 * fine.step;
  fine.origin_y = c.y - 32.0 * fine.step;
  fine.lod_spacing = 0.0f;
  expect_grid_matches(program, fine, name + " fine");
}

// ---------------------------------------------------------------------------------------------

TEST(EglContext, CreatesAHeadlessContextWithComputeShaders) {
  auto context = EglContext::create();
  ASSERT_TRUE(context.ok()) << context.error().message;
  EXPECT_FALSE(context.value()->renderer().empty());
  std::printf("context: %s\n", context.value()->description().c_str());
}

TEST(EglContext, OpensMesaSurfacelessWhenAskedTo) {
  auto context = EglContext::create({EglPlatform::surfaceless, -1});
  ASSERT_TRUE(context.ok()) << context.error().message;
  EXPECT_NE(context.value()->description().find("surfaceless"), std::string::npos);
}

TEST(EglContext, RefusesADeviceThatDoesNotExistWithAClearError) {
  auto context = EglContext::create({EglPlatform::device, 999});
  ASSERT_FALSE(context.ok());
  EXPECT_NE(context.error().message.find("999"), std::string::npos) << context.error().message;
  EXPECT_NE(context.error().message.find("does not exist"), std::string::npos)
      << context.error().message;
}

TEST(GpuEvaluator, KeepsWorkingWhenAnotherEvaluatorOnTheDeviceGoes) {
  const terrain::NodeType* disc = terrain::find_node_type("disc");
  ASSERT_NE(disc, nullptr);
  const terrain::Program program = compile_or_throw(example_scene(*disc));
  const std::vector<float> x{0.0f, 10.0f}, y{0.0f, 5.0f};
  std::vector<float> before(2), after(2);
  auto first = GpuEvaluator::create();
  ASSERT_TRUE(first.ok()) << first.error().message;
  ASSERT_TRUE(first.value()->evaluate(program, x, y, 0.0f, before.data(), nullptr, nullptr).ok());
  {
    auto second = GpuEvaluator::create();  // the same EGL display, initialised again
    ASSERT_TRUE(second.ok()) << second.error().message;
    std::vector<float> f(2);
    ASSERT_TRUE(second.value()->evaluate(program, x, y, 0.0f, f.data(), nullptr, nullptr).ok());
  }
  const terrain::Status s =
      first.value()->evaluate(program, x, y, 0.0f, after.data(), nullptr, nullptr);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(before, after);
}

TEST(EglContext, ReportsShaderCompileFailuresWithTheDriverLog) {
  auto context = EglContext::create();
  ASSERT_TRUE(context.ok()) << context.error().message;
  EglContext::Scope scope(*context.value());
  ASSERT_TRUE(scope.ok());
  auto shader = context.value()->compile_compute(
      "#version 310 es\nlayout(local_size_x = 1) in;\nvoid main() { no_such_variable = 1; }\n");
  ASSERT_FALSE(shader.ok());
  EXPECT_NE(shader.error().message.find("compilation failed"), std::string::npos);
  EXPECT_NE(shader.error().message.find("no_such_variable"), std::string::npos)
      << shader.error().message;
}

TEST(GpuShader, AssemblesFromTheSharedGlslFiles) {
  const std::string source = compute_shader_source(ProgramShader{8, 2, "", ""});
  EXPECT_EQ(source.rfind("#version 310 es", 0), 0u);
  EXPECT_NE(source.find("#define TERRAIN_MAX_FIELDS 8"), std::string::npos);
  for (const char* function : {"Sample2 fractal2(", "Field disc_leaf(", "Field curve_leaf(",
                               "Field evaluate_program(", "void main()"}) {
    EXPECT_NE(source.find(function), std::string::npos) << function;
  }
  // The browser gets the node functions without the compute prelude.
  EXPECT_EQ(std::string(shared_glsl()).find("buffer ProgramCode"), std::string::npos);
}

class EveryNodeTypeOnGpu : public ::testing::TestWithParam<const terrain::NodeType*> {};

TEST_P(EveryNodeTypeOnGpu, MatchesTheCpuReference) {
  const terrain::NodeType& type = *GetParam();
  const terrain::Scene scene = example_scene(type);
  const terrain::Program program = compile_or_throw(scene);
  ASSERT_TRUE(GpuEvaluator::supports(program).ok())
      << GpuEvaluator::supports(program).error().message;
  expect_scene_matches(scene, program, "type " + std::string(type.name));
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryNodeTypeOnGpu, ::testing::ValuesIn(terrain::node_types()),
                         [](const auto& entry) { return std::string(entry.param->name); });

// Every fractal kind on both bases, with a lacunarity and Hurst exponent that make the octave
// gains inexact (the examples and scenes use mostly fbm/ridged on gradient noise).
class EveryFractalOnGpu : public ::testing::TestWithParam<std::tuple<const char*, const char*>> {};

TEST_P(EveryFractalOnGpu, MatchesTheCpuReference) {
  const auto [kind, basis] = GetParam();
  const std::string text =
      std::string(R"({"format": "terrain-scene/1", "name": "fractal", "seed": 5, "root":
 {"type": "disc", "center": [100, -50], "radius": 1800, "elevation": 200,
  "noise": {"kind": ")") +
      kind + R"(", "basis": ")" + basis + R"(", "amplitude": 150, "wavelength": 900,
  "octaves": 9, "lacunarity": 2.3, "hurst": 0.8, "seed": 21}}})";
  terrain::Result<terrain::Scene> scene = terrain::parse_scene_text(text);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  expect_scene_matches(*scene, compile_or_throw(*scene),
                       std::string("fractal ") + kind + "/" + basis);
}

INSTANTIATE_TEST_SUITE_P(Kinds, EveryFractalOnGpu,
                         ::testing::Combine(::testing::Values("fbm", "ridged", "hybrid", "warped"),
                                            ::testing::Values("gradient", "simplex")),
                         [](const auto& entry) {
                           return std::string(std::get<0>(entry.param)) + "_" +
                                  std::get<1>(entry.param);
                         });

using examples::scene_files;

class EveryExampleSceneOnGpu : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryExampleSceneOnGpu, MatchesTheCpuReference) {
  terrain::Result<terrain::Scene> scene = terrain::load_scene_file(GetParam());
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const terrain::Program program = compile_or_throw(*scene);
  const std::string name = std::filesystem::path(GetParam()).stem().string();
  ASSERT_TRUE(GpuEvaluator::supports(program).ok())
      << GpuEvaluator::supports(program).error().message;
  expect_scene_matches(*scene, program, "scene " + name);
}

INSTANTIATE_TEST_SUITE_P(ConfigScenes, EveryExampleSceneOnGpu, ::testing::ValuesIn(scene_files()),
                         [](const auto& entry) { return examples::test_name(entry.param); });

TEST(GpuEvaluator, PointListsGiveTheSameValuesAsTheCpuAtThosePoints) {
  terrain::Result<terrain::Scene> scene =
      terrain::load_scene_file(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/hills-river.json");
  ASSERT_TRUE(scene.ok());
  const terrain::Program program = compile_or_throw(*scene);
  const terrain::Box2 area = scene->area();
  std::vector<float> x, y;
  for (int i = 0; i < 500; ++i) {
    // Scattered, not a grid: a low-discrepancy walk over the area.
    const float u = std::fmod(0.5f + 0.6180339887f * static_cast<float>(i), 1.0f);
    const float v = std::fmod(0.5f + 0.7548776662f * static_cast<float>(i), 1.0f);
    x.push_back(area.lo.x + u * area.size().x);
    y.push_back(area.lo.y + v * area.size().y);
  }
  std::vector<float> f(x.size()), fx(x.size()), fy(x.size());
  const float spacing = 4.0f;
  const terrain::Status s =
      shared_evaluator().evaluate(program, x, y, spacing, f.data(), fx.data(), fy.data());
  ASSERT_TRUE(s.ok()) << s.error().message;
  terrain::Evaluator cpu(program);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const terrain::FieldSample r = cpu.sample({x[i], y[i]}, spacing);
    EXPECT_NEAR(f[i], r.elevation, kHeightTolerance) << i;
    EXPECT_LE(normal_angle_degrees(fx[i], fy[i], r.elevation_gradient.x, r.elevation_gradient.y),
              kNormalTolerance)
        << i;
  }
}

TEST(GpuEvaluator, KeepsSeveralProgramsApartInItsUploadCache) {
  const terrain::Program disc = compile_or_throw(example_scene(*terrain::find_node_type("disc")));
  const terrain::Program warp = compile_or_throw(example_scene(*terrain::find_node_type("warp")));
  const std::vector<float> x{0.0f, 300.0f}, y{0.0f, -200.0f};
  for (int round = 0; round < 2; ++round) {
    for (const terrain::Program* p : {&disc, &warp}) {
      float f[2];
      ASSERT_TRUE(shared_evaluator().evaluate(*p, x, y, 0.0f, f, nullptr, nullptr).ok());
      terrain::Evaluator cpu(*p);
      for (int i = 0; i < 2; ++i) {
        EXPECT_NEAR(
            f[i],
            cpu.sample({x[static_cast<std::size_t>(i)], y[static_cast<std::size_t>(i)]}).elevation,
            kHeightTolerance);
      }
    }
  }
}

TEST(GpuEvaluator, RejectsMismatchedInputsWithoutRunning) {
  const terrain::Program disc = compile_or_throw(example_scene(*terrain::find_node_type("disc")));
  const std::vector<float> x{0.0f, 1.0f}, y{0.0f};
  float f[2];
  EXPECT_FALSE(shared_evaluator().evaluate(disc, x, y, 0.0f, f, nullptr, nullptr).ok());
  EXPECT_FALSE(shared_evaluator().evaluate_grid(disc, terrain::GridSpec{}).ok());
}

}  // namespace
}  // namespace gpu
