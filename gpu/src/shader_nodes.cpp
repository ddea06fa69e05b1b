// The shaders' node tables and dispatch, generated from the node registry (terrain::node_types()
// and each type's ShaderNode), so that a node type is declared once for every evaluator.
#include <cassert>
#include <cctype>
#include <string>
#include <string_view>

#include "gpu/program_glsl.hpp"
#include "terrain/fractal_layout.hpp"

namespace gpu {
namespace {

using terrain::NodeCategory;
using terrain::NodeType;

// "disc" → "Disc", "lod_blend" → "LodBlend": the GLSL constant's part of the name.
std::string camel(std::string_view name) {
  std::string out;
  bool upper = true;
  for (char c : name) {
    if (c == '_' || c == '-') {
      upper = true;
      continue;
    }
    out += upper ? static_cast<char>(std::toupper(static_cast<unsigned char>(c))) : c;
    upper = false;
  }
  return out;
}

std::string u(std::uint32_t v) {
  return std::to_string(v) + "u";
}

// `#if TERRAIN_USES_<NAME>` … `#endif` around one dispatch branch.
std::string guarded(const NodeType& type, const std::string& branch) {
  return "#if " + uses_define(type) + "\n" + branch + "#endif\n";
}

std::string type_test(const NodeType& type) {
  return "type == " + type_constant(type);
}

}  // namespace

std::string type_constant(const terrain::NodeType& type) {
  return "kType" + camel(type.name);
}

std::string uses_define(const terrain::NodeType& type) {
  std::string upper(type.name);
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return "TERRAIN_USES_" + upper;
}

std::string expand_shader_template(std::string_view text, const ShaderArguments& args) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '$') {
      out += text[i];
      continue;
    }
    std::size_t end = i + 1;
    while (end < text.size() && std::islower(static_cast<unsigned char>(text[end]))) ++end;
    const std::string_view name = text.substr(i + 1, end - i - 1);
    const std::string* value = name == "at"  ? &args.at
                               : name == "p" ? &args.point
                               : name == "s" ? &args.spacing
                               : name == "w" ? &args.weighted_only
                               : name == "a" ? &args.a
                               : name == "b" ? &args.b
                               : name == "f" ? &args.field
                               : name == "q" ? &args.child_point
                               : name == "t" ? &args.child_spacing
                               : name == "j" ? &args.jacobian
                                             : nullptr;
    assert(value != nullptr && !value->empty() && "a shader template names an unknown argument");
    if (value != nullptr) out += *value;
    i = end - 1;
  }
  return out;
}

std::string node_table_glsl() {
  std::string out =
      "// Generated from the node registry (gpu/src/shader_nodes.cpp): type ids, where fractals\n"
      "// lie in a node's parameters, and TERRAIN_USES_<TYPE> (1 unless a prelude sets it 0).\n";
  for (const NodeType* type : terrain::node_types()) {
    out += "const uint " + type_constant(*type) + " = " + u(type->id) + ";\n";
    if (type->shader.fractal_offset >= 0) {
      out += "const uint k" + camel(type->name) +
             "Fractal = " + u(static_cast<std::uint32_t>(type->shader.fractal_offset)) + ";\n";
    }
  }
  namespace layout = terrain::fractal_layout;
  for (const auto& [name, offset] : layout::kFields) {
    out += "const uint kFractal" + camel(name) + " = " + u(offset) + ";\n";
  }
  for (const NodeType* type : terrain::node_types()) {
    if (!type->shader.implemented()) continue;
    const std::string define = uses_define(*type);
    out += "#ifndef " + define + "\n#define " + define + " 1\n#endif\n";
  }
  return out;
}

std::string node_dispatch_glsl() {
  ShaderArguments args;
  args.at = "at";
  args.point = "p";
  args.spacing = "s";
  args.weighted_only = "weighted_only";
  args.a = "a";
  args.b = "b";
  args.field = "f";
  args.child_point = "q";
  args.child_spacing = "t";
  args.jacobian = "j";
  // Unsupported types are refused by the host before a program is run; NaN makes misuse loud.
  const std::string loud =
      "  float nan = uintBitsToFloat(0x7fc00000u);\n"
      "  return Field(nan, nan, nan, nan, nan, nan);\n";
  std::string leaf =
      "Field leaf_field(uint type, uint at, bool weighted_only, vec2 p, float s) {\n";
  std::string combine = "Field combine_fields(uint type, uint at, float s, Field a, Field b) {\n";
  std::string enter =
      "void enter_frame(uint type, uint at, vec2 p, float s, out vec2 q, out float t,\n"
      "                 out vec4 j) {\n"
      "  q = p;\n  t = s;\n  j = vec4(1.0, 0.0, 0.0, 1.0);\n";
  std::string leave = "Field leave_frame(uint type, uint at, vec4 j, Field f) {\n";
  for (const NodeType* type : terrain::node_types()) {
    const terrain::ShaderNode& shader = type->shader;
    if (!shader.implemented()) continue;
    switch (type->category) {
      case NodeCategory::primitive:
        leaf += guarded(*type, "  if (" + type_test(*type) + ") return " +
                                   expand_shader_template(shader.call, args) + ";\n");
        break;
      case NodeCategory::binary:
        combine += guarded(*type, "  if (" + type_test(*type) + ") return " +
                                      expand_shader_template(shader.call, args) + ";\n");
        break;
      case NodeCategory::warp:
        enter += guarded(*type, "  if (" + type_test(*type) + ") {\n    " +
                                    expand_shader_template(shader.enter, args) + "\n  }\n");
        leave += guarded(*type, "  if (" + type_test(*type) + ") return " +
                                    expand_shader_template(shader.leave, args) + ";\n");
        break;
      case NodeCategory::blend:
        assert(false && "blend is in every shader: it has no ShaderNode");
        break;
    }
  }
  return "// Generated from the node registry (gpu/src/shader_nodes.cpp): the interpreter's\n"
         "// dispatch over node types.\n#ifndef TERRAIN_SPECIALISED\n" +
         leaf + loud + "}\n\n" + combine + loud + "}\n\n" + enter + "}\n\n" + leave +
         "  return f;\n}\n#endif  // TERRAIN_SPECIALISED\n";
}

}  // namespace gpu
