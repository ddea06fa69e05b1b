// Scene JSON: canonical form, content hash, instancing, and every malformed case with its pointer.
#include <gtest/gtest.h>

#include "field_checks.hpp"

namespace terrain {
namespace {

const char* kDisc = R"({"type": "disc", "center": [0, 0], "radius": 100})";

TEST(SceneJson, CanonicalFormMakesDefaultsExplicit) {
  const Scene s = testing::parse_or_die(std::string(R"({"root": )") + kDisc + "}");
  EXPECT_EQ(s.canonical["format"], "terrain-scene/1");
  EXPECT_EQ(s.canonical["root"]["elevation"], 0.0);
  EXPECT_EQ(s.canonical["root"]["noise"]["kind"], "none");
}

TEST(SceneJson, HashIgnoresKeyOrderWhitespaceAndDefaults) {
  const Scene a =
      testing::parse_or_die(R"({"root": {"type": "disc", "center": [0, 0], "radius": 100}})");
  const Scene b = testing::parse_or_die(
      R"({ "root" : { "radius" : 100.0, "center" : [0,0], "type":"disc", "elevation": 0 },
                                            "format": "terrain-scene/1", "seed": 0 })");
  EXPECT_EQ(a.hash, b.hash);
  EXPECT_EQ(a.hash.rfind("sha256:", 0), 0u);
  EXPECT_EQ(a.hash.size(), 7u + 64u);
}

TEST(SceneJson, HashChangesWithAnyParameter) {
  const Scene a =
      testing::parse_or_die(R"({"root": {"type": "disc", "center": [0, 0], "radius": 100}})");
  const Scene b =
      testing::parse_or_die(R"({"root": {"type": "disc", "center": [0, 0], "radius": 100.5}})");
  EXPECT_NE(a.hash, b.hash);
}

TEST(SceneJson, InstancesShareOneDefinition) {
  const Scene s = testing::parse_or_die(
      R"({"definitions": {"hill": {"type": "disc", "center": [0, 0], "radius": 100, "elevation": 50}},
    "root": {"type": "blend", "children": [
      {"type": "transform", "translate": [0, 0], "children": [{"ref": "hill"}]},
      {"type": "transform", "translate": [500, 0], "children": [{"ref": "hill"}]}]}})");
  ASSERT_EQ(s.root->children.size(), 2u);
  EXPECT_EQ(s.root->children[0]->children[0].get(), s.root->children[1]->children[0].get());
  EXPECT_FLOAT_EQ(evaluate_tree(s, {500, 0}).elevation, 50.0f);
  EXPECT_EQ(s.canonical["root"]["children"][1]["children"][0]["ref"], "hill");
  const Scene again = testing::parse_or_die(s.canonical_text());
  EXPECT_EQ(again.hash, s.hash);
}

TEST(SceneJson, NonFiniteNumbersInADocumentAreRejected) {
  nlohmann::json doc =
      nlohmann::json::parse(R"({"root": {"type": "disc", "center": [0, 0], "radius": 5}})");
  doc["root"]["radius"] = std::numeric_limits<double>::quiet_NaN();
  Result<Scene> scene = parse_scene(doc);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.error().pointer, "/root/radius");
  doc["root"]["radius"] = 5;
  doc["root"]["center"][1] = std::numeric_limits<double>::infinity();
  scene = parse_scene(doc);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.error().pointer, "/root/center");
}

// Every version listing repeats the name: it is bounded in bytes (UTF-8), not characters.
TEST(SceneJson, NamesLongerThanTheLimitAreRejectedAtName) {
  auto with_name = [](const std::string& name) {
    return nlohmann::json{{"name", name},
                          {"root", {{"type", "disc"}, {"center", {0, 0}}, {"radius", 5}}}};
  };
  EXPECT_TRUE(parse_scene(with_name(std::string(256, 'n'))).ok());
  const Result<Scene> long_name = parse_scene(with_name(std::string(257, 'n')));
  ASSERT_FALSE(long_name.ok());
  EXPECT_EQ(long_name.error().pointer, "/name");
  EXPECT_NE(long_name.error().message.find("at most 256 bytes"), std::string::npos)
      << long_name.error().message;
  // 129 two-byte characters are 258 bytes.
  std::string accented;
  for (int i = 0; i < 129; ++i) accented += "\u00e9";
  EXPECT_EQ(parse_scene(with_name(accented)).error().pointer, "/name");
  const Result<Scene> huge = parse_scene(with_name(std::string(3 << 20, 'n')));
  ASSERT_FALSE(huge.ok());
  EXPECT_EQ(huge.error().pointer, "/name");
  ParseOptions roomy;
  roomy.limits.max_name_bytes = 300;
  EXPECT_TRUE(parse_scene(with_name(std::string(257, 'n')), roomy).ok());
}

struct Malformed {
  const char* name;
  const char* json;
  const char* pointer;
  const char* message_part;
};

class MalformedScene : public ::testing::TestWithParam<Malformed> {};

TEST_P(MalformedScene, IsRejectedWithThePointerAndReason) {
  ParseOptions options;
  options.limits.max_nodes = 50;
  options.limits.max_depth = 8;
  const Result<Scene> scene = parse_scene_text(GetParam().json, options);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.error().pointer, GetParam().pointer) << scene.error().message;
  EXPECT_NE(scene.error().message.find(GetParam().message_part), std::string::npos)
      << scene.error().message;
}

const Malformed kMalformed[] = {
    {"NotJson", R"({"root": )", "", "not valid JSON"},
    {"NotAnObject", R"([1, 2])", "", "JSON object"},
    {"MissingRoot", R"({"name": "x"})", "/root", "required"},
    {"WrongFormat",
     R"({"format": "other/2", "root": {"type": "disc", "center": [0,0], "radius": 1}})", "/format",
     "terrain-scene/1"},
    {"UnknownTopLevelField",
     R"({"rooot": 1, "root": {"type": "disc", "center": [0,0], "radius": 1}})", "/rooot",
     "not a known field"},
    {"UnknownNodeType", R"({"root": {"type": "volcano"}})", "/root/type", "unknown node type"},
    {"MissingType", R"({"root": {"center": [0, 0]}})", "/root/type", "required"},
    {"MissingRadius", R"({"root": {"type": "disc", "center": [0, 0]}})", "/root/radius",
     "required"},
    {"NegativeRadius", R"({"root": {"type": "disc", "center": [0, 0], "radius": -5}})",
     "/root/radius", "greater than"},
    {"NumberOverflow", R"({"root": {"type": "disc", "center": [0, 0], "radius": 1e999}})", "",
     "number overflow"},
    {"BadCentre", R"({"root": {"type": "disc", "center": [0], "radius": 5}})", "/root/center",
     "two numbers"},
    {"StringWhereNumber", R"({"root": {"type": "disc", "center": [0, 0], "radius": "big"}})",
     "/root/radius", "number"},
    {"BadNoiseKind",
     R"({"root": {"type": "disc", "center": [0, 0], "radius": 5, "noise": {"kind": "perlin"}}})",
     "/root/noise/kind", "one of"},
    {"TooManyOctaves",
     R"({"root": {"type": "disc", "center": [0, 0], "radius": 5, "noise": {"octaves": 40}}})",
     "/root/noise/octaves", "integer from"},
    {"ChildrenOnAPrimitive",
     R"({"root": {"type": "disc", "center": [0, 0], "radius": 5, "children": []}})",
     "/root/children", "no children"},
    {"ReplaceWithOneChild",
     R"({"root": {"type": "replace", "children": [{"type": "disc", "center": [0, 0], "radius": 5}]}})",
     "/root/children", "takes 2 children"},
    {"BadChildDeepDown",
     R"({"root": {"type": "blend", "children": [{"type": "disc", "center": [0, 0], "radius": 5}, {"type": "disc", "center": [0, 0], "radius": 0}]}})",
     "/root/children/1/radius", "greater than"},
    {"UndefinedReference", R"({"root": {"ref": "nowhere"}})", "/root/ref", "undefined definition"},
    {"ReferenceCycle",
     R"({"definitions": {"a": {"type": "transform", "children": [{"ref": "b"}]}, "b": {"type": "transform", "children": [{"ref": "a"}]}}, "root": {"ref": "a"}})",
     "/definitions/b/children/0/ref", "cycle"},
    {"ReferenceWithExtraFields",
     R"({"definitions": {"a": {"type": "disc", "center": [0, 0], "radius": 5}}, "root": {"ref": "a", "scale": 2}})",
     "/root", "only \"ref\""},
    {"InvalidUnusedDefinition",
     R"({"definitions": {"a": {"type": "disc", "center": [0, 0]}}, "root": {"type": "disc", "center": [0, 0], "radius": 5}})",
     "/definitions/a/radius", "required"},
    {"TooDeep",
     R"({"root": {"type": "transform", "children": [{"type": "transform", "children": [{"type": "transform", "children": [{"type": "transform", "children": [{"type": "transform", "children": [{"type": "transform", "children": [{"type": "transform", "children": [{"type": "transform", "children": [{"type": "disc", "center": [0, 0], "radius": 5}]}]}]}]}]}]}]}]}})",
     "/root/children/0/children/0/children/0/children/0/children/0/children/0/children/0/children/"
     "0",
     "deeper than"},
    {"TooManyNodesAfterInstancing",
     R"({"definitions": {"h": {"type": "blend", "children": [{"type": "disc", "center": [0, 0], "radius": 5}, {"type": "disc", "center": [1, 0], "radius": 5}, {"type": "disc", "center": [2, 0], "radius": 5}, {"type": "disc", "center": [3, 0], "radius": 5}, {"type": "disc", "center": [4, 0], "radius": 5}, {"type": "disc", "center": [5, 0], "radius": 5}, {"type": "disc", "center": [6, 0], "radius": 5}, {"type": "disc", "center": [7, 0], "radius": 5}, {"type": "disc", "center": [8, 0], "radius": 5}]}},
        "root": {"type": "blend", "children": [{"ref": "h"}, {"ref": "h"}, {"ref": "h"}, {"ref": "h"}, {"ref": "h"}, {"ref": "h"}]}})",
     "/root", "more than 50 nodes"},
    {"WarpTooStrong",
     R"({"root": {"type": "warp", "noise": {"amplitude": 500, "wavelength": 100}, "children": [{"type": "disc", "center": [0, 0], "radius": 5}]}})",
     "/root/noise", "invertible"},
    {"LodSpacingsReversed",
     R"({"root": {"type": "lod", "coarse_spacing": 5, "fine_spacing": 50, "children": [{"type": "disc", "center": [0, 0], "radius": 5}, {"type": "disc", "center": [0, 0], "radius": 5}]}})",
     "/root/fine_spacing", "smaller"},
    {"ExtentInverted",
     R"({"extent": {"min": [10, 10], "max": [0, 20]}, "root": {"type": "disc", "center": [0, 0], "radius": 5}})",
     "/extent/max", "larger"},
    {"ScaleZero",
     R"({"root": {"type": "transform", "scale": 0, "children": [{"type": "disc", "center": [0, 0], "radius": 5}]}})",
     "/root/scale", "0.0001"},
};

std::string case_name(const ::testing::TestParamInfo<Malformed>& param) {
  return param.param.name;
}

INSTANTIATE_TEST_SUITE_P(Cases, MalformedScene, ::testing::ValuesIn(kMalformed), case_name);

}  // namespace
}  // namespace terrain
