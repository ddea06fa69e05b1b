#include "nodes/baked_grid.hpp"

#include <algorithm>
#include <cmath>

#include "field_reader.hpp"
#include "nodes/image.hpp"
#include "nodes/stored_bounds.hpp"
#include "terrain/erosion.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"
#include "terrain/tile_products.hpp"

namespace terrain {
namespace {

/// Appends what evaluating a subtree depends on — each node's type and packed parameters (seeds,
/// images and all), its children in order — to `out`: two subtrees with the same bytes evaluate
/// the same everywhere.
void append_content(const Node& node, std::string& out) {
  const std::uint16_t id = node.type->id;
  const auto floats = static_cast<std::uint64_t>(node.params.pool.size());
  const auto children = static_cast<std::uint64_t>(node.children.size());
  out.append(reinterpret_cast<const char*>(&id), sizeof id);
  out.append(reinterpret_cast<const char*>(&floats), sizeof floats);
  out.append(reinterpret_cast<const char*>(node.params.pool.data()), floats * sizeof(float));
  out.append(reinterpret_cast<const char*>(&children), sizeof children);
  for (const NodePtr& child : node.children) append_content(*child, out);
}

// The pool is an image primitive's (nodes/image.cpp: 0 λ_f, 1 λ_α, 2 h_lo, 3 h_hi, 4..7 box,
// 8 mapping, 9 heightfield, 10 mapping mode: 2, the box itself), whose curve-only slot 12 holds the
// offset of a table of local bounds: tile side in cells, tiles per side, cells per side, then per
// tile of kTile × kTile cells its slope bound in metres per metre, its height range and the
// largest weight of its samples (1 for a grid without weights).
constexpr int kBox = 4, kMode = 10, kTable = 12;
constexpr float kOnItsBox = 2.0f;  // the image's mapping mode 2: its support box
constexpr int kTile = 8;
constexpr std::size_t kTileFloats = 4;

/// Local bounds of a bicubic grid of n × n samples (raster rows, north first) over a square of
/// side `side` metres: per tile, 2.5 × the largest neighbour difference per axis over its cells'
/// stencils (a cell's cubic reads one sample more on each side), and the overshoot-widened range
/// of those samples (heightfield.hpp), and the largest of their weights: the weight interpolates
/// bilinearly between samples, so a tile whose samples all weigh 0 weighs exactly 0.
void pack_local_bounds(const std::vector<float>& h, const std::vector<float>& weights, int n,
                       double side, std::vector<float>& pool) {
  const int cells = n - 1;
  const int tiles = (cells + kTile - 1) / kTile;
  const double cell = side / cells;
  pool[kTable] = static_cast<float>(pool.size());
  pool.insert(pool.end(),
              {static_cast<float>(kTile), static_cast<float>(tiles), static_cast<float>(cells)});
  const auto at = [&](int i, int j) {
    return static_cast<double>(
        h[static_cast<std::size_t>(j) * static_cast<std::size_t>(n) + static_cast<std::size_t>(i)]);
  };
  for (int tj = 0; tj < tiles; ++tj) {
    for (int ti = 0; ti < tiles; ++ti) {
      // Samples of the cells' stencils: one before the tile's first cell, one after its last.
      const int i0 = std::max(ti * kTile - 1, 0), i1 = std::min((ti + 1) * kTile + 1, cells);
      const int j0 = std::max(tj * kTile - 1, 0), j1 = std::min((tj + 1) * kTile + 1, cells);
      double du = 0.0, dv = 0.0, lo = at(i0, j0), hi = lo;
      float heaviest = weights.empty() ? 1.0f : 0.0f;
      for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) {
          const double z = at(i, j);
          if (!weights.empty()) {
            heaviest = std::max(heaviest,
                                weights[static_cast<std::size_t>(j) * static_cast<std::size_t>(n) +
                                        static_cast<std::size_t>(i)]);
          }
          lo = std::min(lo, z);
          hi = std::max(hi, z);
          if (i < i1) du = std::max(du, std::abs(at(i + 1, j) - z));
          if (j < j1) dv = std::max(dv, std::abs(at(i, j + 1) - z));
        }
      }
      const double lu = 2.5 * du / cell, lv = 2.5 * dv / cell;
      const double middle = 0.5 * (lo + hi), half = 0.5 * (hi - lo) * 1.5625;
      const double pad = 1e-6 * std::max({std::abs(lo), std::abs(hi), 1.0});
      // Rounded outwards: a bound a float ulp short is no bound.
      pool.push_back(static_cast<float>(std::sqrt(lu * lu + lv * lv) * (1.0 + 1e-5)) *
                     (1.0f + 1e-6f));
      pool.push_back(static_cast<float>(middle - half - pad));
      pool.push_back(static_cast<float>(middle + half + pad));
      pool.push_back(heaviest);
    }
  }
}

/// Nodes of a subtree with references expanded (a shared subtree counts once per use).
std::int64_t expanded_nodes(const Node& node) {
  std::int64_t count = 1;
  for (const NodePtr& child : node.children) count += expanded_nodes(*child);
  return count;
}

}  // namespace

Vec2 GridSquare::south_west() const {
  return {static_cast<float>(center.x - 0.5 * size), static_cast<float>(center.y - 0.5 * size)};
}

std::optional<GridSquare> read_grid_square(FieldReader& reader, const ParseContext& context,
                                           int default_resolution) {
  const SceneLimits& limits = context.options->limits;
  const NodeBounds child_bounds = tree_bounds(*context.children.front(), {});
  const Box2& support = child_bounds.support;
  const bool bounded = !support.empty() && std::isfinite(support.lo.x) &&
                       std::isfinite(support.hi.x) && std::isfinite(support.lo.y) &&
                       std::isfinite(support.hi.y);
  if (!bounded && (!reader.has("center") || !reader.has("size"))) {
    reader.fail("is required: the child's support is unbounded, so the square must be given",
                reader.has("center") ? "size" : "center");
    return std::nullopt;
  }
  GridSquare square;
  square.center = reader.vec2(
      "center", bounded ? std::optional<Vec2>(support.center()) : std::nullopt, {-1e7, 1e7});
  square.size = reader.number(
      "size",
      bounded ? std::optional<double>(std::max(support.size().x, support.size().y)) : std::nullopt,
      {1.0, 1e7});
  square.resolution =
      static_cast<int>(reader.integer("resolution", default_resolution, kMinErosionSide,
                                      std::min(limits.max_erosion_side, kMaxErosionSide)));
  square.margin = static_cast<float>(reader.number("margin", 0.02, {0.001, 0.5}));
  if (!reader.ok()) return std::nullopt;
  return square;
}

std::vector<float> sample_child(const Node& child, float base_elevation, const GridSquare& square) {
  Scene scene;
  scene.root = std::shared_ptr<const Node>(std::shared_ptr<const Node>{}, &child);
  scene.base_elevation = base_elevation;
  scene.bounds = tree_bounds(child, {});
  CompileOptions options;
  options.bound_queries = 0;  // the child's global bound is not needed to sample it
  Result<Program> program = compile(scene, options);
  const int side = square.resolution;
  const double step = square.step();
  const Vec2 origin = square.south_west();
  std::vector<float> out(static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  if (!program) return out;  // compile fails only on limits the scene's own parse enforces
  Evaluator evaluator(*program);
  PointBlock block;
  FieldBlock field;
  block.spacing = static_cast<float>(step);
  constexpr int kSide = 8;
  for (int by = 0; by < side; by += kSide) {
    for (int bx = 0; bx < side; bx += kSide) {
      const int columns = std::min(kSide, side - bx), rows = std::min(kSide, side - by);
      block.count = 0;
      for (int j = 0; j < rows; ++j) {
        for (int i = 0; i < columns; ++i) {
          block.x[block.count] = static_cast<float>(origin.x + step * (bx + i));
          block.y[block.count] = static_cast<float>(origin.y + step * (by + j));
          ++block.count;
        }
      }
      block.recompute_box();
      evaluator.evaluate(block, field);
      for (int j = 0; j < rows; ++j) {
        for (int i = 0; i < columns; ++i) {
          const int k = j * columns + i;
          const float a = std::clamp(field.a[k], 0.0f, 1.0f);
          const std::size_t row = static_cast<std::size_t>(side - 1 - (by + j));
          out[row * static_cast<std::size_t>(side) + static_cast<std::size_t>(bx + i)] =
              a * field.f[k] + (1.0f - a) * base_elevation;
        }
      }
    }
  }
  return out;
}

Status charge_bake(ParseContext& context, const std::string& pointer, std::int64_t work,
                   const GridSquare& square) {
  const SceneLimits& limits = context.options->limits;
  const std::int64_t samples = std::int64_t{square.resolution} * square.resolution;
  context.erosion_work += work;
  context.erosion_evaluations += samples * expanded_nodes(*context.children.front());
  if (context.erosion_work > limits.max_erosion_work) {
    return Error{"the scene's erosion and drainage would take " +
                     std::to_string(context.erosion_work) +
                     " cell-steps (resolution² × steps over their grids), more than the limit of " +
                     std::to_string(limits.max_erosion_work) + ": lower resolution or iterations",
                 pointer_join(pointer, "resolution"), ErrorKind::unsupported};
  }
  if (context.erosion_evaluations > limits.max_erosion_evaluations) {
    return Error{"sampling the subtrees to bake would take " +
                     std::to_string(context.erosion_evaluations) +
                     " node evaluations, more than the limit of " +
                     std::to_string(limits.max_erosion_evaluations),
                 pointer_join(pointer, "resolution"), ErrorKind::unsupported};
  }
  return Ok{};
}

BakeCache::Grid bake_grid(const ParseContext& context, std::string_view kind,
                          const nlohmann::json& canonical,
                          const std::function<BakeCache::Grid()>& make) {
  BakeCache* cache = context.options->bake_cache;
  if (cache == nullptr) return make();
  // The product generation changes with the solvers' arithmetic: a grid made by an older one is
  // never found (in the disk cache, Redis or the store) for a newer one.
  std::string content = std::string(kind) + " g" + std::to_string(kProductGeneration) + " " +
                        canonical.dump() + " base " + std::to_string(context.base_elevation) + " ";
  append_content(*context.children.front(), content);
  return cache->get_or_make(sha256_hex(content), make);
}

Result<std::vector<float>> pack_baked_grid(std::vector<float> samples, int side,
                                           const GridSquare& square, bool local_bounds,
                                           std::vector<float> weights) {
  const Vec2 lo = square.south_west();
  const auto hi_x = static_cast<float>(square.center.x + 0.5 * square.size);
  const auto hi_y = static_cast<float>(square.center.y + 0.5 * square.size);
  // Corners north-west, north-east, south-east, south-west: raster row 0 is the north.
  Result<QuadMap> quad = QuadMap::create({lo.x, hi_y}, {hi_x, hi_y}, {hi_x, lo.y}, {lo.x, lo.y});
  if (!quad) return quad.error();
  HeightfieldParams hp;
  hp.margin_u = hp.margin_v = square.margin;
  hp.cubic = true;  // C1: no creases along the grid's cells in hillshades and normals
  Raster raster;
  raster.width = raster.height = side;
  raster.samples = std::move(samples);
  raster.weights = std::move(weights);
  Result<Heightfield> field = Heightfield::create(raster, hp);
  if (!field) return field.error();
  std::vector<float> pool = pack_image_on_quad(*field, *quad);
  pool[kMode] = kOnItsBox;  // the square is axis-aligned: u, v are affine in x, y
  if (local_bounds) {
    pack_local_bounds(raster.samples, raster.weights, side, static_cast<double>(hi_x) - lo.x, pool);
  }
  return pool;
}

NodeBounds baked_grid_bounds(const float* params, const BoundsQuery& query) {
  const Box2 square = stored_box(params + kBox);
  const auto table = static_cast<std::size_t>(params[kTable]);
  const auto tile = static_cast<int>(params[table]);
  const auto tiles = static_cast<int>(params[table + 1]);
  const double cells = params[table + 2];
  const float* entries = params + table + 3;
  const double side = static_cast<double>(square.hi.x) - square.lo.x;
  const auto index = [&](double offset) {  // a cell index, one cell of slack either way
    const double c = std::floor(offset / side * cells);
    return std::clamp(c, 0.0, cells - 1.0);
  };
  const Box2& q = query.box;
  const double c0 = index(static_cast<double>(q.lo.x) - square.lo.x) - 1.0;
  const double c1 = index(static_cast<double>(q.hi.x) - square.lo.x) + 1.0;
  const double r0 = index(static_cast<double>(square.hi.y) - q.hi.y) - 1.0;  // rows from north
  const double r1 = index(static_cast<double>(square.hi.y) - q.lo.y) + 1.0;
  const auto tile_of = [&](double c) {
    return std::clamp(static_cast<int>(std::max(c, 0.0)) / tile, 0, tiles - 1);
  };
  const int t0 = tile_of(c0), t1 = tile_of(c1), s0 = tile_of(r0), s1 = tile_of(r1);
  float slope = 0.0f, heaviest = 0.0f;
  Interval range{INFINITY, -INFINITY};
  for (int tj = s0; tj <= s1; ++tj) {
    for (int ti = t0; ti <= t1; ++ti) {
      const float* e = entries + kTileFloats * static_cast<std::size_t>(tj * tiles + ti);
      slope = std::max(slope, e[0]);
      range = {std::min(range.lo, e[1]), std::max(range.hi, e[2])};
      heaviest = std::max(heaviest, e[3]);
    }
  }
  NodeBounds b = image_node_type().kernels.leaf_bounds(params, query);
  b.elevation = range;
  b.elevation_lipschitz = std::min(b.elevation_lipschitz, slope);
  if (!(heaviest > 0.0f)) b.weight = {0.0f, 0.0f};  // no sample near the box weighs anything
  return b;
}

std::size_t baked_grid_loop_iterations(std::span<const float> params) {
  constexpr std::size_t kBicubicSteps = 20;
  return image_node_type().loop_iterations(params) + kBicubicSteps;
}

}  // namespace terrain
