// Every registered node type, through its own example: the registry drives these tests, so a
// new node type is checked without touching this file.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include "field_checks.hpp"

#include "terrain/node.hpp"

namespace terrain {
namespace {

// Image examples get a synthetic heightfield (smooth hills with a sharp ridge), whatever the name.
Result<Raster> synthetic_image(std::string_view) {
  Raster r;
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

Scene parse_example(const std::string& text) {
  ParseOptions options;
  options.images = synthetic_image;
  return testing::parse_or_die(text, options);
}

std::string scene_of(const NodeType& type) {
  return R"({"format": "terrain-scene/1", "name": ")" + std::string(type.name) +
         R"(", "seed": 3, "root": )" + std::string(type.example_json) + "}";
}

class EveryNodeType : public ::testing::TestWithParam<const NodeType*> {};

TEST_P(EveryNodeType, ExampleParsesAndRoundTrips) {
  const Scene scene = parse_example(scene_of(*GetParam()));
  const Scene again = parse_example(scene.canonical_text());
  EXPECT_EQ(scene.canonical_text(), again.canonical_text());
  EXPECT_EQ(scene.hash, again.hash);
}

TEST_P(EveryNodeType, GradientMatchesCentralDifferences) {
  testing::expect_gradients_match(parse_example(scene_of(*GetParam())), 400);
}

TEST_P(EveryNodeType, GradientMatchesCentralDifferencesAtCoarseDetail) {
  testing::expect_gradients_match(parse_example(scene_of(*GetParam())), 200, 37.0f);
}

TEST_P(EveryNodeType, SampledSlopesStayWithinLipschitzBounds) {
  testing::expect_bounds_hold(parse_example(scene_of(*GetParam())), 60, 40);
}

TEST_P(EveryNodeType, CompiledProgramEqualsTree) {
  testing::expect_program_equals_tree(parse_example(scene_of(*GetParam())), 300);
}

TEST_P(EveryNodeType, BlockLayoutChangesNoBit) {
  testing::expect_block_layout_independent(parse_example(scene_of(*GetParam())), 0.0f);
  testing::expect_block_layout_independent(parse_example(scene_of(*GetParam())), 37.0f);
}

TEST_P(EveryNodeType, UnknownFieldIsRejectedWithItsPointer) {
  nlohmann::json doc = nlohmann::json::parse(scene_of(*GetParam()));
  doc["root"]["colour"] = "blue";
  ParseOptions options;
  options.images = synthetic_image;
  const Result<Scene> scene = parse_scene(doc, options);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.error().pointer, "/root/colour");
}

std::string type_name(const ::testing::TestParamInfo<const NodeType*>& info) {
  return std::string(info.param->name);
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryNodeType, ::testing::ValuesIn(node_types()), type_name);

// An image mapped along a curve (Génevaux Fig 9): u along the arc length, v across the width.
const char* kImageAlongCurve = R"({"root": {"type": "image", "image": "canyon.png",
  "curve": {"pieces": [[[-1200, 0, 0], [-400, 500, 0], [300, 0, 0]], [[300, 0, 0], [1000, -500, 0], [1500, 200, 0]]],
            "width": 400},
  "elevation": -60, "height_scale": 120, "margin": 0.15}})";

TEST(ImagePrimitive, AlongACurveHasExactGradientsAndHoldsItsBounds) {
  const Scene scene = parse_example(kImageAlongCurve);
  testing::expect_gradients_match(scene, 400);
  testing::expect_bounds_hold(scene, 40, 30);
  testing::expect_program_equals_tree(scene, 300);
}

TEST(ImagePrimitive, FollowsTheCurve) {
  const Scene scene = parse_example(kImageAlongCurve);
  // On the skeleton (v = 0.5) the weight is full well inside the curve; far off it, zero.
  EXPECT_NEAR(evaluate_tree(scene, {300, 0}).weight, 1.0f, 1e-4f);
  EXPECT_EQ(evaluate_tree(scene, {300, 900}).weight, 0.0f);
}

TEST(ImagePrimitive, NeedsExactlyOneMapping) {
  ParseOptions options;
  options.images = synthetic_image;
  Result<Scene> both = parse_scene_text(R"({"root": {"type": "image", "image": "a.png",
    "corners": [[0, 1], [1, 1], [1, 0], [0, 0]], "curve": {"pieces": [[[0, 0, 0], [1, 0, 0]]], "width": 1}}})",
                                        options);
  ASSERT_FALSE(both.ok());
  EXPECT_EQ(both.error().pointer, "/root/corners");
  Result<Scene> no_store = parse_scene_text(R"({"root": {"type": "image", "image": "a.png",
    "corners": [[0, 1], [1, 1], [1, 0], [0, 0]]}})");
  ASSERT_FALSE(no_store.ok());
  EXPECT_EQ(no_store.error().pointer, "/root/image");
  options.images = [](std::string_view) -> Result<Raster> { return Error{"no such file", ""}; };
  Result<Scene> missing = parse_scene_text(R"({"root": {"type": "image", "image": "gone.png",
    "corners": [[0, 1], [1, 1], [1, 0], [0, 0]]}})",
                                           options);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().pointer, "/root/image");
  EXPECT_NE(missing.error().message.find("gone.png"), std::string::npos);
}

// The GPU evaluator's loop budget (llvmpipe) adds up each node's loop cost: none may be missing.
TEST(NodeRegistry, EveryNodeTypeHasALoopCost) {
  for (const NodeType* t : node_types()) EXPECT_NE(t->loop_iterations, nullptr) << t->name;
}

TEST(NodeRegistry, IdsAndNamesAreUnique) {
  std::set<std::uint16_t> ids;
  std::set<std::string_view> names;
  for (const NodeType* t : node_types()) {
    EXPECT_TRUE(ids.insert(t->id).second) << t->name;
    EXPECT_TRUE(names.insert(t->name).second) << t->name;
    EXPECT_EQ(find_node_type(t->name), t);
  }
}

}  // namespace
}  // namespace terrain
