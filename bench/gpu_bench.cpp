// GPU evaluation throughput (f(p)/s: heights and gradients per second) on the machine's EGL
// device (llvmpipe where there is no GPU), next to the CPU interpreter on the same grid; tiles
// batched in one dispatch against one dispatch per tile; and sphere-traced pictures (GPU
// trace.glsl against terrain::render). The 1920×1080 picture cases run only when asked for
// (TERRAIN_BENCH_1080=1): on llvmpipe one frame takes minutes.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "gpu/evaluator.hpp"
#include "gpu/program_glsl.hpp"
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

gpu::GpuEvaluator* evaluator(gpu::ShaderMode mode = gpu::GpuOptions{}.shaders) {
  static std::map<gpu::ShaderMode, std::unique_ptr<gpu::GpuEvaluator>> evaluators;
  auto& e = evaluators[mode];
  if (!e) {
    gpu::GpuOptions options;
    options.shaders = mode;
    auto created = gpu::GpuEvaluator::create(options);
    if (created) e = std::move(created).value();
  }
  return e.get();
}

constexpr const char* kExampleScenes[] = {"butte",      "craters",        "hills-river",
                                          "lake-dunes", "mountain-range", "winding-road"};
constexpr const char* kModeNames[] = {"interpreter", "pruned", "unrolled", "automatic"};

const Fixture& example(std::int64_t index) {
  static std::map<std::int64_t, Fixture> fixtures;
  auto it = fixtures.find(index);
  if (it == fixtures.end()) it = fixtures.emplace(index, load(kExampleScenes[index])).first;
  return it->second;
}

terrain::GridSpec grid_of(const Fixture& f, int side) {
  terrain::GridSpec grid;
  grid.width = grid.height = side;
  grid.step = static_cast<double>(std::max(f.area.size().x, f.area.size().y)) / (side - 1);
  grid.origin_x = f.area.lo.x;
  grid.origin_y = f.area.lo.y;
  return grid;
}

// Evaluates `grid` once to warm up (upload, shader compilation), then once per iteration.
void time_grid(benchmark::State& state, gpu::GpuEvaluator& gpu, const terrain::Program& program,
               const terrain::GridSpec& grid) {
  if (!gpu.evaluate_grid(program, grid)) {
    state.SkipWithError("evaluation failed");
    return;
  }
  for (auto _ : state) {
    auto result = gpu.evaluate_grid(program, grid);
    benchmark::DoNotOptimize(result);
  }
  state.SetItemsProcessed(state.iterations() * grid.width * grid.height);
}

// Renders the example from its default camera once to warm up (shader, program, bounds grid),
// then once per iteration; items are pixels.
void time_picture(benchmark::State& state, gpu::GpuEvaluator& gpu, const Fixture& f, int width,
                  int height) {
  const terrain::Camera camera = terrain::default_camera(f.program, f.area, width, height);
  if (!gpu.render(f.program, f.area, camera)) {
    state.SkipWithError("rendering failed");
    return;
  }
  std::int64_t steps = 0;
  for (auto _ : state) {
    auto picture = gpu.render(f.program, f.area, camera);
    if (picture) steps = picture->total_steps;
    benchmark::DoNotOptimize(picture);
  }
  state.SetItemsProcessed(state.iterations() * width * height);
  // Sphere-tracing steps per pixel: what tighter Lipschitz bounds save (bench/bounds_bench.cpp).
  state.counters["steps_per_pixel"] = static_cast<double>(steps) / (width * height);
}

void BM_GpuWindingRoad(benchmark::State& state) {
  gpu::GpuEvaluator* gpu = evaluator();
  if (gpu == nullptr) {
    state.SkipWithError("no EGL device");
    return;
  }
  const Fixture& f = winding_road();
  const terrain::GridSpec grid = grid_of(f, static_cast<int>(state.range(0)));
  time_grid(state, *gpu, f.program, grid);
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

// Every example in each shader mode (gpu::ShaderMode): a 256² grid, and a 64×40 picture from
// the default camera. Args: scene index, mode. The unrolled mode is measured only where
// automatic would choose it: unrolling the larger examples takes llvmpipe minutes to compile.
// The evaluator and example of a shader-mode case, or null (the case skipped, saying why).
std::pair<gpu::GpuEvaluator*, const Fixture*> shader_mode_case(benchmark::State& state) {
  const auto mode = static_cast<gpu::ShaderMode>(state.range(1));
  gpu::GpuEvaluator* gpu = evaluator(mode);
  if (gpu == nullptr) {
    state.SkipWithError("no EGL device");
    return {nullptr, nullptr};
  }
  const Fixture& f = example(state.range(0));
  if (mode == gpu::ShaderMode::unrolled && !gpu::unroll_pays(f.program)) {
    state.SkipWithError("not unrolled: too large to compile quickly (gpu::unroll_pays)");
    return {nullptr, nullptr};
  }
  state.SetLabel(std::string(kExampleScenes[state.range(0)]) + " " + kModeNames[state.range(1)]);
  return {gpu, &f};
}

void BM_GpuShaderModeGrid(benchmark::State& state) {
  const auto [gpu, fixture] = shader_mode_case(state);
  if (gpu == nullptr) return;
  const Fixture& f = *fixture;
  const terrain::GridSpec grid = grid_of(f, 256);
  time_grid(state, *gpu, f.program, grid);
}

void BM_GpuShaderModePicture(benchmark::State& state) {
  const auto [gpu, fixture] = shader_mode_case(state);
  if (gpu == nullptr) return;
  const Fixture& f = *fixture;
  time_picture(state, *gpu, f, 64, 40);
}

void shader_mode_args(benchmark::internal::Benchmark* b) {
  for (int scene = 0; scene < 6; ++scene) {
    for (int mode = 0; mode < 3; ++mode) b->Args({scene, mode});
  }
}
BENCHMARK(BM_GpuShaderModeGrid)
    ->Apply(shader_mode_args)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_GpuShaderModePicture)
    ->Apply(shader_mode_args)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

// Pictures of craters from its default camera; items are pixels.
void BM_GpuPicture(benchmark::State& state) {
  gpu::GpuEvaluator* gpu = evaluator();
  if (gpu == nullptr) {
    state.SkipWithError("no EGL device");
    return;
  }
  time_picture(state, *gpu, craters(), static_cast<int>(state.range(0)),
               static_cast<int>(state.range(1)));
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
