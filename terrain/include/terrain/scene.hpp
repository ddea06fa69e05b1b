// Scene JSON (docs/scene-format.md): parsing with validation that names the offending JSON
// pointer, canonical serialisation, and the content hash that identifies a scene version.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/image_io.hpp"
#include "terrain/material.hpp"
#include "terrain/node.hpp"
#include "terrain/result.hpp"

namespace terrain {

inline constexpr std::string_view kSceneFormat = "terrain-scene/1";

/// Resolves an image reference from a scene (a file path, or a content hash in the server's store)
/// to its pixels (terrain/image_io.hpp reads and decodes them).
using ImageResolver = std::function<Result<Raster>(std::string_view reference)>;

/// Limits applied while parsing untrusted scenes.
struct SceneLimits {
  int max_depth = 64;     ///< nesting of nodes, definitions expanded
  int max_nodes = 20000;  ///< nodes after instancing is expanded
  std::int64_t max_image_pixels = 16 * 1024 * 1024;
  std::size_t max_pool_floats = 64 * 1024 * 1024;
  /// The name is a label that every version listing repeats: bounded so a listing stays small.
  std::size_t max_name_bytes = 256;
  /// Erosion nodes: the largest grid side, and the work of every erosion of the scene together
  /// (terrain::erosion_work's cell-steps, and grid cells × nodes of the eroded subtree) — what a
  /// parse may cost before it is refused.
  int max_erosion_side = 2048;
  std::int64_t max_erosion_work = std::int64_t{1} << 24;
  std::int64_t max_erosion_evaluations = std::int64_t{1} << 30;
};

/// A number a node parser checked, with the range it was checked against (inclusive unless
/// `exclusive_min`). Ranges are checked on the value as stored, a float32: see
/// docs/scene-format.md, "Numbers".
struct DeclaredNumber {
  std::string pointer;  ///< JSON pointer of the number (an array element for [x, y] pairs)
  double min = 0.0;
  double max = 0.0;
  bool exclusive_min = false;
  bool integer = false;
};

/// Grids that nodes bake while a scene is parsed (erosion), kept by the content hash of all that
/// made them, so that parsing a scene again (a new version that left the subtree alone, the
/// load after a store) does not redo the work. Thread-safe and single-flight: while one thread
/// makes a grid, others asking for it wait for that one. At most `max_bytes` of grids are kept,
/// the least recently used dropped first.
class BakeCache {
 public:
  using Grid = std::shared_ptr<const std::vector<float>>;
  explicit BakeCache(std::size_t max_bytes) : max_bytes_(max_bytes) {}
  /// The grid of `key`, made by `make` (on this thread) when no one has it; null when `make`
  /// gives null (a failure, not kept: the next caller tries again).
  Grid get_or_make(const std::string& key, const std::function<Grid()>& make);
  std::size_t bytes() const;

  /// Stores beyond this process (a server's disk cache, Redis), by the same content key: a
  /// memory miss looks there before making the grid, and a grid made here is given to them, so
  /// a replica or a restart does not make again what another made. Either may be empty.
  struct Shared {
    std::function<std::optional<std::vector<float>>(const std::string& key)> find;
    std::function<void(const std::string& key, const std::vector<float>& grid)> insert;
  };
  /// Set before the cache is first used.
  void share_with(Shared shared);
  /// Grids made in this process, and grids found in the shared stores instead.
  std::int64_t made() const;
  std::int64_t shared_hits() const;

 private:
  void insert(const std::string& key, Grid grid);  // mutex_ held

  mutable std::mutex mutex_;
  std::condition_variable made_;
  std::set<std::string, std::less<>> in_flight_;
  std::size_t max_bytes_;
  std::size_t bytes_ = 0;
  std::uint64_t clock_ = 0;
  std::map<std::string, std::pair<Grid, std::uint64_t>, std::less<>> entries_;
  Shared shared_;
  std::int64_t made_count_ = 0;
  std::int64_t shared_hits_ = 0;
};

struct ParseOptions {
  SceneLimits limits;
  ImageResolver images;  ///< required only by scenes with image primitives
  /// false: validate and canonicalise only (name, hash, canonical text): nodes that bake a grid
  /// check their parameters and cost but do not compute it, and the scene, marked unbaked, is
  /// refused by compile(). Storing a built-in scene needs no more.
  bool bake = true;
  /// Where baked grids are looked up and kept (none: always computed).
  BakeCache* bake_cache = nullptr;
  /// When set, every number that node parsers check is appended here with its range: the
  /// property tests enumerate each node type's parameters and limits this way.
  std::vector<DeclaredNumber>* declared_numbers = nullptr;
};

/// Optional geographic anchor of the scene's origin (used by geographic tilings).
struct Georeference {
  double latitude = 0.0;
  double longitude = 0.0;
  double heading = 0.0;  ///< degrees clockwise from north of the scene's +y axis
};

/// A parsed, validated scene.
struct Scene {
  std::string name;
  std::uint32_t seed = 0;
  float base_elevation = 0.0f;  ///< elevation where no primitive has weight
  std::optional<Box2> extent;   ///< the declared square of interest (tiles cover it)
  Georeference georeference;
  /// The colours of its pictures and colour tiles ("material"; defaults when absent).
  Material material;
  NodePtr root;
  /// Optional water layer (Génevaux Fig. 20): a second tree whose elevation is the water surface
  /// and whose weight marks where water is (weight ≥ 0.5 and surface above the terrain).
  NodePtr water;
  std::map<std::string, NodePtr, std::less<>> definitions;
  NodeBounds bounds;         ///< global bounds of the root at full detail
  NodeBounds water_bounds;   ///< global bounds of the water layer, when there is one
  nlohmann::json canonical;  ///< canonical JSON (defaults explicit), what serialise() writes
  std::string hash;          ///< "sha256:<hex>" of canonical_text()
  /// False when parsed with ParseOptions::bake = false and some node skipped its grid: such a
  /// scene has its canonical form and hash but cannot be compiled.
  bool baked = true;

  /// The canonical text: keys sorted, no whitespace, shortest round-trip numbers.
  std::string canonical_text() const { return canonical.dump(); }
  /// The extent, or the root's support when none is declared.
  Box2 area() const;
};

/// Parses and validates a scene. Errors name the JSON pointer of the offending field.
Result<Scene> parse_scene(const nlohmann::json& document, const ParseOptions& options = {});
/// The same from text (JSON syntax errors are reported with their byte offset).
Result<Scene> parse_scene_text(std::string_view text, const ParseOptions& options = {});

/// Reads and parses a scene file; images it references are read relative to the file's folder
/// unless `options.images` is already set. Unreadable files are errors with an empty pointer.
Result<Scene> load_scene_file(const std::string& path, ParseOptions options = {});

/// Hex SHA-256 of a byte string.
std::string sha256_hex(std::string_view bytes);

/// State shared by node parsers while a scene is parsed.
struct ParseContext {
  std::uint32_t scene_seed = 0;
  float base_elevation = 0.0f;
  /// The children of the node being parsed (already parsed): nodes that bake their subtree into
  /// their own parameters (erosion) read them.
  std::span<const NodePtr> children;
  /// Erosion work spent by the nodes parsed so far (checked against SceneLimits).
  std::int64_t erosion_work = 0;
  std::int64_t erosion_evaluations = 0;
  /// Set by a node that skipped baking its grid (ParseOptions::bake = false).
  bool unbaked = false;
  /// Ancestors of the node being parsed that move or reshape their subtree (transforms, warps,
  /// nodes that bake their child): a drainage's water, in the scene's frame, cannot follow them.
  int reshaping_ancestors = 0;
  /// Whether the water tree (/water) is being parsed.
  bool in_water_tree = false;
  /// Water layers made by nodes of the terrain tree (a drainage's rivers and lakes), in parse
  /// order; the scene's water layer shows them over its own.
  std::vector<NodePtr> water_layers;
  const ParseOptions* options = nullptr;
  /// Derives a node's noise seed from the scene seed and the node's own "seed" field.
  std::uint32_t noise_seed(std::int64_t node_seed) const;
};

}  // namespace terrain
