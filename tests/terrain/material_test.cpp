// The material model's parameters (terrain/material.hpp, docs/material.md): what each does to
// the colour, how a scene's "material" is parsed, written and hashed, and how bad ones are refused.
#include "terrain/material.hpp"

#include <gtest/gtest.h>

#include <string>

#include "terrain/scene.hpp"
#include "terrain/sphere_trace.hpp"

namespace terrain {
namespace {

using nlohmann::json;

constexpr float kSine30 = 0.5f;

Rgb albedo(const MaterialInput& input, const Material& material = {}) {
  return material_albedo(input, pack_material(material));
}

bool same(Rgb a, Rgb b) {
  return a.r == b.r && a.g == b.g && a.b == b.b;
}

MaterialInput at_height(float height, float slope = 0.0f) {
  MaterialInput input;
  input.height = height;
  input.slope = slope;
  return input;
}

TEST(MaterialModel, DefaultsDrawGrassForestSnowRockAndWater) {
  const Material m;
  EXPECT_TRUE(same(albedo(at_height(0.0f)), m.grass));
  EXPECT_TRUE(same(albedo(at_height(0.31f)), m.forest));
  EXPECT_TRUE(same(albedo(at_height(0.95f)), m.snow));
  EXPECT_TRUE(same(albedo(at_height(0.2f, 0.9f)), m.rock));  // 64°: a cliff
  MaterialInput wet = at_height(0.95f);
  wet.water = true;
  EXPECT_TRUE(same(albedo(wet), m.water));
}

TEST(MaterialModel, EveryColourParameterShowsWhereItsCoverIs) {
  Material red;
  red.forest = {1.0f, 0.0f, 0.0f};
  red.rock = {0.0f, 1.0f, 0.0f};
  red.snow = {0.0f, 0.0f, 1.0f};
  EXPECT_TRUE(same(albedo(at_height(0.31f), red), red.forest));
  EXPECT_TRUE(same(albedo(at_height(0.2f, 0.9f), red), red.rock));
  EXPECT_TRUE(same(albedo(at_height(0.95f), red), red.snow));
  EXPECT_TRUE(same(albedo(at_height(0.0f), red), Material{}.grass));
}

TEST(MaterialModel, SlopeBandsAreInDegrees) {
  Material m;
  m.rock_slope = {20.0f, 25.0f};
  EXPECT_TRUE(same(albedo(at_height(0.0f, kSine30), m), m.rock));  // 30° is past the band
  EXPECT_FALSE(same(albedo(at_height(0.0f, kSine30)), m.rock));    // not past the default's
}

TEST(MaterialModel, SnowLineFallsOnPolewardSlopesAndTowardsThePoles) {
  const Material m;
  MaterialInput mid = at_height(0.78f);
  const Rgb level = albedo(mid);
  mid.northness = 1.0f;
  const Rgb poleward = albedo(mid);
  EXPECT_GT(poleward.b, level.b);  // more snow facing the pole
  MaterialInput low = at_height(0.3f);
  EXPECT_FALSE(same(albedo(low), m.snow));
  low.polar = 1.0f;  // at a pole the line lies 0.7 lower
  EXPECT_TRUE(same(albedo(low), m.snow));
  Material temperate;
  temperate.snow_polar = 0.0f;
  EXPECT_FALSE(same(albedo(low, temperate), m.snow));
}

TEST(MaterialJson, ReadsColoursAsArraysOrHexAndKeepsDefaultsElsewhere) {
  const Result<Material> m =
      parse_material(json::parse(R"({"grass": "#ff8000", "snow": [0.5, 0.5, 0.5],
                                     "tree_line": [0.4, 0.5], "snow_line": 0.9})"),
                     "/material");
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->grass.r, 1.0f);
  EXPECT_EQ(m->grass.g, 128.0f / 255.0f);
  EXPECT_EQ(m->grass.b, 0.0f);
  EXPECT_EQ(m->snow.g, 0.5f);
  EXPECT_EQ(m->tree_line.lo, 0.4f);
  EXPECT_EQ(m->snow_line, 0.9f);
  EXPECT_TRUE(same(m->rock, Material{}.rock));
}

TEST(MaterialJson, CanonicalFormReadsBackTheSameMaterial) {
  Material m;
  m.grass = {0.1f, 0.2f, 0.3f};
  m.scree_slope = {20.5f, 33.25f};
  m.snow_polar = 0.25f;
  const json canonical = material_json(m);
  EXPECT_EQ(canonical.size(), kMaterialFields.size());
  EXPECT_EQ(canonical["grass"], json::parse("[0.1, 0.2, 0.3]"));  // the numbers written, tidy
  const Result<Material> back = parse_material(canonical, "");
  ASSERT_TRUE(back);
  EXPECT_TRUE(same_material(*back, m));
}

TEST(MaterialJson, PackedFormHoldsSinesOfSlopesAtTheDeclaredOffsets) {
  const PackedMaterial packed = pack_material({});
  EXPECT_EQ(packed.size(), 47u);
  EXPECT_EQ(packed[material_offset("grass")], 0.36f);
  EXPECT_EQ(packed[material_offset("snow_polar")], 0.70f);
  EXPECT_NEAR(packed[material_offset("snow_slope")], kSine30, 1e-7);
  const std::string glsl = material_glsl_declarations();
  for (const MaterialField& field : kMaterialFields) {
    std::string name(field.name);
    for (char& c : name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    EXPECT_NE(glsl.find("#define MATERIAL_" + name + " " +
                        std::to_string(material_offset(field.name)) + "\n"),
              std::string::npos)
        << field.name;
  }
  EXPECT_NE(glsl.find("uniform float u_material[MATERIAL_FLOATS];"), std::string::npos);
}

TEST(SceneMaterial, DefaultsWrittenOutKeepTheScenesHash) {
  const json plain =
      json::parse(R"({"root": {"type": "disc", "center": [0, 0], "radius": 100, "elevation": 5}})");
  json explicit_defaults = plain;
  explicit_defaults["material"] = material_json(Material{});
  json empty = plain;
  empty["material"] = json::object();
  const Result<Scene> a = parse_scene(plain);
  const Result<Scene> b = parse_scene(explicit_defaults);
  const Result<Scene> c = parse_scene(empty);
  ASSERT_TRUE(a && b && c);
  EXPECT_EQ(a->hash, b->hash);
  EXPECT_EQ(a->hash, c->hash);
  EXPECT_FALSE(a->canonical.contains("material"));
}

TEST(SceneMaterial, AChangedMaterialIsWrittenInFullAndChangesTheHash) {
  json doc =
      json::parse(R"({"root": {"type": "disc", "center": [0, 0], "radius": 100, "elevation": 5},
                             "material": {"rock": "#804020"}})");
  const Result<Scene> scene = parse_scene(doc);
  ASSERT_TRUE(scene) << scene.error().message;
  ASSERT_TRUE(scene->canonical.contains("material"));
  EXPECT_EQ(scene->canonical["material"].size(), kMaterialFields.size());
  doc.erase("material");
  EXPECT_NE(parse_scene(doc)->hash, scene->hash);
  // The canonical text parses to the same scene.
  const Result<Scene> again = parse_scene_text(scene->canonical_text());
  ASSERT_TRUE(again);
  EXPECT_EQ(again->hash, scene->hash);
  EXPECT_TRUE(same_material(again->material, scene->material));
}

TEST(SceneMaterial, PicturesTakeTheScenesColours) {
  const Result<Scene> scene = parse_scene(json::parse(
      R"({"root": {"type": "disc", "center": [0, 0], "radius": 2000, "elevation": 50}})"));
  ASSERT_TRUE(scene);
  const Result<Program> program = compile(*scene);
  ASSERT_TRUE(program);
  const Box2 area = scene->area();
  const Camera camera = default_camera(*program, area, 32, 20);
  RenderOptions options;
  options.threads = 1;
  const Picture before = render(*program, area, camera, options);
  for (Rgb* cover : {&options.material.grass, &options.material.forest, &options.material.meadow,
                     &options.material.bare_ground, &options.material.scree, &options.material.rock,
                     &options.material.snow, &options.material.sand}) {
    *cover = {1.0f, 0.0f, 0.0f};
  }
  const Picture after = render(*program, area, camera, options);
  int redder = 0, hits = 0;
  for (std::size_t i = 0; i < after.depth.size(); ++i) {
    if (after.depth[i] < 0.0f) continue;
    ++hits;
    redder += after.rgb[3 * i] > before.rgb[3 * i] && after.rgb[3 * i + 1] < before.rgb[3 * i + 1];
  }
  ASSERT_GT(hits, 100);
  EXPECT_EQ(redder, hits);
}

// Malformed materials, each refused with the pointer of what is wrong.
TEST(MaterialJsonErrors, NameTheOffendingField) {
  const struct {
    const char* material;
    const char* pointer;
  } cases[] = {
      {R"([1, 2])", "/material"},
      {R"({"gras": [0, 0, 0]})", "/material/gras"},
      {R"({"grass": [0, 0]})", "/material/grass"},
      {R"({"grass": [0, 0, 1.5]})", "/material/grass/2"},
      {R"({"grass": [0, "a", 0]})", "/material/grass/1"},
      {R"({"grass": "#12345"})", "/material/grass"},
      {R"({"grass": "#12345g"})", "/material/grass"},
      {R"({"tree_line": [0.5, 0.4]})", "/material/tree_line/1"},
      {R"({"tree_line": [0.5, 0.5]})", "/material/tree_line/1"},
      {R"({"tree_line": [0.5]})", "/material/tree_line"},
      {R"({"tree_line": [-0.1, 0.5]})", "/material/tree_line/0"},
      {R"({"rock_slope": [30, 91]})", "/material/rock_slope/1"},
      {R"({"rock_slope": [89.99999, 90]})", "/material/rock_slope/1"},
      {R"({"snow_line": "high"})", "/material/snow_line"},
      {R"({"snow_blend": 0})", "/material/snow_blend"},
      {R"({"snow_polar": 1e40})", "/material/snow_polar"},
  };
  for (const auto& c : cases) {
    json doc = json::parse(
        R"({"root": {"type": "disc", "center": [0, 0], "radius": 100, "elevation": 5}})");
    doc["material"] = json::parse(c.material);
    const Result<Scene> scene = parse_scene(doc);
    ASSERT_FALSE(scene) << c.material;
    EXPECT_EQ(scene.error().pointer, c.pointer) << c.material << ": " << scene.error().message;
  }
}

}  // namespace
}  // namespace terrain
