#include <openssl/evp.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>

#include "nodes/transform.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"

namespace terrain {
namespace {

// A coordinate on a fixed lattice of 1/16 m about the origin, offset to be unsigned. The lattice
// does not depend on the other children (unlike a median split of their bounding box would).
std::uint32_t lattice_coordinate(float v) {
  if (!std::isfinite(v)) v = 0.0f;  // an unbounded or empty support has no meaningful centre
  const double q =
      std::clamp(std::floor(static_cast<double>(v) * 16.0), -2147483648.0, 2147483647.0);
  return static_cast<std::uint32_t>(static_cast<std::int64_t>(q) + 2147483648ll);
}

}  // namespace

// The position along a Hilbert curve of the support's centre, on a fixed lattice. Float sums
// depend on the order of their terms, so the order of any two children must depend on those two
// alone: then adding, removing or editing one child never reorders the others, and an edit changes
// no bit where the edited child has no weight (what tile invalidation, scene_diff.hpp, relies
// on). A Hilbert curve (rather than a Morton code) keeps runs of consecutive keys compact, which
// is what the BVH over halves of that order needs.
std::uint64_t blend_order_key(const Box2& support) {
  const Vec2 c = support.center();
  std::uint64_t x = lattice_coordinate(c.x), y = lattice_coordinate(c.y);
  std::uint64_t key = 0;
  for (std::uint64_t s = std::uint64_t{1} << 31; s > 0; s >>= 1) {
    const std::uint64_t rx = (x & s) != 0 ? 1 : 0, ry = (y & s) != 0 ? 1 : 0;
    key += s * s * ((3 * rx) ^ ry);
    if (ry == 0) {  // rotate the quadrant (the bits above s no longer matter)
      if (rx == 1) {
        x = ~x;
        y = ~y;
      }
      std::swap(x, y);
    }
  }
  return key;
}

namespace {

class Compiler {
 public:
  explicit Compiler(const CompileOptions& options) : options_(options) {}

  Result<Program> run(const Scene& scene, const Node& root, const NodeBounds& bounds,
                      const char* pointer) {
    program_.base_elevation = scene.base_elevation;
    program_.scene_hash = scene.hash;
    program_.bounds = bounds;
    emit(root, /*cullable=*/false);
    program_.max_field_depth = max_depth_;
    program_.max_frame_depth = max_frames_;
    if (program_.pool.size() > scene_limits_.max_pool_floats) {
      return Error{"the compiled scene needs " + std::to_string(program_.pool.size()) +
                       " parameters, more than the limit",
                   pointer};
    }
    return std::move(program_);
  }

 private:
  std::uint32_t params_of(const Node& node) {
    auto [it, inserted] = param_offsets_.try_emplace(&node, 0);
    if (inserted) {
      it->second = static_cast<std::uint32_t>(program_.pool.size());
      program_.pool.insert(program_.pool.end(), node.params.pool.begin(), node.params.pool.end());
    }
    return it->second;
  }

  std::uint32_t push_box(const Box2& box) {
    const auto offset = static_cast<std::uint32_t>(program_.pool.size());
    program_.pool.insert(program_.pool.end(), {box.lo.x, box.lo.y, box.hi.x, box.hi.y});
    return offset;
  }

  const NodeBounds& bounds_of(const Node& node) {
    auto it = bounds_.find(&node);
    if (it == bounds_.end()) it = bounds_.emplace(&node, tree_bounds(node, {})).first;
    return it->second;
  }

  std::size_t push(Op op, const Node& node, std::uint32_t params) {
    program_.code.push_back(
        {op, node.type->id, params, 0, static_cast<std::uint32_t>(node_index(node))});
    return program_.code.size() - 1;
  }

  std::size_t node_index(const Node& node) {
    auto [it, inserted] = node_ids_.try_emplace(&node, node_ids_.size());
    return it->second;
  }

  void patch_skip(std::size_t at) {
    program_.code[at].skip = static_cast<std::uint32_t>(program_.code.size() - at - 1);
  }

  void grow(int delta) {
    depth_ += delta;
    max_depth_ = std::max(max_depth_, depth_);
  }

  // `cullable`: the parent ignores this subtree where its weight is zero (blend children and the
  // B side of replace/add), so a box test may skip it.
  void emit(const Node& node, bool cullable) {
    std::size_t cull_at = 0;
    if (cullable && options_.cull) {
      cull_at = push(Op::cull, node, push_box(bounds_of(node).support));
    }
    switch (node.type->category) {
      case NodeCategory::primitive:
        program_.code[push(Op::leaf, node, params_of(node))].skip = cullable ? 1u : 0u;
        grow(+1);
        break;
      case NodeCategory::blend: {
        const std::uint32_t params = params_of(node);
        push(Op::blend_begin, node, params);
        grow(+1);
        std::vector<const Node*> children;
        for (const NodePtr& child : node.children) children.push_back(child.get());
        // Accumulated in the order of a per-child key (the support's centre along a Hilbert
        // curve), the same with or without culling; the BVH splits that order into halves.
        std::vector<std::uint64_t> keys;
        for (const Node* child : children)
          keys.push_back(blend_order_key(bounds_of(*child).support));
        std::vector<std::size_t> order(children.size());
        for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
        std::stable_sort(order.begin(), order.end(),
                         [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
        std::vector<const Node*> sorted;
        for (std::size_t i : order) sorted.push_back(children[i]);
        emit_blend_children(sorted);
        push(Op::blend_end, node, params);
        break;
      }
      case NodeCategory::binary: {
        emit(*node.children[0], false);
        emit(*node.children[1], node.type->second_child_acts_by_weight);
        push(Op::combine, node, params_of(node));
        grow(-1);
        break;
      }
      case NodeCategory::warp:
        emit_warp(node, cullable);
        break;
    }
    if (cullable && options_.cull) patch_skip(cull_at);
  }

  void emit_warp(const Node& node, bool cullable) {
    const Node* child = node.children[0].get();
    std::uint32_t params = params_of(node);
    if (options_.concatenate_affine && node.type->name == "transform" &&
        child->type->name == "transform") {
      AffineParams combined = AffineParams::unpack(node.params.pool.data());
      while (child->type->name == "transform") {
        combined = compose(combined, AffineParams::unpack(child->params.pool.data()));
        child = child->children[0].get();
      }
      params = static_cast<std::uint32_t>(program_.pool.size());
      combined.pack(program_.pool);
    }
    push(Op::warp_begin, node, params);
    ++frames_;
    max_frames_ = std::max(max_frames_, frames_);
    emit(*child, cullable);
    --frames_;
    push(Op::warp_end, node, params);
  }

  // Blend children, already in accumulation order, grouped in a BVH of `group` boxes over
  // halves of that order (consecutive Hilbert keys lie near each other): a block visits only the
  // children whose support it touches. Skipping a child with no weight adds nothing, and the
  // grouping keeps the order, so it never changes a bit of the result.
  void emit_blend_children(const std::vector<const Node*>& children) {
    if (!options_.cull || static_cast<int>(children.size()) <= options_.blend_leaf_size) {
      for (const Node* child : children) {
        emit(*child, true);
        push(Op::blend_add, *child, 0);
        grow(-1);
      }
      return;
    }
    const auto half = static_cast<std::ptrdiff_t>(children.size() / 2);
    const std::vector<const Node*> parts[2] = {{children.begin(), children.begin() + half},
                                               {children.begin() + half, children.end()}};
    for (const auto& part : parts) {
      Box2 box;
      for (const Node* c : part) box = box.united(bounds_of(*c).support);
      const std::size_t at = push(Op::group, *part.front(), push_box(box));
      emit_blend_children(part);
      patch_skip(at);
    }
  }

  const CompileOptions& options_;
  SceneLimits scene_limits_;
  Program program_;
  std::map<const Node*, std::uint32_t> param_offsets_;
  std::map<const Node*, NodeBounds> bounds_;
  std::map<const Node*, std::size_t> node_ids_;
  int depth_ = 0, max_depth_ = 0, frames_ = 0, max_frames_ = 0;
};

nlohmann::json bounds_json(const NodeBounds& b) {
  return {{"support", {b.support.lo.x, b.support.lo.y, b.support.hi.x, b.support.hi.y}},
          {"elevation", {b.elevation.lo, b.elevation.hi}},
          {"elevation_lipschitz", b.elevation_lipschitz},
          {"weight_lipschitz", b.weight_lipschitz}};
}

}  // namespace

std::string base64(const void* data, std::size_t size) {
  std::string out(4 * ((size + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                static_cast<const unsigned char*>(data), static_cast<int>(size));
  out.resize(static_cast<std::size_t>(n));
  return out;
}

Result<Program> compile(const Scene& scene, const CompileOptions& options) {
  if (!scene.baked) {
    return Error{"the scene was parsed without baking its grids and cannot be compiled", "",
                 ErrorKind::internal};
  }
  Compiler compiler(options);
  Result<Program> program = compiler.run(scene, *scene.root, scene.bounds, "/root");
  if (program && options.bound_queries > 0) {
    // The bound over the whole plane adds up every feature's worst case; the maximum of local
    // bounds over a partition of the plane does not.
    const auto size = static_cast<std::int64_t>(std::max<std::size_t>(1, program->code.size()));
    const auto queries = static_cast<int>(
        std::min<std::int64_t>(options.bound_queries, options.bound_instruction_budget / size));
    Evaluator evaluator(*program);
    program->bounds.elevation_lipschitz =
        std::min(program->bounds.elevation_lipschitz, partitioned_lipschitz(evaluator, queries));
  }
  return program;
}

Result<Program> compile_water(const Scene& scene, const CompileOptions& options) {
  assert(scene.water != nullptr);
  Compiler compiler(options);
  return compiler.run(scene, *scene.water, scene.water_bounds, "/water");
}

nlohmann::json Program::to_json() const {
  nlohmann::json types = nlohmann::json::array();
  for (const NodeType* t : node_types()) {
    types.push_back({{"id", t->id}, {"name", t->name}});
  }
  return {{"format", "terrain-program/1"},
          {"scene", scene_hash},
          {"instruction_count", code.size()},
          {"pool_size", pool.size()},
          {"code", base64(code.data(), code.size() * sizeof(Instruction))},
          {"pool", base64(pool.data(), pool.size() * sizeof(float))},
          {"node_types", std::move(types)},
          {"bounds", bounds_json(bounds)},
          {"base_elevation", base_elevation},
          {"max_field_depth", max_field_depth},
          {"max_frame_depth", max_frame_depth}};
}

}  // namespace terrain
