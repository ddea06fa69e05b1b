// Which tiles an edit can change (docs/tiles.md, "Which tiles an edit changes"): two versions of a
// scene are compared once, then asked, per scheme, zoom, tile address and format, whether the
// tile's bytes may differ. The answer is sound — a tile called unchanged is byte-identical in both
// versions, in every format, so a server may answer it from the older version's cache — and tight:
// a tile is called changed only where an edited node can reach one of the tile's samples (with its
// weight, where its parent ignores it without weight), judged with the nodes' bounds over the
// tile's footprint at the tile's level of detail.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "terrain/math.hpp"
#include "terrain/scene.hpp"
#include "terrain/tile.hpp"
#include "terrain/tile_products.hpp"
#include "terrain/tile_source.hpp"

namespace terrain {

/// What differs between two versions of a scene, for tile invalidation. Immutable once made, so
/// one SceneChange may be queried from several threads.
class SceneChange {
 public:
  /// Compares two parsed scenes with their tile sources (TileSource::from_scene of each). Keeps
  /// the shared pointers it needs; cheap to keep for a while. Every pointer must be non-null.
  static SceneChange between(std::shared_ptr<const Scene> before,
                             std::shared_ptr<const TileSource> before_source,
                             std::shared_ptr<const Scene> after,
                             std::shared_ptr<const TileSource> after_source);

  /// No tile of any format can differ.
  bool unchanged() const;
  /// A scene-wide change (seed, base elevation, tile area, georeference, or an edit whose effect
  /// has no bound): every tile of every format may differ.
  bool everything() const;
  /// Every tile in this format may differ although the change itself is local: gray16 PNG (its
  /// offset and scale), quantized-mesh (its edge quantum) and glb/drc (their position lattice)
  /// follow the scene's elevation range. True as well when everything() is.
  bool format_global(TileFormat format) const;
  /// A scene-plane box bounding every sample that may differ; nullopt when unchanged() and when
  /// everything().
  std::optional<Box2> box() const;
  /// False only when the tile's bytes are provably identical in both versions. Requests that
  /// ProductMaker would refuse (bad address, size or scheme) answer true.
  bool tile_may_change(TileScheme scheme, const TileAddress& address, TileFormat format,
                       const ProductOptions& options) const;
  /// The tiles of (scheme, z) for which tile_may_change holds, in quadtree order, found by descent
  /// from zoom 0 (cost ∝ answer size × z), at most `limit` of them; `*truncated` (when given) says
  /// whether more were left out. Empty for requests ProductMaker would refuse.
  std::vector<TileAddress> changed_tiles(TileScheme scheme, int z, TileFormat format,
                                         const ProductOptions& options, std::size_t limit,
                                         bool* truncated = nullptr) const;

  struct Data;  ///< what the comparison found (an implementation detail of scene_diff.cpp)

 private:
  explicit SceneChange(std::shared_ptr<const Data> data) : data_(std::move(data)) {}

  std::shared_ptr<const Data> data_;
};

}  // namespace terrain
