#include "nodes/drainage.hpp"

#include <algorithm>

#include "field_reader.hpp"
#include "nodes/baked_grid.hpp"
#include "nodes/image.hpp"
#include "terrain/rivers.hpp"

namespace terrain {
namespace {

// Work counted against the scene's erosion budget per grid cell: two routings, the lakes and the
// carve's sections.
constexpr std::int64_t kWorkPerCell = 4;

/// The baked pair in one cached vector: the carved ground's pool's length, that pool, then the
/// water surface's pool.
BakeCache::Grid join(std::vector<float> ground, const std::vector<float>& water) {
  std::vector<float> both;
  both.reserve(1 + ground.size() + water.size());
  both.push_back(static_cast<float>(ground.size()));
  both.insert(both.end(), ground.begin(), ground.end());
  both.insert(both.end(), water.begin(), water.end());
  return std::make_shared<const std::vector<float>>(std::move(both));
}

Result<NodeParams> parse_drainage(FieldReader& reader, ParseContext& context) {
  const Node& child = *context.children.front();
  if (context.in_water_tree) {
    return Error{
        "a drainage shapes the terrain: it belongs under /root, and its rivers and lakes "
        "join the water layer by themselves",
        pointer_join(reader.pointer(), "type")};
  }
  if (context.reshaping_ancestors > 0) {
    return Error{
        "a drainage may not sit under a transform, warp or erosion: its rivers and "
        "lakes join the water layer where the drainage computes them",
        pointer_join(reader.pointer(), "type")};
  }
  const std::optional<GridSquare> square = read_grid_square(reader, context, 256);
  if (!square) return reader.error();
  const int resolution = square->resolution;
  RiverParams p;
  const double area = square->size * square->size;
  // Defaults follow the square's size, within the ranges.
  p.channel_area =
      reader.number("channel_area", std::clamp(0.002 * area, kMinChannelArea, kMaxChannelArea),
                    {kMinChannelArea, kMaxChannelArea});
  p.width = reader.number("width", std::clamp(square->size / 500.0, 1e-3, kMaxChannelWidth),
                          {1e-3, kMaxChannelWidth});
  p.depth = reader.number("depth", std::clamp(p.width / 8.0, 1e-3, kMaxChannelDepth),
                          {1e-3, kMaxChannelDepth});
  p.bank_slope = reader.number("bank_slope", 0.5, {kMinBankSlope, kMaxBankSlope});
  p.lake_depth = reader.number("lake_depth", 1.0, {1e-3, kMaxLakeDepth});
  if (reader.has("sea_level")) p.sea_level = reader.number("sea_level", std::nullopt, {-1e5, 1e5});
  if (!reader.ok()) return reader.error();

  // The cost first, in the erosion budget: refused before anything is sampled.
  if (Status charged =
          charge_bake(context, reader.pointer(), kWorkPerCell * resolution * resolution, *square);
      !charged) {
    return charged.error();
  }

  NodeParams out;
  out.canonical = reader.canonical();
  BakeCache::Grid grid;
  if (!context.options->bake) {
    // Validated and costed; the grids are made when the scene is parsed to be served. Flat
    // stand-ins keep the node's bounds and the water layer's shape defined meanwhile.
    context.unbaked = true;
    const float base = context.base_elevation;
    Result<std::vector<float>> ground =
        pack_baked_grid(std::vector<float>(4, base), 2, *square, true);
    Result<std::vector<float>> water =
        pack_baked_grid(std::vector<float>(4, base - kDryDepth), 2, *square, true,
                        std::vector<float>(4, 0.0f));  // no water until the rivers are made
    if (!ground || !water) {
      return Error{"the square cannot be mapped", pointer_join(reader.pointer(), "size")};
    }
    grid = join(std::move(*ground), *water);
  } else {
    // Sampled, drained, carved and packed. Each step fails only on what the parameters above
    // exclude, so a failure here is this module's (internal).
    const auto bake = [&]() -> BakeCache::Grid {
      const std::vector<float> samples = sample_child(child, context.base_elevation, *square);
      Result<RiverNetwork> rivers =
          carve_rivers({resolution, resolution, square->step(), samples, std::nullopt, {}}, p);
      if (!rivers) return nullptr;
      Result<std::vector<float>> ground =
          pack_baked_grid(std::move(rivers->terrain), resolution, *square, true);
      Result<std::vector<float>> water = pack_baked_grid(
          std::move(rivers->water), resolution, *square, true, std::move(rivers->water_weight));
      if (!ground || !water) return nullptr;
      return join(std::move(*ground), *water);
    };
    grid = bake_grid(context, "drainage/2", out.canonical, bake);
  }
  if (!grid) {
    return Error{"the drainage grids could not be made", reader.pointer(), ErrorKind::internal};
  }
  const auto ground_floats = static_cast<std::ptrdiff_t>((*grid)[0]);
  out.pool.assign(grid->begin() + 1, grid->begin() + 1 + ground_floats);
  auto water = std::make_shared<Node>();
  // A grid with local bounds, its weights' included, like the drainage's own: the water's
  // evaluators skip what lies far from water (TileGenerator::height_tile_with_water).
  water->type = &drainage_node_type();
  water->params.pool.assign(grid->begin() + 1 + ground_floats, grid->end());
  context.water_layers.push_back(std::move(water));
  return out;
}

}  // namespace

const NodeType& drainage_node_type() {
  static const NodeType type{
      .id = 6,
      .name = "drainage",
      .category = NodeCategory::primitive,
      .min_children = 1,
      .max_children = 1,
      .summary =
          "its child with rivers and lakes: depressions kept as lakes at their spill level, "
          "channels where flow gathers, carved as wide and deep as their discharge, all in the "
          "water layer",
      .parse = parse_drainage,
      .kernels = {.leaf = image_node_type().kernels.leaf,
                  .leaf_bounds = baked_grid_bounds,
                  .varies_with_spacing = never_varies_with_spacing},
      .example_json = R"({"type": "drainage", "resolution": 48, "channel_area": 40000,
 "children": [{"type": "disc", "center": [0, 0], "radius": 600, "elevation": 300,
   "noise": {"kind": "ridged", "amplitude": 200, "wavelength": 400, "octaves": 4, "seed": 3}}]})",
      .loop_iterations = baked_grid_loop_iterations,
      .shader = {.call = "image_leaf($at, $p)", .heavy = true},
  };
  return type;
}

}  // namespace terrain
