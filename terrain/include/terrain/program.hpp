// The compiled form of a scene: a flat instruction stream plus a float parameter pool, walked
// without recursion by the CPU interpreter (the reference), the GPU compute shader and the
// browser's fragment shader. Layout: docs/program.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/field.hpp"
#include "terrain/result.hpp"
#include "terrain/scene.hpp"

namespace terrain {

enum class Op : std::uint16_t {
  leaf = 0,         ///< push the primitive's field
  blend_begin = 1,  ///< push an empty blend accumulator
  blend_add = 2,    ///< pop a field, add it to the accumulator on top
  blend_end = 3,    ///< turn the accumulator into the blend's field
  cull = 4,         ///< box at params: if the block misses it, push a zero-weight field, jump
  group = 5,        ///< box at params: if the block misses it, jump (a blend's BVH node)
  combine = 6,      ///< pop B, pop A, push the binary operator's field
  warp_begin = 7,   ///< push the child's coordinate frame
  warp_end = 8,     ///< pop the frame, map the field on top back to the parent frame
};

/// One instruction: 16 bytes, read as a uvec4 by the shaders.
struct Instruction {
  Op op = Op::leaf;
  std::uint16_t type = 0;    ///< node type id (NodeType::id) for leaf/combine/warp/blend
  std::uint32_t params = 0;  ///< offset of the node's parameters (or the cull/group box) in pool
  std::uint32_t skip = 0;    ///< cull/group: instructions to jump over when the box is missed;
                             ///< leaf: 1 when the parent ignores f wherever α = 0
  std::uint32_t node = 0;    ///< index of the source node (diagnostics)
};
static_assert(sizeof(Instruction) == 16);

struct Program {
  std::vector<Instruction> code;
  std::vector<float> pool;
  NodeBounds bounds;  ///< global bounds of the root
  float base_elevation = 0.0f;
  int max_field_depth = 0;  ///< field-stack slots the interpreter needs
  int max_frame_depth = 0;  ///< nested warps
  std::string scene_hash;

  /// A JSON description (the browser and tests read it; binary buffers are base64).
  nlohmann::json to_json() const;
};

struct CompileOptions {
  int blend_leaf_size = 4;  ///< children per BVH leaf in large blends
  bool concatenate_affine = true;
  bool cull = true;  ///< emit cull/group boxes (false: plain traversal)
  /// Box queries spent on the global Lipschitz bound (partitioned_lipschitz): more is tighter and
  /// slower (about 25 µs each on the mountain-range example, 0.3 s in all); 0 keeps the
  /// single-query bound.
  int bound_queries = 12288;
  /// At most this many instructions walked by those queries together, so a large scene's compile
  /// stays bounded (a query walks at most the whole program): fewer queries for longer programs.
  std::int64_t bound_instruction_budget = 4'000'000;
};

/// Where a blend child with this support (tree_bounds(child, {}).support) goes in its blend's
/// accumulation order: the compiler adds a blend's children in increasing key order, ties in
/// declaration order, with or without culling. A child's key depends on that child alone.
std::uint64_t blend_order_key(const Box2& support);

/// Flattens a scene's tree into a program. Fails only on limits (depth, size).
Result<Program> compile(const Scene& scene, const CompileOptions& options = {});
/// Compiles the scene's water layer (Scene::water, which must be present).
Result<Program> compile_water(const Scene& scene, const CompileOptions& options = {});

/// Standard base64 (RFC 4648, padded) of `size` bytes: how JSON carries binary buffers.
std::string base64(const void* data, std::size_t size);

}  // namespace terrain
