// Node types (primitives and operators) and the registry that describes them. One registry entry
// drives parsing, canonical serialisation, compilation, the CPU kernels, documentation examples,
// tests and benchmarks: a node type is added in one place.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/field.hpp"
#include "terrain/result.hpp"

namespace terrain {

/// How a node combines with its children; the interpreter has one code path per category.
enum class NodeCategory : std::uint8_t {
  primitive,  ///< a leaf: f and α from its own parameters
  blend,      ///< n-ary blend (Génevaux §5.1), accumulated child by child
  binary,     ///< combines A and B (replace, add, LoD)
  warp,       ///< unary: evaluates its child in warped coordinates
};

/// Per-point Jacobian of a warp q(p), kept while its child runs: ∂q/∂p, row-major.
struct WarpJacobian {
  alignas(64) float xx[kBlockSize];
  alignas(64) float xy[kBlockSize];
  alignas(64) float yx[kBlockSize];
  alignas(64) float yy[kBlockSize];
};

/// CPU kernels of a node type. Each reads its parameters from the program's float pool. Only the
/// members of the node's category are set.
/// varies_with_spacing of primitives whose field never depends on the sample spacing.
inline bool never_varies_with_spacing(const float*, float, float) {
  return false;
}

struct NodeKernels {
  // primitive
  void (*leaf)(const float* params, const PointBlock& points, FieldBlock& out) = nullptr;
  NodeBounds (*leaf_bounds)(const float* params, const BoundsQuery& query) = nullptr;
  /// Optional: the same where the parent ignores f wherever α = 0 (blend children, the B side of
  /// replace/add), so f may be left arbitrary (finite) there and its work skipped. Returns false,
  /// leaving `out` unwritten, when α = 0 at every point: the interpreter then treats the leaf as
  /// culled for this block.
  bool (*leaf_where_weighted)(const float* params, const PointBlock& points,
                              FieldBlock& out) = nullptr;
  /// Optional: a bound of |∇α| within `radius` of a point where α = `weight`, for primitives
  /// whose weight falls off with a distance that leaf_bounds cannot bound over a box.
  float (*weight_lipschitz_near)(const float* params, float weight, float radius) = nullptr;
  /// Optional: whether the leaf's field may differ between two sample spacings (bounds over a
  /// band of spacings then skip the sample at the box centre). Without it, both are sampled.
  bool (*varies_with_spacing)(const float* params, float fine, float coarse) = nullptr;
  // binary: `out` may alias `a`
  void (*combine)(const float* params, const PointBlock& points, const FieldBlock& a,
                  const FieldBlock& b, FieldBlock& out) = nullptr;
  NodeBounds (*combine_bounds)(const float* params, const BoundsQuery& query, const NodeBounds& a,
                               const NodeBounds& b) = nullptr;
  // warp: map points into the child's frame, then map the child's field back
  void (*warp_points)(const float* params, const PointBlock& in, PointBlock& out,
                      WarpJacobian& jacobian) = nullptr;
  void (*warp_field)(const float* params, int count, const WarpJacobian& jacobian,
                     FieldBlock& field) = nullptr;
  /// The child-frame box holding the points of the parent's query box, at its level of detail.
  Box2 (*warp_box)(const float* params, const BoundsQuery& query) = nullptr;
  /// The node's bounds over the parent's `query` from its child's (over warp_box of it).
  NodeBounds (*warp_bounds)(const float* params, const BoundsQuery& query,
                            const NodeBounds& child) = nullptr;
  /// parent sample spacing → child sample spacing (nullptr: unchanged)
  float (*warp_spacing)(const float* params, float spacing) = nullptr;
};

struct ParseContext;

/// The parameters of one parsed node: packed floats for the evaluators, and the canonical JSON
/// of its own fields (defaults made explicit), which serialisation writes back.
struct NodeParams {
  std::vector<float> pool;
  nlohmann::json canonical = nlohmann::json::object();
};

/// Reads node-specific fields. `reader` has already consumed "type", "id" and "children".
class FieldReader;
using NodeParser = Result<NodeParams> (*)(FieldReader& reader, ParseContext& context);

/// Upper bounds of the loops inside the GPU shaders' kernels, which per-node loop costs count: the
/// fractal octave loop (at most 24 octaves, plus one) and a profile's binary search.
inline constexpr std::size_t kShaderOctaveLoops = 25;
inline constexpr std::size_t kShaderSearchLoops = 16;

/// The loop iterations one evaluation of a node runs inside its kernels (not counting the one per
/// instruction), an upper estimate, from its compiled parameters: `params` holds the program's
/// pool from the node's first float on. Evaluators whose loops are capped (llvmpipe ends every
/// loop of an invocation after 65 535 iterations in all) split or refuse work by it.
using LoopCost = std::size_t (*)(std::span<const float> params);

/// A node type's side in the GPU shaders: GLSL that calls its function of gpu/glsl/nodes.glsl,
/// from which the shaders' type ids, TERRAIN_USES_* switches, the interpreter's dispatch and the
/// unrolled programs are generated (gpu/program_glsl.hpp). Placeholders the generator fills in:
/// `$at` the node's pool offset (uint); `$p`, `$s` the point (vec2) and sample spacing (float)
/// of the node's frame; `$w` whether its parent ignores f where α = 0 (bool); `$a`, `$b` a
/// binary node's children's fields; `$f` a warp's child field; `$q`, `$t`, `$j` the child
/// frame's point, spacing and Jacobian (vec4) that a warp's `enter` sets. Blend is in every
/// shader and has none. A node type without it runs on the CPU only.
struct ShaderNode {
  std::string_view call = {};   ///< primitive, binary: a Field expression
  std::string_view enter = {};  ///< warp: statements that set $q, $t and, for a warp, $j
  std::string_view leave = {};  ///< warp: the Field expression of the parent's field from $f
  /// Where the node's fractal (pack_fractal's kFractalFloats floats) starts in its pool, or -1.
  int fractal_offset = -1;
  /// Whether its call is a large body to inline (a leaf, a noise warp): the driver's compile time
  /// grows faster than the code, so gpu::unroll_pays counts these calls.
  bool heavy = false;

  bool implemented() const { return !call.empty() || !enter.empty(); }
};

/// Static description of a node type.
struct NodeType {
  std::uint16_t id = 0;   ///< stable opcode shared by every evaluator (never reused)
  std::string_view name;  ///< the JSON "type"
  NodeCategory category = NodeCategory::primitive;
  std::uint16_t min_children = 0;
  std::uint16_t max_children = 0;  ///< 0xffff = unbounded
  /// Binary operators whose B child acts only through its weight (replace, add): B may be culled
  /// where it has none. Not so for lod, which interpolates both children regardless.
  bool second_child_acts_by_weight = false;
  std::string_view summary;  ///< one line for docs and --help
  NodeParser parse = nullptr;
  NodeKernels kernels;
  /// A small complete example of this node (children included) for docs, tests and benchmarks.
  std::string_view example_json;
  /// Its loop iterations per evaluation; every node type has one (no_loops where there are none).
  LoopCost loop_iterations = nullptr;
  /// How the GPU shaders evaluate it.
  ShaderNode shader = {};
};

/// The loop cost of a node type whose kernels have no loops of their own.
std::size_t no_loops(std::span<const float> params);

/// The count stored at params[i] by a node's parser (0 where absent or not a positive number).
inline std::size_t pool_count(std::span<const float> params, std::size_t i) {
  return i < params.size() && params[i] > 0.0f && params[i] < 1e9f
             ? static_cast<std::size_t>(params[i])
             : std::size_t{0};
}

/// Every node type, in opcode order.
std::span<const NodeType* const> node_types();
/// "primitive", "blend", "binary" or "warp": how the CLI and the HTTP API name a category.
std::string_view category_name(NodeCategory category);
/// The node type with this JSON name, or nullptr.
const NodeType* find_node_type(std::string_view name);
/// The node type with this id (an instruction's `type`), or nullptr. A table lookup: the
/// evaluators call it per instruction.
const NodeType* node_type_by_id(std::uint16_t id);

/// A node of a parsed scene tree. Subtrees may be shared (instancing): the tree is a DAG.
struct Node {
  const NodeType* type = nullptr;
  std::string id;  ///< optional user label
  NodeParams params;
  std::vector<std::shared_ptr<const Node>> children;
};
using NodePtr = std::shared_ptr<const Node>;

}  // namespace terrain
