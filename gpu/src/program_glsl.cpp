#include "gpu/program_glsl.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cctype>
#include <iterator>
#include <set>
#include <string_view>

namespace gpu {
namespace {

using terrain::Error;
using terrain::Op;

using terrain::NodeCategory;

// The node types gpu/glsl/nodes.glsl implements (besides blend, which every shader has), by
// their registry names; interpreter.glsl has a TERRAIN_USES_<NAME> switch for each.
constexpr std::string_view kShaderNodes[] = {"disc", "curve", "contour",   "image", "replace",
                                             "add",  "lod",   "transform", "warp"};

bool in_shaders(const terrain::NodeType& node) {
  return std::find(std::begin(kShaderNodes), std::end(kShaderNodes), node.name) !=
         std::end(kShaderNodes);
}

std::string_view type_name(std::uint16_t id) {
  const terrain::NodeType* node = terrain::node_type_by_id(id);
  return node ? node->name : std::string_view("unknown");
}

Error unsupported_node(const terrain::Instruction& ins) {
  return Error{"the GPU shaders do not implement node type '" + std::string(type_name(ins.type)) +
                   "' (id " + std::to_string(ins.type) + ", node " + std::to_string(ins.node) +
                   "); evaluate this program on the CPU",
               ""};
}

std::string u(std::uint32_t v) {
  return std::to_string(v) + "u";
}

// Emits instructions [begin, end) as GLSL statements. The interpreter's stacks become variables
// named by their (statically known) depth: field slot k is f<k>; coordinate frame k is the point
// p<k>, the sample spacing s<k> and, under a warp, the Jacobian j<k>.
class Emitter {
 public:
  explicit Emitter(const terrain::Program& program) : code_(program.code) {}

  // Returns the field depth after the range, or an error for a malformed stream.
  terrain::Result<int> range(std::size_t begin, std::size_t end, int sp, int fp, int indent) {
    for (std::size_t pc = begin; pc < end; ++pc) {
      const terrain::Instruction& ins = code_[pc];
      const std::string at = u(ins.params);
      const std::string pad(static_cast<std::size_t>(indent) * 2, ' ');
      const std::string point = "p" + std::to_string(fp);
      const std::string spacing = "s" + std::to_string(fp);
      auto field = [](int k) { return "f" + std::to_string(k); };
      auto need = [&](int depth) -> terrain::Status {
        if (sp < depth)
          return Error{"instruction " + std::to_string(pc) + " pops an empty stack", ""};
        return terrain::Ok{};
      };
      const std::string_view name = type_name(ins.type);
      switch (ins.op) {
        case Op::leaf: {
          std::string call;
          if (name == "disc") call = "disc_leaf(" + at + ", " + point + ", " + spacing + ")";
          if (name == "curve")
            call = "curve_leaf_field(" + at + ", " + point + ", " +
                   (ins.skip != 0 ? "true" : "false") + ")";
          if (name == "contour") call = "contour_leaf(" + at + ", " + point + ")";
          if (name == "image") call = "image_leaf(" + at + ", " + point + ")";
          if (call.empty()) return unsupported(pc);
          line(pad + field(sp) + " = " + call + ";");
          ++sp;
          break;
        }
        case Op::blend_begin:
          line(pad + field(sp) + " = field_zero();");
          ++sp;
          break;
        case Op::blend_add:
          if (auto s = need(2); !s) return s.error();
          --sp;
          line(pad + field(sp - 1) + " = blend_accumulate(" + field(sp - 1) + ", " + field(sp) +
               ");");
          break;
        case Op::blend_end:
          if (auto s = need(1); !s) return s.error();
          line(pad + field(sp - 1) + " = blend_finish(" + at + ", " + field(sp - 1) + ");");
          break;
        case Op::cull:
        case Op::group: {
          const std::size_t body_end = pc + 1 + ins.skip;
          if (body_end > end) return malformed(pc, "jumps past its enclosing range");
          line(pad + "if (box_contains(" + at + ", " + point + ")) {");
          terrain::Result<int> after = range(pc + 1, body_end, sp, fp, indent + 1);
          if (!after) return after.error();
          // A culled subtree pushes one field; a blend's BVH group leaves the stack as it was.
          if (*after != sp + (ins.op == Op::cull ? 1 : 0)) {
            return malformed(pc, "skips a range that does not keep the stack balanced");
          }
          if (ins.op == Op::cull) {
            line(pad + "} else {");
            line(pad + "  " + field(sp) + " = field_zero();");
            ++sp;
          }
          line(pad + "}");
          pc = body_end - 1;
          break;
        }
        case Op::combine: {
          if (auto s = need(2); !s) return s.error();
          --sp;
          const std::string a = field(sp - 1), b = field(sp);
          std::string call;
          if (name == "replace") call = "replace_combine(" + at + ", " + a + ", " + b + ")";
          if (name == "add") call = "add_combine(" + at + ", " + a + ", " + b + ")";
          if (name == "lod")
            call = "lod_combine(" + at + ", " + spacing + ", " + a + ", " + b + ")";
          if (call.empty()) return unsupported(pc);
          line(pad + a + " = " + call + ";");
          break;
        }
        case Op::warp_begin: {
          const std::string inner = std::to_string(fp + 1);
          if (name == "transform") {
            line(pad + "p" + inner + " = transform_point(" + at + ", " + point + ");");
            line(pad + "s" + inner + " = transform_spacing(" + at + ", " + spacing + ");");
          } else if (name == "warp") {
            line(pad + "p" + inner + " = warp_point(" + at + ", " + point + ", " + spacing + ", j" +
                 inner + ");");
            line(pad + "s" + inner + " = " + spacing + ";");
          } else {
            return unsupported(pc);
          }
          ++fp;
          max_frames_ = std::max(max_frames_, fp + 1);
          break;
        }
        case Op::warp_end: {
          if (auto s = need(1); !s) return s.error();
          if (fp == 0) return malformed(pc, "ends a frame that was not begun");
          const std::string f = field(sp - 1);
          if (name == "transform") {
            line(pad + f + " = transform_field(" + at + ", " + f + ");");
          } else if (name == "warp") {
            line(pad + f + " = warp_field(j" + std::to_string(fp) + ", " + f + ");");
          } else {
            return unsupported(pc);
          }
          --fp;
          break;
        }
        default:
          return malformed(pc, "has an unknown op");
      }
      max_fields_ = std::max(max_fields_, sp);
    }
    return sp;
  }

  std::string body;
  int max_fields_ = 0;
  int max_frames_ = 1;

 private:
  void line(const std::string& text) {
    body += "  ";
    body += text;
    body += '\n';
  }
  Error unsupported(std::size_t pc) const { return unsupported_node(code_[pc]); }
  Error malformed(std::size_t pc, const char* what) const {
    return Error{"instruction " + std::to_string(pc) + " " + what, ""};
  }

  const std::vector<terrain::Instruction>& code_;
};

}  // namespace

bool shader_implements(Op op, std::uint16_t type) {
  const terrain::NodeType* node = terrain::node_type_by_id(type);
  switch (op) {
    case Op::leaf:
      return node && node->category == NodeCategory::primitive && in_shaders(*node);
    case Op::combine:
      return node && node->category == NodeCategory::binary && in_shaders(*node);
    case Op::warp_begin:
    case Op::warp_end:
      return node && node->category == NodeCategory::warp && in_shaders(*node);
    case Op::blend_begin:
    case Op::blend_add:
    case Op::blend_end:
    case Op::cull:
    case Op::group:
      return true;
  }
  return false;
}

bool unroll_pays(const terrain::Program& program) {
  constexpr int kMaxInlinedCalls = 16;
  int calls = 0;
  for (const terrain::Instruction& ins : program.code) {
    if (ins.op == Op::leaf || (ins.op == Op::warp_begin && type_name(ins.type) == "warp")) ++calls;
  }
  return calls <= kMaxInlinedCalls;
}

std::vector<std::uint32_t> fractal_offsets(const terrain::Program& program) {
  std::vector<std::uint32_t> out;
  for (const terrain::Instruction& ins : program.code) {
    const std::string_view name = type_name(ins.type);
    if (ins.op == Op::leaf && name == "disc") out.push_back(ins.params + 4);
    if (ins.op == Op::warp_begin && name == "warp") out.push_back(ins.params);
  }
  return out;
}

std::string node_type_defines(const terrain::Program& program) {
  std::set<std::uint16_t> used;
  for (const terrain::Instruction& ins : program.code) used.insert(ins.type);
  // Fractal kinds (0 fbm, 1 ridged, 2 hybrid, 3 warped) and bases (0 gradient, 1 simplex), as
  // terrain::pack_fractal stores their bits.
  bool kinds[4] = {false, false, false, false}, bases[2] = {false, false};
  // A fractal of amplitude 0 (a plain disc) adds nothing whatever its kind: not counted.
  for (const std::uint32_t at : fractal_offsets(program)) {
    if (at + 6 > program.pool.size() || program.pool[at + 5] == 0.0f) continue;
    const auto kind = std::bit_cast<std::uint32_t>(program.pool[at]);
    const auto basis = std::bit_cast<std::uint32_t>(program.pool[at + 1]);
    if (kind < 4) kinds[kind] = true;
    if (basis < 2) bases[basis] = true;
  }
  std::string out;
  auto define = [&out](std::string_view name, bool on) {
    out += "#define TERRAIN_USES_" + std::string(name) + (on ? " 1\n" : " 0\n");
  };
  define("NOISE_FBM", kinds[0]);
  define("NOISE_RIDGED", kinds[1]);
  define("NOISE_HYBRID", kinds[2]);
  define("NOISE_WARPED", kinds[3]);
  define("NOISE_GRADIENT", bases[0]);
  define("NOISE_SIMPLEX", bases[1]);
  for (std::string_view name : kShaderNodes) {
    const terrain::NodeType* node = terrain::find_node_type(name);
    assert(node != nullptr);
    std::string upper(name);
    for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    define(upper, used.contains(node->id));
  }
  return out;
}

terrain::Status shaders_implement(const terrain::Program& program) {
  for (std::size_t pc = 0; pc < program.code.size(); ++pc) {
    const terrain::Instruction& ins = program.code[pc];
    if (static_cast<std::uint16_t>(ins.op) > static_cast<std::uint16_t>(Op::warp_end)) {
      return Error{"instruction " + std::to_string(pc) + " has an unknown op", ""};
    }
    if (!shader_implements(ins.op, ins.type)) return unsupported_node(ins);
  }
  if (program.code.empty()) return Error{"the program is empty", ""};
  return terrain::Ok{};
}

terrain::Result<std::string> specialised_program_glsl(const terrain::Program& program) {
  if (terrain::Status s = shaders_implement(program); !s) return s.error();
  Emitter emitter(program);
  terrain::Result<int> depth = emitter.range(0, program.code.size(), 0, 0, 0);
  if (!depth) return depth.error();
  if (*depth != 1) return Error{"the program does not leave exactly one field", ""};
  // Nothing version-specific (no hash, no parameter value) goes in: equal structures share a
  // shader.
  std::string out = "// The program's " + std::to_string(program.code.size()) +
                    " instructions, unrolled (gpu/program_glsl.hpp).\n";
  out += "Field evaluate_program(vec2 p0, float s0) {\n";
  for (int k = 0; k < emitter.max_fields_; ++k) out += "  Field f" + std::to_string(k) + ";\n";
  for (int k = 1; k < emitter.max_frames_; ++k) {
    out += "  vec2 p" + std::to_string(k) + ";\n  float s" + std::to_string(k) + ";\n  vec4 j" +
           std::to_string(k) + ";\n";
  }
  out += emitter.body;
  out += "  return f0;\n}\n";
  return out;
}

}  // namespace gpu
