#include "terrain/evaluate.hpp"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <limits>
#include <queue>
#include <thread>

#include "nodes/blend.hpp"
#include "nodes/stored_bounds.hpp"

namespace terrain {
namespace {

NodeBounds no_weight_bounds() {
  return NodeBounds{};
}

// The leaf's field at one point at one sample spacing.
FieldBlock leaf_at(const NodeKernels& k, const float* params, Vec2 p, float spacing) {
  PointBlock point;
  point.count = 1;
  point.spacing = spacing;
  point.x[0] = p.x;
  point.y[0] = p.y;
  point.box = Box2::of_point(p);
  FieldBlock out;
  k.leaf(params, point, out);
  return out;
}

// Over a finite box, a primitive's ranges shrink to its value at the centre ± its Lipschitz
// bound times the half diagonal: cheap (one sample) and it keeps local bounds local, which is
// what makes blends of many tall features traceable. Over a band of spacings the centre is
// sampled at both ends: a value that is the same at both (the leaf's octave count, which only
// falls with the spacing, does not change) is the value throughout; one that differs says
// nothing between them.
void tighten_with_centre(const NodeKernels& k, const float* params, const BoundsQuery& q,
                         NodeBounds& b) {
  if (!q.box.is_finite()) return;
  const bool band = q.coarsest() > q.spacing;
  if (band && k.varies_with_spacing != nullptr &&
      k.varies_with_spacing(params, q.spacing, q.coarsest())) {
    return;
  }
  const Vec2 c = q.box.center();
  const FieldBlock out = leaf_at(k, params, c, q.spacing);
  bool same_elevation = true, same_weight = true;
  if (band && k.varies_with_spacing == nullptr) {
    const FieldBlock coarse = leaf_at(k, params, c, q.coarsest());
    same_elevation = coarse.f[0] == out.f[0];
    same_weight = coarse.a[0] == out.a[0];
  }
  const float r = 0.5f * length(q.box.size()) * 1.0001f;
  if (same_elevation) {
    const float slack = 1e-4f * (1.0f + std::abs(out.f[0]));  // float rounding of the sample
    b.elevation.lo = std::max(b.elevation.lo, out.f[0] - b.elevation_lipschitz * r - slack);
    b.elevation.hi = std::min(b.elevation.hi, out.f[0] + b.elevation_lipschitz * r + slack);
  }
  if (!same_weight) return;
  b.weight.lo = std::max(b.weight.lo, out.a[0] - b.weight_lipschitz * r - 1e-6f);
  b.weight.hi = std::min(b.weight.hi, out.a[0] + b.weight_lipschitz * r + 1e-6f);
  b.weight.lo = std::max(b.weight.lo, 0.0f);
  if (b.weight.lo > b.weight.hi) b.weight.lo = b.weight.hi;
  if (k.weight_lipschitz_near != nullptr && b.weight_lipschitz > 0.0f) {
    b.weight_lipschitz = std::min(b.weight_lipschitz, k.weight_lipschitz_near(params, out.a[0], r));
  }
}

// A subtree ending at `last` has no weight anywhere in the block. Its parent ignores it there: a
// blend adds nothing (every term is ±0, and an accumulator, a sum started at +0, is never −0, so
// adding changes no bit), so the following blend_add is skipped too; other parents get a
// zero-weight field pushed. Returns the instruction to continue from (the loop's ++ follows).
std::size_t skip_zero_weight(const Instruction* code, std::size_t size, std::size_t last,
                             FieldBlock& slot, int& sp, int n) {
  if (last + 1 < size && code[last + 1].op == Op::blend_add) return last + 1;
  slot.clear(n);
  ++sp;
  return last;
}

}  // namespace

struct Evaluator::Scratch {
  std::vector<FieldBlock> fields;
  std::vector<PointBlock> frames;
  std::vector<WarpJacobian> jacobians;
  std::vector<const NodeType*> types;  // per instruction
  std::vector<NodeBounds> bounds;
  std::vector<BlendBoundsAccumulator> blends;
  std::vector<BoundsQuery> queries;
};

Evaluator::Evaluator(const Program& program)
    : program_(program), scratch_(std::make_unique<Scratch>()) {
  scratch_->fields.resize(static_cast<std::size_t>(program.max_field_depth) + 1);
  scratch_->frames.resize(static_cast<std::size_t>(program.max_frame_depth) + 1);
  scratch_->jacobians.resize(static_cast<std::size_t>(program.max_frame_depth) + 1);
  scratch_->types.reserve(program.code.size());
  for (const Instruction& ins : program.code) {
    scratch_->types.push_back(node_type_by_id(ins.type));
    assert(scratch_->types.back() != nullptr && "programs come from compile(): known types only");
  }
}

Evaluator::~Evaluator() = default;

void Evaluator::evaluate(const PointBlock& block, FieldBlock& out) {
  Scratch& s = *scratch_;
  const Instruction* code = program_.code.data();
  const float* pool = program_.pool.data();
  const std::size_t size = program_.code.size();
  const int n = block.count;
  FieldBlock* fields = s.fields.data();
  int sp = 0;
  int fp = 0;
  const PointBlock* frame = &block;
  for (std::size_t pc = 0; pc < size; ++pc) {
    const Instruction& ins = code[pc];
    const float* params = pool + ins.params;
    switch (ins.op) {
      case Op::leaf: {
        const NodeKernels& k = s.types[pc]->kernels;
        if (ins.skip == 0 || k.leaf_where_weighted == nullptr) {
          k.leaf(params, *frame, fields[sp++]);
        } else if (!k.leaf_where_weighted(params, *frame, fields[sp])) {
          pc = skip_zero_weight(code, size, pc, fields[sp], sp, n);
        } else {
          ++sp;
        }
        break;
      }
      case Op::blend_begin:
        blend_clear(fields[sp++], n);
        break;
      case Op::blend_add:
        --sp;
        blend_accumulate(fields[sp - 1], fields[sp], n);
        break;
      case Op::blend_end:
        blend_finish(params, fields[sp - 1], n);
        break;
      case Op::cull:
        if (!frame->box.intersects(stored_box(params))) {
          pc = skip_zero_weight(code, size, pc + ins.skip, fields[sp], sp, n);
        }
        break;
      case Op::group:
        if (!frame->box.intersects(stored_box(params))) pc += ins.skip;
        break;
      case Op::combine:
        --sp;
        s.types[pc]->kernels.combine(params, *frame, fields[sp - 1], fields[sp], fields[sp - 1]);
        break;
      case Op::warp_begin:
        ++fp;
        s.types[pc]->kernels.warp_points(params, *frame, s.frames[static_cast<std::size_t>(fp)],
                                         s.jacobians[static_cast<std::size_t>(fp)]);
        frame = &s.frames[static_cast<std::size_t>(fp)];
        break;
      case Op::warp_end:
        s.types[pc]->kernels.warp_field(params, n, s.jacobians[static_cast<std::size_t>(fp)],
                                        fields[sp - 1]);
        --fp;
        frame = fp == 0 ? &block : &s.frames[static_cast<std::size_t>(fp)];
        break;
    }
  }
  const FieldBlock& result = fields[0];
  std::copy_n(result.f, n, out.f);
  std::copy_n(result.a, n, out.a);
  std::copy_n(result.fx, n, out.fx);
  std::copy_n(result.fy, n, out.fy);
  std::copy_n(result.ax, n, out.ax);
  std::copy_n(result.ay, n, out.ay);
}

FieldSample Evaluator::sample(Vec2 p, float spacing) {
  PointBlock block;
  block.count = 1;
  block.spacing = spacing;
  block.x[0] = p.x;
  block.y[0] = p.y;
  block.box = Box2::of_point(p);
  FieldBlock out;
  evaluate(block, out);
  return out.at(0);
}

NodeBounds Evaluator::bounds(const BoundsQuery& query) {
  Scratch& s = *scratch_;
  const Instruction* code = program_.code.data();
  const float* pool = program_.pool.data();
  const std::size_t size = program_.code.size();
  s.bounds.clear();
  s.blends.clear();
  s.queries.clear();
  BoundsQuery q = query;
  for (std::size_t pc = 0; pc < size; ++pc) {
    const Instruction& ins = code[pc];
    const float* params = pool + ins.params;
    const NodeKernels& k = s.types[pc]->kernels;
    switch (ins.op) {
      case Op::leaf:
        s.bounds.push_back(k.leaf_bounds(params, q));
        tighten_with_centre(k, params, q, s.bounds.back());
        break;
      case Op::blend_begin:
        s.blends.emplace_back();
        break;
      case Op::blend_add:
        s.blends.back().add(s.bounds.back());
        s.bounds.pop_back();
        break;
      case Op::blend_end:
        s.bounds.push_back(s.blends.back().finish(params));
        s.blends.pop_back();
        break;
      case Op::cull:
        if (!q.box.intersects(stored_box(params))) {
          s.bounds.push_back(no_weight_bounds());
          pc += ins.skip;
        }
        break;
      case Op::group:
        if (!q.box.intersects(stored_box(params))) pc += ins.skip;
        break;
      case Op::combine: {
        const NodeBounds b = s.bounds.back();
        s.bounds.pop_back();
        s.bounds.back() = k.combine_bounds(params, q, s.bounds.back(), b);
        break;
      }
      case Op::warp_begin:
        s.queries.push_back(q);
        q.box = k.warp_box(params, q);
        if (k.warp_spacing != nullptr) {
          q.spacing = k.warp_spacing(params, q.spacing);
          q.coarsest_spacing = k.warp_spacing(params, q.coarsest_spacing);
        }
        break;
      case Op::warp_end:
        q = s.queries.back();
        s.queries.pop_back();
        s.bounds.back() = k.warp_bounds(params, q, s.bounds.back());
        break;
    }
  }
  return s.bounds.back();
}

const NodeBounds& Evaluator::global_bounds() {
  if (!global_) {
    global_ = bounds({Box2::everywhere(), 0.0f});
    // compile() stores the partitioned bound, which no single query can match.
    global_->elevation_lipschitz =
        std::min(global_->elevation_lipschitz, program_.bounds.elevation_lipschitz);
  }
  return *global_;
}

float partitioned_lipschitz(Evaluator& evaluator, int max_queries) {
  const NodeBounds whole = evaluator.bounds({Box2::everywhere(), 0.0f});
  const Box2 s = whole.support;
  if (s.empty() || !s.is_finite() || max_queries < 20) return whole.elevation_lipschitz;
  const float inf = std::numeric_limits<float>::infinity();
  int queries = 0;
  auto bound_of = [&](const Box2& box) {
    ++queries;
    return evaluator.bounds({box, 0.0f}).elevation_lipschitz;
  };
  // The plane outside the support, as four unbounded boxes.
  float outside = 0.0f;
  for (const Box2& box :
       {Box2{{-inf, -inf}, {s.lo.x, inf}}, Box2{{s.hi.x, -inf}, {inf, inf}},
        Box2{{s.lo.x, -inf}, {s.hi.x, s.lo.y}}, Box2{{s.lo.x, s.hi.y}, {s.hi.x, inf}}}) {
    outside = std::max(outside, bound_of(box));
  }
  // The support, refined where the bound is highest: the answer is the top of the queue.
  using Cell = std::pair<float, Box2>;
  auto lower = [](const Cell& a, const Cell& b) { return a.first < b.first; };
  std::priority_queue<Cell, std::vector<Cell>, decltype(lower)> cells(lower);
  auto push_quarters = [&](const Box2& box, int n) {
    const Vec2 size = box.size();
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const auto fi = static_cast<float>(i), fj = static_cast<float>(j);
        const auto fn = static_cast<float>(n);
        const Vec2 lo{box.lo.x + size.x * fi / fn, box.lo.y + size.y * fj / fn};
        // The last row and column end exactly on the box, so no sliver is left out by rounding.
        const Vec2 hi{i + 1 == n ? box.hi.x : box.lo.x + size.x * (fi + 1) / fn,
                      j + 1 == n ? box.hi.y : box.lo.y + size.y * (fj + 1) / fn};
        const Box2 cell{lo, hi};
        cells.emplace(bound_of(cell), cell);
      }
    }
  };
  push_quarters(s, 4);
  // A cell is cut while its bound exceeds what is already certain (the largest bound outside)
  // and cutting can still shrink it; cells of a metre are left whole.
  while (queries + 4 <= max_queries && cells.top().first > outside &&
         std::max(cells.top().second.size().x, cells.top().second.size().y) > 1.0f) {
    const Box2 box = cells.top().second;
    cells.pop();
    push_quarters(box, 2);
  }
  return std::max(outside, cells.top().first);
}

GridResult evaluate_grid(const Program& program, const GridSpec& grid, int threads) {
  GridResult result;
  result.width = grid.width;
  result.height = grid.height;
  const auto total = static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height);
  result.elevation.resize(total);
  result.gradient_x.resize(total);
  result.gradient_y.resize(total);
  constexpr int kSide = 8;  // 8×8 = kBlockSize points per block
  const int blocks_x = (grid.width + kSide - 1) / kSide;
  const int blocks_y = (grid.height + kSide - 1) / kSide;
  const int block_count = blocks_x * blocks_y;
  const float spacing = grid.lod_spacing < 0.0f ? static_cast<float>(grid.step) : grid.lod_spacing;
  std::atomic<int> next{0};

  auto worker = [&] {
    Evaluator evaluator(program);
    PointBlock block;
    FieldBlock out;
    for (int b = next.fetch_add(1); b < block_count; b = next.fetch_add(1)) {
      const int bx = (b % blocks_x) * kSide;
      const int by = (b / blocks_x) * kSide;
      const int columns = std::min(kSide, grid.width - bx);
      const int rows = std::min(kSide, grid.height - by);
      // Positions in double, then rounded once, so every tile agrees on shared samples.
      float xs[kSide], ys[kSide];
      for (int i = 0; i < columns; ++i)
        xs[i] = static_cast<float>(grid.origin_x + grid.step * (bx + i));
      for (int j = 0; j < rows; ++j)
        ys[j] = static_cast<float>(grid.origin_y + grid.step * (by + j));
      block.count = 0;
      block.spacing = spacing;
      for (int j = 0; j < rows; ++j) {
        for (int i = 0; i < columns; ++i) {
          block.x[block.count] = xs[i];
          block.y[block.count] = ys[j];
          ++block.count;
        }
      }
      // The grid's points are ordered, so the box is that of its first and last rows and columns.
      block.box = {{std::min(xs[0], xs[columns - 1]), std::min(ys[0], ys[rows - 1])},
                   {std::max(xs[0], xs[columns - 1]), std::max(ys[0], ys[rows - 1])}};
      evaluator.evaluate(block, out);
      for (int j = 0; j < rows; ++j) {
        const std::size_t at =
            static_cast<std::size_t>(by + j) * static_cast<std::size_t>(grid.width) +
            static_cast<std::size_t>(bx);
        const int k = j * columns;
        std::copy_n(out.f + k, columns, result.elevation.begin() + static_cast<std::ptrdiff_t>(at));
        std::copy_n(out.fx + k, columns,
                    result.gradient_x.begin() + static_cast<std::ptrdiff_t>(at));
        std::copy_n(out.fy + k, columns,
                    result.gradient_y.begin() + static_cast<std::ptrdiff_t>(at));
      }
    }
  };

  const int count =
      threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int used = std::min(count, block_count);
  std::vector<std::thread> pool;
  for (int t = 1; t < used; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  return result;
}

namespace {

void evaluate_node(const Node& node, const PointBlock& points, FieldBlock& out) {
  const float* params = node.params.pool.data();
  const NodeKernels& k = node.type->kernels;
  switch (node.type->category) {
    case NodeCategory::primitive:
      k.leaf(params, points, out);
      return;
    case NodeCategory::blend: {
      blend_clear(out, points.count);
      auto child = std::make_unique<FieldBlock>();
      for (const NodePtr& c : node.children) {
        evaluate_node(*c, points, *child);
        blend_accumulate(out, *child, points.count);
      }
      blend_finish(params, out, points.count);
      return;
    }
    case NodeCategory::binary: {
      auto b = std::make_unique<FieldBlock>();
      evaluate_node(*node.children[0], points, out);
      evaluate_node(*node.children[1], points, *b);
      k.combine(params, points, out, *b, out);
      return;
    }
    case NodeCategory::warp: {
      auto warped = std::make_unique<PointBlock>();
      auto jacobian = std::make_unique<WarpJacobian>();
      k.warp_points(params, points, *warped, *jacobian);
      evaluate_node(*node.children[0], *warped, out);
      k.warp_field(params, points.count, *jacobian, out);
      return;
    }
  }
}

}  // namespace

NodeBounds tree_bounds(const Node& node, const BoundsQuery& query) {
  const float* params = node.params.pool.data();
  const NodeKernels& k = node.type->kernels;
  switch (node.type->category) {
    case NodeCategory::primitive:
      return k.leaf_bounds(params, query);
    case NodeCategory::blend: {
      BlendBoundsAccumulator acc;
      for (const NodePtr& c : node.children) acc.add(tree_bounds(*c, query));
      return acc.finish(params);
    }
    case NodeCategory::binary:
      return k.combine_bounds(params, query, tree_bounds(*node.children[0], query),
                              tree_bounds(*node.children[1], query));
    case NodeCategory::warp: {
      BoundsQuery inner{k.warp_box(params, query), query.spacing, query.coarsest_spacing};
      if (k.warp_spacing != nullptr) {
        inner.spacing = k.warp_spacing(params, query.spacing);
        inner.coarsest_spacing = k.warp_spacing(params, query.coarsest_spacing);
      }
      return k.warp_bounds(params, query, tree_bounds(*node.children[0], inner));
    }
  }
  return {};
}

FieldSample evaluate_tree(const Scene& scene, Vec2 p, float spacing) {
  PointBlock block;
  block.count = 1;
  block.spacing = spacing;
  block.x[0] = p.x;
  block.y[0] = p.y;
  block.box = Box2::of_point(p);
  FieldBlock out;
  evaluate_node(*scene.root, block, out);
  return out.at(0);
}

}  // namespace terrain
