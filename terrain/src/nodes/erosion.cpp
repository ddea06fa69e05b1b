#include "nodes/erosion.hpp"

#include <algorithm>

#include "field_reader.hpp"
#include "nodes/baked_grid.hpp"
#include "nodes/image.hpp"
#include "terrain/erosion.hpp"

namespace terrain {
namespace {

Result<NodeParams> parse_erosion(FieldReader& reader, ParseContext& context) {
  const Node& child = *context.children.front();
  const std::optional<GridSquare> square = read_grid_square(reader, context, 256);
  if (!square) return reader.error();
  const int resolution = square->resolution;
  ErosionParams p;
  p.iterations = static_cast<int>(reader.integer("iterations", 24, 1, kMaxErosionIterations));
  p.strength = reader.number("strength", 2.0, {0.0, kMaxErosionStrength});
  p.concavity = reader.number("concavity", 0.45, {kMinConcavity, kMaxConcavity});
  p.uplift = reader.number("uplift", 0.6, {0.0, 1.0});
  p.diffusion = reader.number("diffusion", 0.05, {0.0, kMaxDiffusion});
  p.talus_angle = reader.number("talus_angle", 60.0, {kMinTalusAngle, kMaxTalusAngle});
  if (reader.has("sea_level")) p.sea_level = reader.number("sea_level", std::nullopt, {-1e5, 1e5});
  if (!reader.ok()) return reader.error();

  // The cost first: refused before anything is sampled.
  if (Status charged =
          charge_bake(context, reader.pointer(),
                      erosion_work(resolution, resolution, p.iterations, p.diffusion), *square);
      !charged) {
    return charged.error();
  }

  NodeParams out;
  out.canonical = reader.canonical();
  if (!context.options->bake) {
    // Validated and costed; the grid is made when the scene is parsed to be served. A flat
    // stand-in keeps the node's bounds defined meanwhile.
    context.unbaked = true;
    Result<std::vector<float>> flat =
        pack_baked_grid(std::vector<float>(4, context.base_elevation), 2, *square, true);
    if (!flat) return Error{flat.error().message, pointer_join(reader.pointer(), "size")};
    out.pool = std::move(*flat);
    return out;
  }
  // The grid: sampled, eroded and packed with its local bounds. Erosion and packing fail only
  // on what the parameters above exclude, so a failure here is this module's (internal).
  const auto bake = [&]() -> BakeCache::Grid {
    std::vector<float> samples = sample_child(child, context.base_elevation, *square);
    // The solver's row 0 is the south row: the raster's rows are flipped in place (a copy would
    // be a quarter of a 2048² solve's memory again), eroded, and the result flipped back.
    const auto row = static_cast<std::size_t>(resolution);
    const auto flip_rows = [row](std::vector<float>& raster) {
      for (std::size_t j = 0; j < row / 2; ++j) {
        std::swap_ranges(raster.begin() + static_cast<std::ptrdiff_t>(j * row),
                         raster.begin() + static_cast<std::ptrdiff_t>((j + 1) * row),
                         raster.begin() + static_cast<std::ptrdiff_t>((row - 1 - j) * row));
      }
    };
    flip_rows(samples);
    // Handed over: the solve works in the samples' storage (fifteen bytes a cell in all).
    Result<std::vector<float>> eroded =
        erode(std::move(samples), resolution, resolution, square->step(), p);
    if (!eroded) return nullptr;
    samples = std::move(*eroded);
    flip_rows(samples);
    Result<std::vector<float>> pool =
        pack_baked_grid(std::move(samples), resolution, *square, true);
    if (!pool) return nullptr;
    return std::make_shared<const std::vector<float>>(std::move(*pool));
  };
  const BakeCache::Grid grid = bake_grid(context, "erosion/1", out.canonical, bake);
  if (!grid) {
    return Error{"the erosion grid could not be made", reader.pointer(), ErrorKind::internal};
  }
  out.pool = *grid;
  return out;
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
      .kernels = {.leaf = image_node_type().kernels.leaf,
                  .leaf_bounds = baked_grid_bounds,
                  .varies_with_spacing = never_varies_with_spacing},
      .example_json = R"({"type": "erosion", "resolution": 48, "iterations": 6,
 "children": [{"type": "disc", "center": [0, 0], "radius": 600, "elevation": 300,
   "noise": {"kind": "ridged", "amplitude": 200, "wavelength": 400, "octaves": 4, "seed": 3}}]})",
      .loop_iterations = baked_grid_loop_iterations,
      .shader = {.call = "image_leaf($at, $p)", .heavy = true},
  };
  return type;
}

}  // namespace terrain
