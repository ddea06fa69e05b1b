// How tight the Lipschitz bounds are, and what that costs the sphere tracer, on every example
// scene (Génevaux §7: a sphere tracer steps h / λ, so a bound k times too loose takes about k
// times the steps near the terrain).
//
// BM_BoundTightness: the program's global bound over the whole plane at full detail, against the
// steepest slope found by dense sampling (the largest exact |∇f| on a grid of `spacing` metres
// over the scene's extent). Counters: global_bound, steepest_slope, ratio (≥ 1 while the bound
// is sound, and the nearer 1 the faster a tracer falling back on it).
// Counters cell_*: the same for local bounds over the 32 × 32 cells of the extent (the median and
// 90th percentile of bound / steepest slope in the cell, over cells that are not flat).
// BM_TracedPicture: the default camera's picture on one thread (bounds grid included); counter
// steps_per_pixel.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"
#include "terrain/sphere_trace.hpp"

#include "example_scenes.hpp"

namespace {

using namespace terrain;

// The largest |∇f| at full detail on a grid of `spacing` metres over `area`, in strips so memory
// stays small whatever the spacing.
float steepest_slope(const Program& program, const Box2& area, double spacing) {
  const int columns = static_cast<int>(std::ceil(area.size().x / spacing)) + 1;
  const int rows = static_cast<int>(std::ceil(area.size().y / spacing)) + 1;
  constexpr int kStrip = 256;
  float steepest = 0.0f;
  for (int row = 0; row < rows; row += kStrip) {
    GridSpec grid{area.lo.x, area.lo.y + row * spacing,    spacing,
                  columns,   std::min(kStrip, rows - row), 0.0f};
    const GridResult r = evaluate_grid(program, grid, 0);
    for (std::size_t k = 0; k < r.elevation.size(); ++k) {
      steepest = std::max(steepest, std::hypot(r.gradient_x[k], r.gradient_y[k]));
    }
  }
  return steepest;
}

// Local bounds over the cells of a 32 × 32 grid on the scene's extent (about the cells a tracer
// looks bounds up in), against the steepest slope sampled in each cell on a 4 m grid.
struct CellTightness {
  float largest_bound = 0.0f;
  float median_ratio = 0.0f;
  float p90_ratio = 0.0f;
};

CellTightness cell_tightness(Evaluator& e, const Program& program, const Box2& area) {
  constexpr int kCells = 32;
  const Vec2 cell = area.size() * (1.0f / static_cast<float>(kCells));
  CellTightness out;
  std::vector<float> ratios;
  for (int j = 0; j < kCells; ++j) {
    for (int i = 0; i < kCells; ++i) {
      const Vec2 lo{area.lo.x + cell.x * static_cast<float>(i),
                    area.lo.y + cell.y * static_cast<float>(j)};
      const Box2 box{lo, lo + cell};
      const float bound = e.bounds({box, 0.0f}).elevation_lipschitz;
      out.largest_bound = std::max(out.largest_bound, bound);
      const float steepest = steepest_slope(program, box, 4.0);
      if (steepest > 0.05f) ratios.push_back(bound / steepest);  // flat cells say nothing
    }
  }
  std::sort(ratios.begin(), ratios.end());
  if (!ratios.empty()) {
    out.median_ratio = ratios[ratios.size() / 2];
    out.p90_ratio = ratios[ratios.size() * 9 / 10];
  }
  return out;
}

void BM_BoundTightness(benchmark::State& state, const std::string& name, double spacing) {
  const bench::LoadedExample& l = bench::load_example(name);
  Evaluator e(l.program);
  const float global = e.global_bounds().elevation_lipschitz;
  float steepest = 0.0f;
  for (auto _ : state) steepest = steepest_slope(l.program, l.scene.area(), spacing);
  state.counters["global_bound"] = global;
  state.counters["steepest_slope"] = steepest;
  state.counters["ratio"] = steepest > 0.0f ? global / steepest : 0.0;
  state.counters["spacing_m"] = spacing;
  const CellTightness cells = cell_tightness(e, l.program, l.scene.area());
  state.counters["cell_bound_max"] = cells.largest_bound;
  state.counters["cell_ratio_median"] = cells.median_ratio;
  state.counters["cell_ratio_p90"] = cells.p90_ratio;
}

// `lit`: with soft shadows and sky occlusion (render()'s default), else the sun and sky light
// without them; issue 21 asks the lit picture to cost at most 1.5 times the unlit one.
void BM_TracedPicture(benchmark::State& state, const std::string& name, bool lit) {
  const bench::LoadedExample& l = bench::load_example(name);
  const auto width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  const Camera camera = default_camera(l.program, l.scene.area(), width, height);
  RenderOptions options;
  options.threads = 1;
  options.shadows = lit;
  options.occlusion = lit;
  options.material = l.scene.material;
  std::optional<WaterRaster> water;
  if (l.scene.water) {
    water = water_raster(compile_water(l.scene).value(), l.scene.area());
    options.water = &*water;
  }
  std::int64_t steps = 0;
  for (auto _ : state) {
    const Picture picture = render(l.program, l.scene.area(), camera, options);
    steps = picture.total_steps;
    benchmark::DoNotOptimize(picture.rgb.data());
  }
  state.counters["steps_per_pixel"] = static_cast<double>(steps) / (width * height);
  state.SetItemsProcessed(state.iterations() * width * height);
}

const bool kRegistered = [] {
  for (const std::string& name : bench::example_names()) {
    benchmark::RegisterBenchmark(("BM_BoundTightness/" + name).c_str(), BM_BoundTightness, name,
                                 1.0)
        ->Unit(benchmark::kSecond)
        ->Iterations(1);
    for (const bool lit : {false, true}) {
      benchmark::RegisterBenchmark(("BM_TracedPicture/" + name + (lit ? "/lit" : "/unlit")).c_str(),
                                   BM_TracedPicture, name, lit)
          ->Args({160, 100})
          ->Unit(benchmark::kMillisecond)
          ->Iterations(1);
    }
  }
  return true;
}();

}  // namespace
