// Algebraic properties of the operators (Génevaux §5–6).
#include <gtest/gtest.h>

#include "field_checks.hpp"

namespace terrain {
namespace {

const char* kA = R"({"type": "disc", "center": [-300, 0], "radius": 900, "elevation": 100,
  "noise": {"kind": "fbm", "amplitude": 40, "wavelength": 300, "seed": 1}})";
const char* kB = R"({"type": "disc", "center": [250, 100], "radius": 800, "elevation": 260,
  "noise": {"kind": "ridged", "amplitude": 60, "wavelength": 400, "seed": 2}})";
const char* kC = R"({"type": "disc", "center": [0, -350], "radius": 700, "elevation": 180})";

Scene blend_of(const std::string& children) {
  return testing::parse_or_die(R"({"root": {"type": "blend", "children": [)" + children + "]}}");
}

TEST(BlendOperator, IsCommutative) {
  const Scene ab = blend_of(std::string(kA) + "," + kB + "," + kC);
  const Scene ba = blend_of(std::string(kC) + "," + kB + "," + kA);
  std::mt19937 rng(5);
  for (int k = 0; k < 500; ++k) {
    const Vec2 p = testing::random_point(rng, Box2::around({0, 0}, 1500));
    const FieldSample x = evaluate_tree(ab, p), y = evaluate_tree(ba, p);
    EXPECT_NEAR(x.elevation, y.elevation, 1e-3f);
    EXPECT_NEAR(x.weight, y.weight, 1e-6f);
  }
}

// The background (scene base level) fills in only where the children's weights sum below the
// threshold; wherever the inner blend has weight ≥ threshold, nesting does not matter.
TEST(BlendOperator, IsAssociativeWhereWeightsReachTheThreshold) {
  const Scene flat = blend_of(std::string(kA) + "," + kB + "," + kC);
  const Scene nested =
      blend_of(std::string(kA) + R"(, {"type": "blend", "children": [)" + kB + "," + kC + "]}");
  const Scene inner = blend_of(std::string(kB) + "," + kC);
  std::mt19937 rng(6);
  int compared = 0;
  for (int k = 0; k < 4000; ++k) {
    const Vec2 p = testing::random_point(rng, Box2::around({0, 0}, 1500));
    if (evaluate_tree(inner, p).weight < 0.5f) continue;
    ++compared;
    EXPECT_NEAR(evaluate_tree(flat, p).elevation, evaluate_tree(nested, p).elevation, 1e-3f);
    EXPECT_NEAR(evaluate_tree(flat, p).weight, evaluate_tree(nested, p).weight, 1e-5f);
  }
  EXPECT_GT(compared, 200);
}

TEST(BlendOperator, FadesToTheBaseLevelOutsideEverySupport) {
  const Scene s = testing::parse_or_die(
      std::string(R"({"base_elevation": -20, "root": {"type": "blend", "children": [)") + kA +
      "]}}");
  const FieldSample far = evaluate_tree(s, {5000, 5000});
  EXPECT_FLOAT_EQ(far.elevation, -20.0f);
  EXPECT_EQ(far.weight, 0.0f);
}

TEST(ReplaceOperator, KeepsAOutsideBAndGivesBInsideItsCore) {
  const Scene s = testing::parse_or_die(
      std::string(R"({"root": {"type": "replace", "children": [)") + kA + "," +
      R"({"type": "disc", "center": [0, 0], "radius": 200, "elevation": 5}]}})");
  const Scene a = testing::parse_or_die(std::string(R"({"root": )") + kA + "}");
  EXPECT_FLOAT_EQ(evaluate_tree(s, {0, 0}).elevation, 5.0f);
  EXPECT_FLOAT_EQ(evaluate_tree(s, {-600, 300}).elevation, evaluate_tree(a, {-600, 300}).elevation);
  EXPECT_FLOAT_EQ(evaluate_tree(s, {0, 0}).weight, evaluate_tree(a, {0, 0}).weight);
}

TEST(AddOperator, AddsWeightedElevation) {
  const Scene s = testing::parse_or_die(
      std::string(R"({"root": {"type": "add", "children": [)") + kC + "," +
      R"({"type": "disc", "center": [0, -350], "radius": 400, "elevation": 10}]}})");
  EXPECT_FLOAT_EQ(evaluate_tree(s, {0, -350}).elevation, 190.0f);
}

TEST(LodOperator, HasNoJumpsAsTheDetailVaries) {
  const Scene s = testing::parse_or_die(
      std::string(
          R"({"root": {"type": "lod", "coarse_spacing": 50, "fine_spacing": 5, "children": [)") +
      kC + "," + kA + "]}}");
  const Vec2 p{-100, -100};
  float previous = evaluate_tree(s, p, 100.0f).elevation;
  for (float spacing = 100.0f; spacing > 1.0f; spacing *= 0.99f) {
    const float f = evaluate_tree(s, p, spacing).elevation;
    EXPECT_LT(std::abs(f - previous), 2.0f) << "jump at spacing " << spacing;
    previous = f;
  }
  EXPECT_FLOAT_EQ(
      evaluate_tree(s, p, 60.0f).elevation,
      evaluate_tree(testing::parse_or_die(std::string(R"({"root": )") + kC + "}"), p).elevation);
}

TEST(DiscPrimitive, OctavesUnravelContinuouslyWithTheDetail) {
  const Scene s = testing::parse_or_die(std::string(R"({"root": )") + kB + "}");
  const Vec2 p{300, 120};
  float previous = evaluate_tree(s, p, 400.0f).elevation;
  for (float spacing = 400.0f; spacing > 0.5f; spacing *= 0.995f) {
    const float f = evaluate_tree(s, p, spacing).elevation;
    EXPECT_LT(std::abs(f - previous), 1.5f) << "jump at spacing " << spacing;
    previous = f;
  }
}

TEST(WeightFunction, IsZeroOutsideItsSupportAndContinuous) {
  const Scene s = testing::parse_or_die(std::string(R"({"root": )") + kA + "}");
  EXPECT_EQ(evaluate_tree(s, {-300 + 900.5f, 0}).weight, 0.0f);
  float previous = evaluate_tree(s, {-300, 0}).weight;
  for (float x = -300; x < 700; x += 0.5f) {
    const float a = evaluate_tree(s, {x, 0}).weight;
    EXPECT_LT(std::abs(a - previous), 0.5f * 1.7174f / 900.0f + 1e-6f);
    previous = a;
  }
}

TEST(TransformOperator, ConcatenatedTransformsEqualNestedOnes) {
  const Scene s = testing::parse_or_die(
      std::string(
          R"({"root": {"type": "transform", "translate": [100, 50], "rotate": 20, "scale": 1.5, "children": [
     {"type": "transform", "translate": [-30, 10], "rotate": -45, "scale": [0.5, 2], "elevation_scale": 2, "elevation_offset": 3, "children": [)") +
      kB + "]}]}}");
  testing::expect_program_equals_tree(s, 500);
  CompileOptions plain;
  plain.concatenate_affine = false;
  EXPECT_LT(compile(s).value().code.size(), compile(s, plain).value().code.size());
}

}  // namespace
}  // namespace terrain
