#include "nodes/erosion.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include "field_reader.hpp"
#include "nodes/image.hpp"
#include "terrain/erosion.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/heightfield.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"

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

/// Nodes of a subtree with references expanded (a shared subtree counts once per use).
std::int64_t expanded_nodes(const Node& node) {
  std::int64_t count = 1;
  for (const NodePtr& child : node.children) count += expanded_nodes(*child);
  return count;
}

/// The child's surface over the square, row 0 north (a raster): α f + (1 − α) base, sampled at
/// the grid's own level of detail so the grid does not alias finer detail.
std::vector<float> sample_child(const Node& child, float base_elevation, Vec2 origin, double step,
                                int side) {
  Scene scene;
  scene.root = std::shared_ptr<const Node>(std::shared_ptr<const Node>{}, &child);
  scene.base_elevation = base_elevation;
  scene.bounds = tree_bounds(child, {});
  CompileOptions options;
  options.bound_queries = 0;  // the child's global bound is not needed to sample it
  Result<Program> program = compile(scene, options);
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

Result<NodeParams> parse_erosion(FieldReader& reader, ParseContext& context) {
  const SceneLimits& limits = context.options->limits;
  const Node& child = *context.children.front();
  const NodeBounds child_bounds = tree_bounds(child, {});
  const Box2& support = child_bounds.support;
  const bool bounded = !support.empty() && std::isfinite(support.lo.x) &&
                       std::isfinite(support.hi.x) && std::isfinite(support.lo.y) &&
                       std::isfinite(support.hi.y);
  if (!bounded && (!reader.has("center") || !reader.has("size"))) {
    reader.fail(
        "is required: the child's support is unbounded, so the square to erode must be given",
        reader.has("center") ? "size" : "center");
    return reader.error();
  }
  const Vec2 center = reader.vec2(
      "center", bounded ? std::optional<Vec2>(support.center()) : std::nullopt, {-1e7, 1e7});
  const double size = reader.number(
      "size",
      bounded ? std::optional<double>(std::max(support.size().x, support.size().y)) : std::nullopt,
      {1.0, 1e7});
  const auto resolution = static_cast<int>(reader.integer(
      "resolution", 256, kMinErosionSide, std::min(limits.max_erosion_side, kMaxErosionSide)));
  ErosionParams p;
  p.iterations = static_cast<int>(reader.integer("iterations", 24, 1, kMaxErosionIterations));
  p.strength = reader.number("strength", 2.0, {0.0, kMaxErosionStrength});
  p.concavity = reader.number("concavity", 0.45, {kMinConcavity, kMaxConcavity});
  p.uplift = reader.number("uplift", 0.6, {0.0, 1.0});
  p.diffusion = reader.number("diffusion", 0.05, {0.0, kMaxDiffusion});
  p.talus_angle = reader.number("talus_angle", 60.0, {kMinTalusAngle, kMaxTalusAngle});
  if (reader.has("sea_level")) p.sea_level = reader.number("sea_level", std::nullopt, {-1e5, 1e5});
  const auto margin = static_cast<float>(reader.number("margin", 0.02, {0.001, 0.5}));
  if (!reader.ok()) return reader.error();

  // The cost first: refused before anything is sampled.
  const std::int64_t work = erosion_work(resolution, resolution, p.iterations);
  const std::int64_t evaluations = std::int64_t{resolution} * resolution * expanded_nodes(child);
  context.erosion_work += work;
  context.erosion_evaluations += evaluations;
  if (context.erosion_work > limits.max_erosion_work) {
    return Error{"the scene's erosion would take " + std::to_string(context.erosion_work) +
                     " cell-steps (resolution² × iterations over its grids), more than the limit "
                     "of " +
                     std::to_string(limits.max_erosion_work) + ": lower resolution or iterations",
                 pointer_join(reader.pointer(), "resolution"), ErrorKind::unsupported};
  }
  if (context.erosion_evaluations > limits.max_erosion_evaluations) {
    return Error{"sampling the eroded subtree would take " +
                     std::to_string(context.erosion_evaluations) +
                     " node evaluations, more than the limit of " +
                     std::to_string(limits.max_erosion_evaluations),
                 pointer_join(reader.pointer(), "resolution"), ErrorKind::unsupported};
  }

  const double step = size / (resolution - 1);
  const auto lo_x = static_cast<float>(center.x - 0.5 * size);
  const auto hi_x = static_cast<float>(center.x + 0.5 * size);
  const auto lo_y = static_cast<float>(center.y - 0.5 * size);
  const auto hi_y = static_cast<float>(center.y + 0.5 * size);
  // Corners north-west, north-east, south-east, south-west: raster row 0 is the north.
  Result<QuadMap> quad = QuadMap::create({lo_x, hi_y}, {hi_x, hi_y}, {hi_x, lo_y}, {lo_x, lo_y});
  if (!quad) return Error{quad.error().message, pointer_join(reader.pointer(), "size")};
  HeightfieldParams hp;
  hp.margin_u = hp.margin_v = margin;
  hp.cubic = true;  // C1: no creases along the grid's cells in hillshades and normals

  NodeParams out;
  out.canonical = reader.canonical();
  if (!context.options->bake) {
    // Validated and costed; the grid is made when the scene is parsed to be served. A flat
    // stand-in keeps the node's bounds defined meanwhile.
    context.unbaked = true;
    Raster flat;
    flat.width = flat.height = 2;
    flat.samples.assign(4, context.base_elevation);
    out.pool = pack_image_on_quad(Heightfield::create(flat, hp).value(), *quad);
    return out;
  }
  std::string content =
      "erosion/1 " + out.canonical.dump() + " base " + std::to_string(context.base_elevation) + " ";
  append_content(child, content);
  const std::string key = sha256_hex(content);
  if (BakeCache* cache = context.options->bake_cache) {
    if (auto grid = cache->find(key)) {
      out.pool = *grid;
      return out;
    }
  }

  const Vec2 origin{lo_x, lo_y};
  Raster raster;
  raster.width = raster.height = resolution;
  raster.samples = sample_child(child, context.base_elevation, origin, step, resolution);
  // The solver's row 0 is the south row: flip the raster's rows in and out.
  std::vector<float> south_up(raster.samples.size());
  const auto row = static_cast<std::size_t>(resolution);
  for (std::size_t j = 0; j < row; ++j) {
    std::copy_n(raster.samples.begin() + static_cast<std::ptrdiff_t>(j * row), row,
                south_up.begin() + static_cast<std::ptrdiff_t>((row - 1 - j) * row));
  }
  Result<std::vector<float>> eroded =
      erode({resolution, resolution, step, south_up, std::nullopt, {}}, p);
  if (!eroded) return Error{eroded.error().message, reader.pointer() + eroded.error().pointer};
  for (std::size_t j = 0; j < row; ++j) {
    std::copy_n(eroded->begin() + static_cast<std::ptrdiff_t>(j * row), row,
                raster.samples.begin() + static_cast<std::ptrdiff_t>((row - 1 - j) * row));
  }
  Result<Heightfield> field = Heightfield::create(raster, hp);
  if (!field) return Error{field.error().message, reader.pointer(), ErrorKind::internal};
  out.pool = pack_image_on_quad(*field, *quad);
  if (BakeCache* cache = context.options->bake_cache) {
    cache->insert(key, std::make_shared<const std::vector<float>>(out.pool));
  }
  return out;
}

// The image primitive's mapping steps, and the bicubic's 4 × 4 sample loop.
std::size_t erosion_loop_iterations(std::span<const float> params) {
  constexpr std::size_t kBicubicSteps = 20;
  return image_node_type().loop_iterations(params) + kBicubicSteps;
}

}  // namespace

const NodeType& erosion_node_type() {
  static const NodeType type{
      .id = 5,
      .name = "erosion",
      .category = NodeCategory::primitive,
      .min_children = 1,
      .max_children = 1,
      .summary =
          "its child shaped by rivers: stream-power incision with uplift, hillslope "
          "diffusion, a talus slope and depression deposits on a grid over a square",
      .parse = parse_erosion,
      .kernels = image_node_type().kernels,
      .example_json = R"({"type": "erosion", "resolution": 48, "iterations": 6,
 "children": [{"type": "disc", "center": [0, 0], "radius": 600, "elevation": 300,
   "noise": {"kind": "ridged", "amplitude": 200, "wavelength": 400, "octaves": 4, "seed": 3}}]})",
      .loop_iterations = erosion_loop_iterations,
      .shader = {.call = "image_leaf($at, $p)", .heavy = true},
  };
  return type;
}

}  // namespace terrain
