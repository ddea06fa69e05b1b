// GPU evaluation throughput (f(p)/s: heights and gradients per second) on the machine's EGL
// device (llvmpipe where there is no GPU), next to the CPU interpreter on the same grid; tiles
// batched in one dispatch against one dispatch per tile; and sphere-traced pictures (GPU
// trace.glsl against terrain::render). The 1920×1080 picture cases run only when asked for
// (TERRAIN_BENCH_1080=1): on llvmpipe one frame takes minutes.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "gpu/evaluator.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"
#include "terrain/sphere_trace.hpp"

namespace {

struct Fixture {
  terrain::Program program;
  terrain::Box2 area;
};

Fixture load(const char* name) {
  auto scene = terrain::load_scene_file(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/" + name +
                                        ".json");
  if (!scene) throw std::runtime_error(scene.error().message);
  auto program = terrain::compile(*scene);
  if (!program) throw std::runtime_error(program.error().message);
  return Fixture{std::move(program).value(), scene->area()};
}

const Fixture& winding_road() {
  static const Fixture fixture = load("winding-road");
  return fixture;
}

const Fixture& craters() {
  static const Fixture fixture = load("craters");
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

// 16 tiles of 64² (a zoom-2 local tiling of the area): one dispatch per tile, or all in one.
std::vector<terrain::GridSpec> zoom2_tiles(const Fixture& f) {
  std::vector<terrain::GridSpec> tiles;
  const double side = static_cast<double>(std::max(f.area.size().x, f.area.size().y)) / 4.0;
  for (int k = 0; k < 16; ++k) {
    terrain::GridSpec g;
    g.width = g.height = 64;
    g.step = side / 64.0;
    g.origin_x = f.area.lo.x + (k % 4) * side + 0.5 * g.step;
    g.origin_y = f.area.lo.y + (k / 4) * side + 0.5 * g.step;
    tiles.push_back(g);
  }
  return tiles;
}

void BM_GpuTilesOneByOne(benchmark::State& state) {
  gpu::GpuEvaluator* gpu = evaluator();
  if (gpu == nullptr) {
    state.SkipWithError("no EGL device");
    return;
  }
  const std::vector<terrain::GridSpec> tiles = zoom2_tiles(winding_road());
  static_cast<void>(gpu->evaluate_grid(winding_road().program, tiles.front()));
  for (auto _ : state) {
    for (const terrain::GridSpec& g : tiles) {
      auto result = gpu->evaluate_grid(winding_road().program, g);
      benchmark::DoNotOptimize(result);
    }
  }
  state.SetItemsProcessed(state.iterations() * 16 * 64 * 64);
}
BENCHMARK(BM_GpuTilesOneByOne)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_GpuTilesBatched(benchmark::State& state) {
  gpu::GpuEvaluator* gpu = evaluator();
  if (gpu == nullptr) {
    state.SkipWithError("no EGL device");
    return;
  }
  const std::vector<terrain::GridSpec> tiles = zoom2_tiles(winding_road());
  static_cast<void>(gpu->evaluate_grids(winding_road().program, tiles));
  for (auto _ : state) {
    auto result = gpu->evaluate_grids(winding_road().program, tiles);
    benchmark::DoNotOptimize(result);
  }
  state.SetItemsProcessed(state.iterations() * 16 * 64 * 64);
}
BENCHMARK(BM_GpuTilesBatched)->Unit(benchmark::kMillisecond)->UseRealTime();

// Pictures of craters from its default camera; items are pixels.
void BM_GpuPicture(benchmark::State& state) {
  gpu::GpuEvaluator* gpu = evaluator();
  if (gpu == nullptr) {
    state.SkipWithError("no EGL device");
    return;
  }
  const Fixture& f = craters();
  const auto width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  const terrain::Camera camera = terrain::default_camera(f.program, f.area, width, height);
  if (!gpu->render(f.program, f.area, camera)) {  // warm-up: shader, program and bounds grid
    state.SkipWithError("rendering failed");
    return;
  }
  for (auto _ : state) {
    auto picture = gpu->render(f.program, f.area, camera);
    benchmark::DoNotOptimize(picture);
  }
  state.SetItemsProcessed(state.iterations() * width * height);
  state.SetLabel(gpu->device_name());
}
BENCHMARK(BM_GpuPicture)
    ->Args({192, 108})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

void BM_CpuPicture(benchmark::State& state) {
  const Fixture& f = craters();
  const auto width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  const terrain::Camera camera = terrain::default_camera(f.program, f.area, width, height);
  terrain::RenderOptions options;
  options.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (auto _ : state) {
    auto picture = terrain::render(f.program, f.area, camera, options);
    benchmark::DoNotOptimize(picture);
  }
  state.SetItemsProcessed(state.iterations() * width * height);
}
BENCHMARK(BM_CpuPicture)
    ->Args({192, 108})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);
// Full-HD frames, registered only with TERRAIN_BENCH_1080=1: on llvmpipe one frame takes
// minutes, and the default run stays short.
const bool registered_1080 = [] {
  if (std::getenv("TERRAIN_BENCH_1080") == nullptr) return false;
  for (auto* b : {benchmark::RegisterBenchmark("BM_GpuPicture1080", BM_GpuPicture),
                  benchmark::RegisterBenchmark("BM_CpuPicture1080", BM_CpuPicture)}) {
    b->Args({1920, 1080})->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
  }
  return true;
}();

}  // namespace
