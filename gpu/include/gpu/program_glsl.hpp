// Program-specialised GLSL: one compiled program's instruction stream unrolled into a
// straight-line evaluate_program that calls the shared node functions (gpu/glsl/nodes.glsl) with
// the parameter offsets as constants. The interpreter fetches and dispatches every instruction at
// run time, which GPUs pay for in registers and divergence, and which software rasterizers
// (llvmpipe, SwiftShader) pay for by running every node type's code at every instruction; the
// specialised function runs only the program's own nodes. Parameters are still read from the
// pool, so versions that differ only in parameter values share one shader.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "terrain/node.hpp"
#include "terrain/program.hpp"
#include "terrain/result.hpp"

namespace gpu {

/// The GLSL constant of a node type's id (`kTypeDisc`) and its TERRAIN_USES_<TYPE> switch.
std::string type_constant(const terrain::NodeType& type);
std::string uses_define(const terrain::NodeType& type);

/// What a node's shader templates (terrain::ShaderNode) are filled in with: GLSL expressions.
struct ShaderArguments {
  std::string at, point, spacing, weighted_only, a, b, field, child_point, child_spacing, jacobian;
};

/// A ShaderNode template with its `$` placeholders replaced by `args`.
std::string expand_shader_template(std::string_view text, const ShaderArguments& args);

/// Generated from the registry, put before the shared GLSL: every node type's id constant, the
/// pool offset of its fractal (`k<Type>Fractal`), the fractal layout (`kFractal<Field>`), and
/// the default (1) of every TERRAIN_USES_<TYPE> the shaders implement.
std::string node_table_glsl();

/// Generated from the registry, put after the node functions: the interpreter's dispatch over
/// node types (leaf_field, combine_fields, enter_frame, leave_frame), each branch under its
/// TERRAIN_USES_<TYPE>; left out under TERRAIN_SPECIALISED.
std::string node_dispatch_glsl();

/// Whether the shaders implement node type `type` for instructions of kind `op`.
bool shader_implements(terrain::Op op, std::uint16_t type);

/// Whether the shaders can run the program: the error names the first instruction they cannot
/// (an unknown op, or a node type they do not implement), or says the program is empty.
terrain::Status shaders_implement(const terrain::Program& program);

/// Whether unrolling this program pays: it does for small programs (on llvmpipe 5–13 times the
/// pruned interpreter's speed on the small examples), but every leaf and warp is inlined, and
/// drivers' compile time grows faster than the code (llvmpipe: 10 warped, transformed discs
/// 32 s, 20 of them 144 s). True for at most 16 leaf and warp instructions.
bool unroll_pays(const terrain::Program& program);

/// Pool offsets of the program's fractals (terrain::pack_fractal's 16 floats): a disc's after its
/// 4 floats, a warp's at its start.
std::vector<std::uint32_t> fractal_offsets(const terrain::Program& program);

/// `#define TERRAIN_USES_<TYPE> 0|1` for every node type the shaders implement, and
/// `TERRAIN_USES_NOISE_<KIND>` for every fractal kind and noise basis: 1 where the program uses
/// it. Put before the shared GLSL, the interpreter and the fractal loop leave out the others'
/// code. Fractal kinds are parameters, so a version that changes one gets other defines.
std::string node_type_defines(const terrain::Program& program);

/// The GLSL definition of `Field evaluate_program(vec2 p, float spacing)` for this program, to
/// follow the shared GLSL compiled with `#define TERRAIN_SPECIALISED` (which leaves out the
/// interpreter's own definition and declares its prototype). It computes exactly what the
/// interpreter computes: the same node functions in the same order on the same values. An error
/// names the first instruction the shaders do not implement, or a malformed instruction stream.
terrain::Result<std::string> specialised_program_glsl(const terrain::Program& program);

}  // namespace gpu
