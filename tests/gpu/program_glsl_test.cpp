// Program-specialised shaders (gpu/program_glsl.hpp): the unrolled evaluate_program and the
// interpreter pruned to a program's node types compute exactly what the full interpreter
// computes, for every example scene and every node type's example, on the machine's EGL device
// (llvmpipe in CI); malformed streams are refused. (The browser's ES 3.00 builds of both are
// compiled in gpu_trace_test.cpp.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "example_scenes.hpp"
#include "gpu/egl_context.hpp"
#include "gpu/evaluator.hpp"
#include "gpu/program_glsl.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/node.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"

namespace gpu {
namespace {

using terrain::Instruction;
using terrain::Op;

GpuEvaluator& evaluator(ShaderMode mode) {
  static std::map<ShaderMode, std::unique_ptr<GpuEvaluator>> evaluators;
  std::unique_ptr<GpuEvaluator>& e = evaluators[mode];
  if (!e) {
    GpuOptions options;
    options.shaders = mode;
    auto created = GpuEvaluator::create(options);
    if (!created) throw std::runtime_error("no GPU evaluator: " + created.error().message);
    e = std::move(created).value();
  }
  return *e;
}

// Image primitives read a small ramp of a heightfield, whatever file they name.
terrain::Result<terrain::Raster> ramp_image(std::string_view) {
  terrain::Raster r;
  r.width = 6;
  r.height = 5;
  for (int i = 0; i < r.width * r.height; ++i)
    r.samples.push_back(0.1f * static_cast<float>(i % 7));
  return r;
}

terrain::Program compile_text(const std::string& root) {
  const std::string text =
      R"({"format": "terrain-scene/1", "name": "t", "seed": 3, "root": )" + root + "}";
  terrain::ParseOptions options;
  options.images = ramp_image;
  terrain::Result<terrain::Scene> scene = terrain::parse_scene_text(text, options);
  if (!scene) throw std::runtime_error(scene.error().message);
  terrain::Result<terrain::Program> program = terrain::compile(*scene);
  if (!program) throw std::runtime_error(program.error().message);
  return std::move(program).value();
}

terrain::Program compile_file(const std::string& path) {
  terrain::Result<terrain::Scene> scene = terrain::load_scene_file(path);
  if (!scene) throw std::runtime_error(scene.error().message);
  terrain::Result<terrain::Program> program = terrain::compile(*scene);
  if (!program) throw std::runtime_error(program.error().message);
  return std::move(program).value();
}

using examples::scene_files;

// Two discs in a blend, under a transform: every kind of instruction but combine.
const char* kTwoDiscs = R"({"type": "transform", "translate": [10, 0], "children": [
  {"type": "blend", "children": [
    {"type": "disc", "center": [0, 0], "radius": RADIUS, "elevation": 50},
    {"type": "disc", "center": [300, 0], "radius": 200, "elevation": 80}]}]})";

std::string two_discs(const char* radius) {
  std::string text = kTwoDiscs;
  text.replace(text.find("RADIUS"), 6, radius);
  return text;
}

// ---------------------------------------------------------------------------------------------
// The generated GLSL.

TEST(SpecialisedProgramGlsl, IsSharedByVersionsThatDifferOnlyInParameterValues) {
  auto a = specialised_program_glsl(compile_text(two_discs("100")));
  auto b = specialised_program_glsl(compile_text(two_discs("120")));
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(*a, *b);
  const terrain::Program three = compile_text(R"({"type": "blend", "children": [
    {"type": "disc", "center": [0, 0], "radius": 100, "elevation": 50},
    {"type": "disc", "center": [300, 0], "radius": 200, "elevation": 80},
    {"type": "disc", "center": [600, 0], "radius": 200, "elevation": 80}]})");
  auto c = specialised_program_glsl(three);
  ASSERT_TRUE(c.ok());
  EXPECT_NE(*a, *c);
}

TEST(SpecialisedProgramGlsl, CallsTheNodeFunctionsWithConstantOffsets) {
  const terrain::Program program = compile_text(two_discs("100"));
  auto glsl = specialised_program_glsl(program);
  ASSERT_TRUE(glsl.ok()) << glsl.error().message;
  EXPECT_NE(glsl->find("Field evaluate_program(vec2 p0, float s0)"), std::string::npos);
  EXPECT_NE(glsl->find("p1 = transform_point("), std::string::npos) << *glsl;
  EXPECT_NE(glsl->find("= disc_leaf("), std::string::npos);
  EXPECT_NE(glsl->find("blend_finish("), std::string::npos);
  EXPECT_EQ(glsl->find("fetch_code"), std::string::npos) << "no instruction is fetched";
}

TEST(NodeTypeDefines, KeepOnlyTheTypesAProgramUses) {
  const std::string defines = node_type_defines(compile_text(two_discs("100")));
  EXPECT_NE(defines.find("#define TERRAIN_USES_DISC 1\n"), std::string::npos) << defines;
  EXPECT_NE(defines.find("#define TERRAIN_USES_TRANSFORM 1\n"), std::string::npos);
  EXPECT_NE(defines.find("#define TERRAIN_USES_CURVE 0\n"), std::string::npos);
  EXPECT_NE(defines.find("#define TERRAIN_USES_WARP 0\n"), std::string::npos);
  EXPECT_NE(defines.find("#define TERRAIN_USES_NOISE_FBM 0\n"), std::string::npos);
}

TEST(NodeTypeDefines, KeepOnlyTheFractalKindsAndBasesAProgramUses) {
  const std::string defines = node_type_defines(compile_text(R"({"type": "warp",
    "noise": {"kind": "fbm", "amplitude": 10, "wavelength": 1500, "seed": 2},
    "children": [{"type": "disc", "center": [0, 0], "radius": 900, "elevation": 100,
      "noise": {"kind": "ridged", "basis": "simplex", "amplitude": 200, "wavelength": 600}}]})"));
  for (const char* on : {"NOISE_FBM 1", "NOISE_RIDGED 1", "NOISE_HYBRID 0", "NOISE_WARPED 0",
                         "NOISE_GRADIENT 1", "NOISE_SIMPLEX 1"}) {
    EXPECT_NE(defines.find(std::string("#define TERRAIN_USES_") + on + "\n"), std::string::npos)
        << on << "\n"
        << defines;
  }
}

// Malformed instruction streams (never made by terrain::compile) are refused by name.
TEST(SpecialisedProgramGlsl, RefusesAnEmptyProgram) {
  auto glsl = specialised_program_glsl(terrain::Program{});
  ASSERT_FALSE(glsl.ok());
  EXPECT_NE(glsl.error().message.find("empty"), std::string::npos);
}

TEST(SpecialisedProgramGlsl, RefusesANodeTypeTheShadersDoNotImplement) {
  terrain::Program program;
  const terrain::NodeType* blend = terrain::find_node_type("blend");
  ASSERT_NE(blend, nullptr);
  program.code.push_back(Instruction{Op::leaf, blend->id, 0, 0, 7});  // blend is no leaf
  auto glsl = specialised_program_glsl(program);
  ASSERT_FALSE(glsl.ok());
  EXPECT_NE(glsl.error().message.find("'blend'"), std::string::npos) << glsl.error().message;
  EXPECT_NE(glsl.error().message.find("node 7"), std::string::npos);
}

TEST(SpecialisedProgramGlsl, RefusesAJumpPastTheEnd) {
  terrain::Program program = compile_text(two_discs("100"));
  for (Instruction& ins : program.code) {
    if (ins.op == Op::cull || ins.op == Op::group) ins.skip += 100;
  }
  auto glsl = specialised_program_glsl(program);
  ASSERT_FALSE(glsl.ok());
  EXPECT_NE(glsl.error().message.find("jumps past"), std::string::npos) << glsl.error().message;
}

TEST(SpecialisedProgramGlsl, RefusesACullThatSkipsNothing) {
  terrain::Program program = compile_text(two_discs("100"));
  bool changed = false;
  for (Instruction& ins : program.code) {
    if (ins.op == Op::cull && !changed) ins.skip = 0, changed = true;
  }
  ASSERT_TRUE(changed);
  auto glsl = specialised_program_glsl(program);
  ASSERT_FALSE(glsl.ok());
  EXPECT_NE(glsl.error().message.find("balanced"), std::string::npos) << glsl.error().message;
}

TEST(SpecialisedProgramGlsl, RefusesAPopFromAnEmptyStack) {
  terrain::Program program;
  program.code.push_back(Instruction{Op::blend_add, 0, 0, 0, 0});
  auto glsl = specialised_program_glsl(program);
  ASSERT_FALSE(glsl.ok());
  EXPECT_NE(glsl.error().message.find("empty stack"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// On the device: each mode against the full interpreter, sample for sample.

void expect_equal_to_interpreter(const terrain::Program& program, const terrain::Box2& area,
                                 ShaderMode mode, const std::string& label) {
  terrain::GridSpec grid;
  grid.width = grid.height = 48;
  const terrain::Box2 box = area.expanded(0.15f * std::max(area.size().x, area.size().y));
  grid.step = std::max(box.size().x, box.size().y) / 47.0;
  grid.origin_x = box.lo.x;
  grid.origin_y = box.lo.y;
  auto reference = evaluator(ShaderMode::interpreter).evaluate_grid(program, grid);
  auto specialised = evaluator(mode).evaluate_grid(program, grid);
  ASSERT_TRUE(reference.ok()) << reference.error().message;
  ASSERT_TRUE(specialised.ok()) << label << ": " << specialised.error().message;
  int differing = 0;
  for (std::size_t i = 0; i < reference->elevation.size(); ++i) {
    // Bit for bit (NaN included): the same node functions run on the same values in order.
    const bool same =
        std::memcmp(&reference->elevation[i], &specialised->elevation[i], sizeof(float)) == 0 &&
        std::memcmp(&reference->gradient_x[i], &specialised->gradient_x[i], sizeof(float)) == 0 &&
        std::memcmp(&reference->gradient_y[i], &specialised->gradient_y[i], sizeof(float)) == 0;
    if (!same && ++differing <= 3) {
      ADD_FAILURE() << label << ": sample " << i << " interpreter f=" << reference->elevation[i]
                    << " specialised f=" << specialised->elevation[i];
    }
  }
  EXPECT_EQ(differing, 0) << label;
}

class EveryExampleInEveryShaderMode
    : public ::testing::TestWithParam<std::tuple<std::string, ShaderMode>> {};

TEST_P(EveryExampleInEveryShaderMode, EqualsTheInterpreter) {
  const auto& [path, mode] = GetParam();
  terrain::Result<terrain::Scene> scene = terrain::load_scene_file(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  expect_equal_to_interpreter(compile_file(path), scene->area(), mode, path);
}

// Pruned for every example; unrolled where automatic unrolls (unrolling the larger examples
// takes llvmpipe minutes to compile, which is why automatic does not).
std::vector<std::tuple<std::string, ShaderMode>> examples_and_modes() {
  std::vector<std::tuple<std::string, ShaderMode>> out;
  for (const std::string& path : scene_files()) {
    out.emplace_back(path, ShaderMode::pruned);
    if (unroll_pays(compile_file(path))) out.emplace_back(path, ShaderMode::unrolled);
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(ConfigScenes, EveryExampleInEveryShaderMode,
                         ::testing::ValuesIn(examples_and_modes()), [](const auto& entry) {
                           return examples::test_name(std::get<0>(entry.param)) +
                                  (std::get<1>(entry.param) == ShaderMode::pruned ? "_pruned"
                                                                                  : "_unrolled");
                         });

// Every node type's registry example, unrolled.
class EveryNodeTypeUnrolled : public ::testing::TestWithParam<const terrain::NodeType*> {};

TEST_P(EveryNodeTypeUnrolled, EqualsTheInterpreter) {
  const terrain::NodeType& type = *GetParam();
  const terrain::Program program = compile_text(std::string(type.example_json));
  const terrain::Box2 support = program.bounds.support;
  const bool finite = !support.empty() && std::isfinite(support.lo.x) &&
                      std::isfinite(support.lo.y) && std::isfinite(support.hi.x) &&
                      std::isfinite(support.hi.y);
  const terrain::Box2 area = finite ? support : terrain::Box2{{-500, -500}, {500, 500}};
  expect_equal_to_interpreter(program, area, ShaderMode::unrolled, std::string(type.name));
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryNodeTypeUnrolled,
                         ::testing::ValuesIn(terrain::node_types()),
                         [](const auto& entry) { return std::string(entry.param->name); });

TEST(GpuEvaluator, KeepsOnlyTheMostRecentlyUsedShaders) {
  GpuOptions options;
  options.shaders = ShaderMode::unrolled;
  options.cached_shaders = 2;
  auto created = GpuEvaluator::create(options);
  ASSERT_TRUE(created.ok()) << created.error().message;
  GpuEvaluator& gpu = *created.value();
  // Three structures: one, two and three discs.
  std::vector<terrain::Program> programs;
  std::string children;
  for (int n = 1; n <= 3; ++n) {
    if (n > 1) children += ",";
    children += R"({"type": "disc", "center": [)" + std::to_string(100 * n) +
                R"(, 0], "radius": 150, "elevation": 40})";
    programs.push_back(compile_text(R"({"type": "blend", "children": [)" + children + "]}"));
  }
  const std::vector<float> x{0.0f, 100.0f, 250.0f}, y{0.0f, 10.0f, -20.0f};
  std::vector<float> first(3), again(3), f(3);
  ASSERT_TRUE(gpu.evaluate(programs[0], x, y, 0.0f, first.data(), nullptr, nullptr).ok());
  for (const terrain::Program& p : programs) {
    ASSERT_TRUE(gpu.evaluate(p, x, y, 0.0f, f.data(), nullptr, nullptr).ok());
    EXPECT_LE(gpu.compiled_shaders(), 2u);
  }
  // The first structure's shader went; it is compiled again and gives the same values.
  ASSERT_TRUE(gpu.evaluate(programs[0], x, y, 0.0f, again.data(), nullptr, nullptr).ok());
  EXPECT_EQ(gpu.compiled_shaders(), 2u);
  EXPECT_EQ(first, again);
}

TEST(UnrollPays, ForTheSmallExamplesOnly) {
  const std::string dir = std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/";
  EXPECT_TRUE(unroll_pays(compile_file(dir + "butte.json")));
  EXPECT_TRUE(unroll_pays(compile_file(dir + "craters.json")));
  EXPECT_FALSE(unroll_pays(compile_file(dir + "mountain-range.json")));
  EXPECT_FALSE(unroll_pays(compile_file(dir + "winding-road.json")));
}

}  // namespace
}  // namespace gpu
