// Every built-in example scene (config/scenes/*.json) through the same property checks as the
// node types: parse, round trip, gradients, Lipschitz bounds, compiled program = tree.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "field_checks.hpp"
#include "terrain/image_io.hpp"
#include "terrain/sphere_trace.hpp"

namespace terrain {
namespace {

namespace fs = std::filesystem;

const fs::path kScenes = fs::path(TERRAIN_SOURCE_DIR) / "config" / "scenes";

std::vector<std::string> scene_names() {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(kScenes)) {
    if (entry.path().extension() == ".json") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

Scene load(const std::string& name) {
  Result<Scene> scene = load_scene_file((kScenes / (name + ".json")).string());
  EXPECT_TRUE(scene.ok()) << (scene.ok() ? ""
                                         : scene.error().pointer + ": " + scene.error().message);
  if (!scene.ok()) throw std::runtime_error("scene did not load");
  return std::move(scene).value();
}

int primitive_count(const Node& node) {
  if (node.type->category == NodeCategory::primitive) return 1;
  int n = 0;
  for (const NodePtr& c : node.children) n += primitive_count(*c);
  return n;
}

class ExampleScene : public ::testing::TestWithParam<std::string> {};

TEST_P(ExampleScene, ParsesAndRoundTrips) {
  const Scene scene = load(GetParam());
  EXPECT_FALSE(scene.name.empty());
  ASSERT_TRUE(scene.extent.has_value());
  ParseOptions options;
  options.images = [](std::string_view ref) {
    return read_heightfield((kScenes / std::string(ref)).string());
  };
  const Scene again = testing::parse_or_die(scene.canonical_text(), options);
  EXPECT_EQ(again.hash, scene.hash);
}

TEST_P(ExampleScene, GradientMatchesCentralDifferences) {
  testing::expect_gradients_match(load(GetParam()), 300);
}

TEST_P(ExampleScene, SampledSlopesStayWithinLipschitzBounds) {
  testing::expect_bounds_hold(load(GetParam()), 25, 30);
}

// The global bound is what a sphere tracer falls back on and what `validate` reports: it must
// be sound (above every slope sampled) and near the steepest slope there is. Before bounds were
// taken over a partition of the plane and per box, it was 13× to 101× the slope sampled here.
TEST_P(ExampleScene, GlobalBoundIsWithinTenTimesTheSteepestSlope) {
  const Scene scene = load(GetParam());
  const Program program = testing::compile_or_die(scene);
  const Box2 area = scene.area();
  constexpr double kStep = 6.0;
  const int columns = static_cast<int>(area.size().x / kStep) + 1;
  const int rows = static_cast<int>(area.size().y / kStep) + 1;
  const GridResult grid =
      evaluate_grid(program, {area.lo.x, area.lo.y, kStep, columns, rows, 0.0f}, 0);
  float steepest = 0.0f;
  for (std::size_t k = 0; k < grid.elevation.size(); ++k) {
    steepest = std::max(steepest, std::hypot(grid.gradient_x[k], grid.gradient_y[k]));
  }
  const float bound = program.bounds.elevation_lipschitz;
  EXPECT_GE(bound, steepest);
  EXPECT_LE(bound, 10.0f * steepest) << "global bound " << bound << ", steepest " << steepest;
  RecordProperty("ratio", std::to_string(bound / steepest));
}

TEST_P(ExampleScene, CompiledProgramEqualsTree) {
  testing::expect_program_equals_tree(load(GetParam()), 200);
  testing::expect_program_equals_tree(load(GetParam()), 100, 20.0f);
}

TEST_P(ExampleScene, BlockLayoutChangesNoBit) {
  testing::expect_block_layout_independent(load(GetParam()), 0.0f);
  testing::expect_block_layout_independent(load(GetParam()), 30.0f);
}

TEST_P(ExampleScene, AcceleratedSphereTracingFindsEveryDenseHit) {
  const Scene scene = load(GetParam());
  const Program program = testing::compile_or_die(scene);
  Evaluator e(program);
  const Box2 area = scene.area();
  // A 480×320 picture's camera, sampled sparsely; both tracers use its pixel footprint as LoD.
  const Camera camera = default_camera(program, area, 480, 320);
  const TraceDomain domain = trace_domain(program, area);
  TraceOptions options;
  options.lod_per_metre = pixel_footprint(camera);
  Evaluator grid_evaluator(program);
  const LipschitzGrid grid(grid_evaluator, area, 32);
  TraceOptions with_grid = options;
  with_grid.bounds = &grid;
  for (int y = 0; y < camera.height; y += 60) {
    for (int x = 0; x < camera.width; x += 60) {
      const Ray ray = camera.ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
      const TraceResult dense = march_dense(e, domain, ray, 1.0f, 1e6f, options.lod_per_metre);
      const TraceResult fast = sphere_trace(e, domain, ray, options);
      const TraceResult gridded = sphere_trace(e, domain, ray, with_grid);
      if (dense.hit) {
        ASSERT_TRUE(fast.hit) << "pixel " << x << ", " << y;
        EXPECT_LE(fast.t, dense.t + 0.05f);
        ASSERT_TRUE(gridded.hit) << "pixel " << x << ", " << y << " (Lipschitz grid)";
        EXPECT_LE(gridded.t, dense.t + 0.05f);
      }
    }
  }
}

std::string test_name(const ::testing::TestParamInfo<std::string>& param) {
  std::string n = param.param;
  std::replace(n.begin(), n.end(), '-', '_');
  return n;
}

INSTANTIATE_TEST_SUITE_P(Builtin, ExampleScene, ::testing::ValuesIn(scene_names()), test_name);

TEST(ExampleScenes, AtLeastFiveExistAndOneHasSeventyPrimitives) {
  const std::vector<std::string> names = scene_names();
  EXPECT_GE(names.size(), 5u);
  int most = 0;
  for (const std::string& n : names) most = std::max(most, primitive_count(*load(n).root));
  EXPECT_GE(most, 70);
}

}  // namespace
}  // namespace terrain
