// The shaders' node tables and dispatch come from the registry (no GPU needed): every node type
// the shaders implement has its id constant, its switch, its dispatch branch and a GLSL function
// behind its template, and nothing in the hand-written GLSL lists node types beside them.
#include <gtest/gtest.h>

#include <cctype>
#include <regex>
#include <string>

#include "gpu/evaluator.hpp"
#include "gpu/program_glsl.hpp"
#include "terrain/fractal_layout.hpp"
#include "terrain/node.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"

namespace gpu {
namespace {

std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) {
    ++n;
  }
  return n;
}

// The GLSL functions a template calls: identifiers followed by '('.
std::vector<std::string> called_functions(std::string_view text) {
  std::vector<std::string> out;
  const std::string s(text);
  const std::regex call(R"(([A-Za-z_][A-Za-z_0-9]*)\s*\()");
  for (auto it = std::sregex_iterator(s.begin(), s.end(), call); it != std::sregex_iterator();
       ++it) {
    out.push_back((*it)[1]);
  }
  return out;
}

ShaderArguments all_arguments() {
  ShaderArguments a;
  a.at = "AT";
  a.point = "P";
  a.spacing = "S";
  a.weighted_only = "W";
  a.a = "A";
  a.b = "B";
  a.field = "F";
  a.child_point = "Q";
  a.child_spacing = "T";
  a.jacobian = "J";
  return a;
}

TEST(ShaderNodes, EveryNodeTypeHasItsIdConstantOnceInTheSharedGlsl) {
  const std::string glsl(shared_glsl());
  for (const terrain::NodeType* type : terrain::node_types()) {
    const std::string constant =
        "const uint " + type_constant(*type) + " = " + std::to_string(type->id) + "u;";
    EXPECT_EQ(occurrences(glsl, constant), 1u) << constant;
    // No other declaration of the same name (a hand-written copy with another id).
    EXPECT_EQ(occurrences(glsl, "const uint " + type_constant(*type) + " "), 1u) << type->name;
  }
}

TEST(ShaderNodes, EachImplementedTypeHasASwitchADispatchBranchAndItsFunctions) {
  const std::string glsl(shared_glsl());
  for (const terrain::NodeType* type : terrain::node_types()) {
    SCOPED_TRACE(std::string(type->name));
    const terrain::ShaderNode& shader = type->shader;
    if (type->category == terrain::NodeCategory::blend) {
      EXPECT_FALSE(shader.implemented()) << "blend is in every shader; it has no template";
      continue;
    }
    if (!shader.implemented()) continue;  // runs on the CPU only
    EXPECT_EQ(occurrences(glsl, "#ifndef " + uses_define(*type) + "\n"), 1u);
    EXPECT_GE(occurrences(glsl, "#if " + uses_define(*type) + "\n"), 1u);
    EXPECT_GE(occurrences(glsl, "type == " + type_constant(*type)), 1u);
    const bool warp = type->category == terrain::NodeCategory::warp;
    EXPECT_EQ(shader.call.empty(), warp) << "primitives and binaries have a call, warps none";
    EXPECT_EQ(shader.enter.empty(), !warp);
    EXPECT_EQ(shader.leave.empty(), !warp);
    for (std::string_view text : {shader.call, shader.enter, shader.leave}) {
      const std::string expanded = expand_shader_template(text, all_arguments());
      EXPECT_EQ(expanded.find('$'), std::string::npos) << expanded;
      for (const std::string& function : called_functions(text)) {
        const std::regex definition("\\n[A-Za-z0-9_]+ " + function + "\\(");
        EXPECT_TRUE(std::regex_search(glsl, definition))
            << function << " is not defined in the shared GLSL";
      }
    }
  }
}

TEST(ShaderNodes, TemplatesExpandTheirPlaceholdersAndNothingElse) {
  EXPECT_EQ(expand_shader_template("disc_leaf($at, $p, $s)", all_arguments()),
            "disc_leaf(AT, P, S)");
  EXPECT_EQ(expand_shader_template("$q = warp_point($at, $p, $s, $j); $t = $s;", all_arguments()),
            "Q = warp_point(AT, P, S, J); T = S;");
  EXPECT_EQ(expand_shader_template("lod_combine($at, $s, $a, $b)", all_arguments()),
            "lod_combine(AT, S, A, B)");
}

TEST(ShaderNodes, TheFractalLayoutReachesTheGlslFromItsOneDeclaration) {
  const std::string glsl(shared_glsl());
  for (const auto& [name, offset] : terrain::fractal_layout::kFields) {
    std::string camel;
    bool upper = true;
    for (char c : name) {
      if (c == '_') {
        upper = true;
        continue;
      }
      camel += upper ? static_cast<char>(std::toupper(static_cast<unsigned char>(c))) : c;
      upper = false;
    }
    const std::string constant =
        "const uint kFractal" + camel + " = " + std::to_string(offset) + "u;";
    EXPECT_EQ(occurrences(glsl, constant), 1u) << constant;
    EXPECT_GE(occurrences(glsl, "at + kFractal" + camel + ")"), 1u)
        << "read_fractal reads " << name;
  }
  for (const terrain::NodeType* type : terrain::node_types()) {
    if (type->shader.fractal_offset < 0) continue;
    // kTypeDisc → kDiscFractal: the node's GLSL reads its fractal where its parser packed it.
    const std::string constant = "k" + type_constant(*type).substr(5) + "Fractal";
    EXPECT_EQ(occurrences(glsl, "const uint " + constant + " = " +
                                    std::to_string(type->shader.fractal_offset) + "u;"),
              1u)
        << constant;
    EXPECT_GE(occurrences(glsl, "read_fractal(at + " + constant + ")"), 1u) << constant;
  }
}

TEST(ShaderNodes, DefinesSwitchOnExactlyTheProgramsNodeTypes) {
  auto scene = terrain::parse_scene_text(
      R"({"extent": {"min": [-10, -10], "max": [10, 10]}, "root": {"type": "transform",
          "translate": [1, 2], "children": [{"type": "disc", "center": [0, 0], "radius": 5,
          "elevation": 3}]}})");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto program = terrain::compile(*scene);
  ASSERT_TRUE(program.ok()) << program.error().message;
  const std::string defines = node_type_defines(*program);
  for (const terrain::NodeType* type : terrain::node_types()) {
    if (!type->shader.implemented()) continue;
    const bool used = type->name == "disc" || type->name == "transform";
    EXPECT_EQ(occurrences(defines, "#define " + uses_define(*type) + (used ? " 1" : " 0")), 1u)
        << type->name;
  }
}

}  // namespace
}  // namespace gpu
