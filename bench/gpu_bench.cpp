// GPU evaluation throughput (f(p)/s: heights and gradients per second) on the machine's EGL
// device (llvmpipe where there is no GPU), next to the CPU interpreter on the same grid.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <memory>
#include <string>

#include "gpu/evaluator.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"

namespace {

struct Fixture {
  terrain::Program program;
  terrain::Box2 area;
};

const Fixture& winding_road() {
  static const Fixture fixture = [] {
    auto scene = terrain::load_scene_file(std::string(TERRAIN_SOURCE_DIR) +
                                          "/config/scenes/winding-road.json");
    if (!scene) throw std::runtime_error(scene.error().message);
    auto program = terrain::compile(*scene);
    if (!program) throw std::runtime_error(program.error().message);
    return Fixture{std::move(program).value(), scene->area()};
  }();
  return fixture;
}

gpu::GpuEvaluator* evaluator() {
  static std::unique_ptr<gpu::GpuEvaluator> e = [] {
    auto created = gpu::GpuEvaluator::create();
    return created ? std::move(created).value() : nullptr;
  }();
  return e.get();
}

terrain::GridSpec grid_of(const Fixture& f, int side) {
  terrain::GridSpec grid;
  grid.width = grid.height = side;
  grid.step = static_cast<double>(std::max(f.area.size().x, f.area.size().y)) / (side - 1);
  grid.origin_x = f.area.lo.x;
  grid.origin_y = f.area.lo.y;
  return grid;
}

void BM_GpuWindingRoad(benchmark::State& state) {
  gpu::GpuEvaluator* gpu = evaluator();
  if (gpu == nullptr) {
    state.SkipWithError("no EGL device");
    return;
  }
  const Fixture& f = winding_road();
  const terrain::GridSpec grid = grid_of(f, static_cast<int>(state.range(0)));
  if (!gpu->evaluate_grid(f.program, grid)) {  // warm-up: upload and shader compilation
    state.SkipWithError("evaluation failed");
    return;
  }
  for (auto _ : state) {
    auto result = gpu->evaluate_grid(f.program, grid);
    benchmark::DoNotOptimize(result);
  }
  state.SetItemsProcessed(state.iterations() * grid.width * grid.height);
  state.SetLabel(gpu->device_name());
}
BENCHMARK(BM_GpuWindingRoad)->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_CpuWindingRoadOneThread(benchmark::State& state) {
  const Fixture& f = winding_road();
  const terrain::GridSpec grid = grid_of(f, static_cast<int>(state.range(0)));
  for (auto _ : state) {
    auto result = terrain::evaluate_grid(f.program, grid, 1);
    benchmark::DoNotOptimize(result);
  }
  state.SetItemsProcessed(state.iterations() * grid.width * grid.height);
}
BENCHMARK(BM_CpuWindingRoadOneThread)->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond);

}  // namespace
