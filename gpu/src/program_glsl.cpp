#include "gpu/program_glsl.hpp"

#include "terrain/fractal_layout.hpp"

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

std::string_view type_name(std::uint16_t id) {
  const terrain::NodeType* node = terrain::node_type_by_id(id);
  return node ? node->name : std::string_view("unknown");
}

// The node type of an instruction the shaders implement, or null.
const terrain::NodeType* shader_node(const terrain::Instruction& ins) {
  return shader_implements(ins.op, ins.type) ? terrain::node_type_by_id(ins.type) : nullptr;
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
      switch (ins.op) {
        case Op::leaf: {
          const terrain::NodeType* node = shader_node(ins);
          if (node == nullptr) return unsupported(pc);
          ShaderArguments args;
          args.at = at;
          args.point = point;
          args.spacing = spacing;
          args.weighted_only = ins.skip != 0 ? "true" : "false";
          line(pad + field(sp) + " = " + expand_shader_template(node->shader.call, args) + ";");
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
          const terrain::NodeType* node = shader_node(ins);
          if (node == nullptr) return unsupported(pc);
          --sp;
          ShaderArguments args;
          args.at = at;
          args.spacing = spacing;
          args.a = field(sp - 1);
          args.b = field(sp);
          line(pad + args.a + " = " + expand_shader_template(node->shader.call, args) + ";");
          break;
        }
        case Op::warp_begin: {
          const terrain::NodeType* node = shader_node(ins);
          if (node == nullptr) return unsupported(pc);
          const std::string inner = std::to_string(fp + 1);
          ShaderArguments args;
          args.at = at;
          args.point = point;
          args.spacing = spacing;
          args.child_point = "p" + inner;
          args.child_spacing = "s" + inner;
          args.jacobian = "j" + inner;
          line(pad + expand_shader_template(node->shader.enter, args));
          ++fp;
          max_frames_ = std::max(max_frames_, fp + 1);
          break;
        }
        case Op::warp_end: {
          if (auto s = need(1); !s) return s.error();
          if (fp == 0) return malformed(pc, "ends a frame that was not begun");
          const terrain::NodeType* node = shader_node(ins);
          if (node == nullptr) return unsupported(pc);
          const std::string f = field(sp - 1);
          ShaderArguments args;
          args.at = at;
          args.field = f;
          args.jacobian = "j" + std::to_string(fp);
          line(pad + f + " = " + expand_shader_template(node->shader.leave, args) + ";");
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
      return node && node->category == NodeCategory::primitive && node->shader.implemented();
    case Op::combine:
      return node && node->category == NodeCategory::binary && node->shader.implemented();
    case Op::warp_begin:
    case Op::warp_end:
      return node && node->category == NodeCategory::warp && node->shader.implemented();
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
    const terrain::NodeType* node = terrain::node_type_by_id(ins.type);
    if ((ins.op == Op::leaf || ins.op == Op::warp_begin) && node != nullptr && node->shader.heavy) {
      ++calls;
    }
  }
  return calls <= kMaxInlinedCalls;
}

std::vector<std::uint32_t> fractal_offsets(const terrain::Program& program) {
  std::vector<std::uint32_t> out;
  for (const terrain::Instruction& ins : program.code) {
    // One instruction per node carries its parameters: the leaf, the combine, the warp's begin.
    if (ins.op != Op::leaf && ins.op != Op::combine && ins.op != Op::warp_begin) continue;
    const terrain::NodeType* node = terrain::node_type_by_id(ins.type);
    if (node != nullptr && node->shader.fractal_offset >= 0) {
      out.push_back(ins.params + static_cast<std::uint32_t>(node->shader.fractal_offset));
    }
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
  namespace layout = terrain::fractal_layout;
  for (const std::uint32_t at : fractal_offsets(program)) {
    if (at + layout::kFloats > program.pool.size() ||
        program.pool[at + layout::kAmplitude] == 0.0f) {
      continue;
    }
    const auto kind = std::bit_cast<std::uint32_t>(program.pool[at + layout::kKind]);
    const auto basis = std::bit_cast<std::uint32_t>(program.pool[at + layout::kBasis]);
    if (kind < 4) kinds[kind] = true;
    if (basis < 2) bases[basis] = true;
  }
  std::string out;
  auto define = [&out](const std::string& name, bool on) {
    out += "#define " + name + (on ? " 1\n" : " 0\n");
  };
  define("TERRAIN_USES_NOISE_FBM", kinds[0]);
  define("TERRAIN_USES_NOISE_RIDGED", kinds[1]);
  define("TERRAIN_USES_NOISE_HYBRID", kinds[2]);
  define("TERRAIN_USES_NOISE_WARPED", kinds[3]);
  define("TERRAIN_USES_NOISE_GRADIENT", bases[0]);
  define("TERRAIN_USES_NOISE_SIMPLEX", bases[1]);
  for (const terrain::NodeType* node : terrain::node_types()) {
    if (node->shader.implemented()) define(uses_define(*node), used.contains(node->id));
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
