// The geomorphometry of a scene (docs/analysis.md): its terrain sampled on a square grid over
// an area, the water of its water layer taken out of the land, then analyze(). What
// `terrain analyze SCENE.json` prints and GET /api/v1/scenes/{ref}/analysis.json serves.
#pragma once

#include <optional>

#include <nlohmann/json.hpp>

#include "terrain/geomorphometry.hpp"
#include "terrain/math.hpp"
#include "terrain/program.hpp"
#include "terrain/result.hpp"
#include "terrain/scene.hpp"

namespace terrain {

/// The largest analysis grid side the server and the CLI accept.
inline constexpr int kMaxSceneAnalysisSide = 4096;

struct SceneAnalysisOptions {
  int size = 512;                  ///< samples per side, 2 to kMaxSceneAnalysisSide
  std::optional<Box2> area;        ///< the scene's area() by default; the grid is a square of its
                                   ///< larger side from its lower corner, as `terrain grid` samples
  std::optional<float> sea_level;  ///< cells at or below are sea
  AnalysisOptions analysis;
};

/// Samples `program` (the scene's compiled terrain) and the scene's water layer, then analyses.
/// Errors name the field: /size, /area, /sea_level, and analyze()'s.
/// With `picture`, also draws the grid (draw_drainage).
Result<nlohmann::json> analyze_scene(const Scene& scene, const Program& program,
                                     const SceneAnalysisOptions& options = {},
                                     AnalysisPicture* picture = nullptr);

}  // namespace terrain
