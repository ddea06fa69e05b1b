// CPU evaluation: the reference interpreter of a compiled program (points, blocks, grids, bounds
// over boxes) and a direct recursive evaluator of the scene tree used to check the compiler.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "terrain/field.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"

namespace terrain {

/// Interprets one program. Not thread-safe (it owns scratch stacks): use one per thread.
class Evaluator {
 public:
  explicit Evaluator(const Program& program);
  ~Evaluator();
  Evaluator(const Evaluator&) = delete;
  Evaluator& operator=(const Evaluator&) = delete;

  /// f, α and gradients at p, at level of detail `spacing` (metres; 0 = full detail).
  FieldSample sample(Vec2 p, float spacing = 0.0f);
  /// The same for a block of points (block.box must bound the points).
  void evaluate(const PointBlock& block, FieldBlock& out);
  /// Bounds of the root over a box at a level of detail.
  NodeBounds bounds(const BoundsQuery& query);
  /// Bounds of the root over the whole plane at full detail (computed once).
  const NodeBounds& global_bounds();

  const Program& program() const { return program_; }

 private:
  struct Scratch;
  const Program& program_;
  std::unique_ptr<Scratch> scratch_;
  std::optional<NodeBounds> global_;
};

/// A Lipschitz bound of the root over the whole plane at full detail, as the largest local bound
/// over a partition of the plane: the root's support cut into boxes, those with the highest bound
/// cut again while fewer than `max_queries` box queries have been made, and the four unbounded
/// boxes around it. Every local bound is sound, so their maximum is; it is far tighter than one
/// query over the plane, where the worst cases of features that never meet add up (a blend sums
/// every child's weight slope).
float partitioned_lipschitz(Evaluator& evaluator, int max_queries = 2048);

/// A regular grid of samples: point (i, j) is origin + (i, j)·step; row j = 0 is the southern row.
struct GridSpec {
  double origin_x = 0.0;
  double origin_y = 0.0;
  double step = 1.0;
  int width = 0;
  int height = 0;
  float lod_spacing = -1.0f;  ///< level of detail; < 0 means "the grid's step"
};

/// Heights and gradients of a grid, row-major from row 0.
struct GridResult {
  int width = 0;
  int height = 0;
  std::vector<float> elevation;
  std::vector<float> gradient_x;
  std::vector<float> gradient_y;
};

/// Evaluates a grid on `threads` threads (0 = all cores), in 8×8 blocks.
GridResult evaluate_grid(const Program& program, const GridSpec& grid, int threads = 0);

/// Bounds of a scene (sub)tree by direct recursion over the nodes.
NodeBounds tree_bounds(const Node& node, const BoundsQuery& query);

/// Evaluates the scene tree directly (recursion, no culling, no affine concatenation).
FieldSample evaluate_tree(const Scene& scene, Vec2 p, float spacing = 0.0f);

}  // namespace terrain
