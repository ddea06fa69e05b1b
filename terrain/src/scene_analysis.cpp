#include "terrain/scene_analysis.hpp"

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "terrain/evaluate.hpp"

namespace terrain {

Result<nlohmann::json> analyze_scene(const Scene& scene, const Program& program,
                                     const SceneAnalysisOptions& options,
                                     AnalysisPicture* picture) {
  const int n = options.size;
  if (n < 2 || n > kMaxSceneAnalysisSide) {
    return Error{"must be an integer from 2 to " + std::to_string(kMaxSceneAnalysisSide), "/size"};
  }
  const Box2 area = options.area.value_or(scene.area());
  if (area.empty() || !std::isfinite(area.lo.x) || !std::isfinite(area.lo.y) ||
      !std::isfinite(area.hi.x) || !std::isfinite(area.hi.y) || !(area.size().x > 0.0f) ||
      !(area.size().y > 0.0f)) {
    return Error{"must be a finite box X0 < X1, Y0 < Y1", "/area"};
  }
  // The same grid as `terrain grid`: N × N samples over a square of the area's larger side.
  const double side = std::max(area.size().x, area.size().y);
  const GridSpec spec{area.lo.x, area.lo.y, side / (n - 1), n, n, -1.0f};
  const std::vector<float> elevation = evaluate_grid(program, spec, 1).elevation;

  // Water surfaces flatter than this (metres per metre) stand: lakes. A drainage's rivers fall
  // faster than that wherever they are a channel (δ per cell at least, rivers.hpp).
  constexpr float kStandingSlope = 1e-5f;
  // Water of the scene's water layer (weight ≥ 0.5, surface above the ground) is wet land: flow
  // crosses its lakes and rivers, and no pit or closed depression is counted under them.
  std::vector<std::uint8_t> water;
  std::int64_t water_cells = 0;
  if (scene.water) {
    Result<Program> water_program = compile_water(scene);
    if (!water_program) return water_program.error();
    Evaluator e(*water_program);
    water.assign(elevation.size(), 0);
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const std::size_t c =
            static_cast<std::size_t>(j) * static_cast<std::size_t>(n) + static_cast<std::size_t>(i);
        const Vec2 p{static_cast<float>(spec.origin_x + i * spec.step),
                     static_cast<float>(spec.origin_y + j * spec.step)};
        const FieldSample s = e.sample(p, static_cast<float>(spec.step));
        if (s.weight >= 0.5f && s.elevation > elevation[c]) {
          // A flat surface stands (a lake); one that falls flows (a river).
          const float fall = std::hypot(s.elevation_gradient.x, s.elevation_gradient.y);
          water[c] = fall < kStandingSlope ? kStandingWater : kFlowingWater;
          ++water_cells;
        }
      }
    }
  }
  const ElevationGrid grid{n, n, spec.step, elevation, options.sea_level, {}, water};
  Result<Geomorphometry> figures = analyze(grid, options.analysis, picture);
  if (!figures) return figures.error();
  nlohmann::json out = to_json(*figures);
  out["input"] = {
      {"kind", "scene"},
      {"scene_hash", scene.hash},
      {"area", {spec.origin_x, spec.origin_y, spec.origin_x + side, spec.origin_y + side}},
      {"water_cells", water_cells}};
  if (options.sea_level) out["input"]["sea_level_m"] = *options.sea_level;
  return out;
}

}  // namespace terrain
