// What the nodes that bake their child into a grid (erosion, drainage) share: the square they
// cover, sampling the child on it, the content hash their grids are cached by, and packing a grid
// as an image primitive on its square (bicubic, mapping mode 2) with a table of local bounds.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "terrain/heightfield.hpp"
#include "terrain/node.hpp"
#include "terrain/result.hpp"
#include "terrain/scene.hpp"

namespace terrain {

class FieldReader;

/// The square a baked grid covers and how finely: `resolution` samples a side, row 0 north.
struct GridSquare {
  Vec2 center;
  double size = 0.0;
  int resolution = 0;
  float margin = 0.02f;  ///< the image's weight falloff, a share of the side
  double step() const { return size / (resolution - 1); }
  Vec2 south_west() const;
};

/// Reads "center", "size" (defaults: the child's support), "resolution" and "margin"; fails,
/// naming the field, when the child's support is unbounded and the square is not given.
std::optional<GridSquare> read_grid_square(FieldReader& reader, const ParseContext& context,
                                           int default_resolution);

/// Adds a baking node's cost to the scene's — `work` cell-steps of its solver, and the node
/// evaluations that sampling its child on the square takes — and refuses it, as unsupported and
/// naming the node's `resolution`, when the scene's bakes together pass the limits.
Status charge_bake(ParseContext& context, const std::string& pointer, std::int64_t work,
                   const GridSquare& square);

/// The child's surface over the square as a raster (row 0 north): α f + (1 − α) base, sampled
/// at the grid's own level of detail so the grid does not alias finer detail.
std::vector<float> sample_child(const Node& child, float base_elevation, const GridSquare& square);

/// A baking node's grid: found in the parse's bake cache by the content hash of `kind` (with its
/// version), the node's canonical fields, the base elevation and the child subtree's bytes, or
/// made by `make` there; made directly when the parse has no cache.
BakeCache::Grid bake_grid(const ParseContext& context, std::string_view kind,
                          const nlohmann::json& canonical,
                          const std::function<BakeCache::Grid()>& make);

/// An image primitive's pool for a raster of side² samples (row 0 north) on the square: bicubic,
/// affinely mapped, and — with `local_bounds` — the table that baked_grid_bounds reads; with
/// `weights` (side² values, row 0 north), the primitive's weight inside the square follows them.
/// Fails only on rasters Heightfield refuses.
Result<std::vector<float>> pack_baked_grid(std::vector<float> samples, int side,
                                           const GridSquare& square, bool local_bounds,
                                           std::vector<float> weights = {});

/// Bounds over the query box from the local bounds of the tiles it may touch.
NodeBounds baked_grid_bounds(const float* params, const BoundsQuery& query);

/// The image primitive's mapping steps, and the bicubic's 4 × 4 sample loop.
std::size_t baked_grid_loop_iterations(std::span<const float> params);

}  // namespace terrain
