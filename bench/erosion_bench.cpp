// The erosion solver on one core (issue target: a 1024² grid ≤ 2 s): rough value-noise land of
// 1 km relief over a 4 km square at 512², 1024² and 2048², default parameters but the example
// scenes' hillslope diffusion (6: 30 diffusion sub-steps per step on the finest grid); the most
// heap the call holds at once, its input and output included (heap_peak_MB: bench/heap_peak.hpp),
// and the process's peak resident set (peak_rss_MB, from getrusage; earlier runs' pages count too).
// The drainage's lakes, channels and carving on the same land (noise: many depressions, so the lake
// search works hardest).
#include <benchmark/benchmark.h>

#include <sys/resource.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "../tests/terrain/synthetic_land.hpp"
#include "heap_peak.hpp"
#include "terrain/erosion.hpp"
#include "terrain/rivers.hpp"

namespace {

using namespace terrain;

/// The tests' rough land (tests/terrain/synthetic_land.hpp) at 500 × its octave sum.
std::vector<float> rough_land(int side) {
  return terrain::testing::rough_land(side, 500.0);
}

void BM_Erosion(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  const std::vector<float> z = rough_land(side);
  const ElevationGrid grid{side, side, 4000.0 / (side - 1), z, std::nullopt, {}};
  ErosionParams params;
  params.diffusion = 6.0;
  std::size_t heap_peak = 0;
  for (auto _ : state) {
    bench::reset_heap_peak();
    // As the erosion node calls it: the grid handed over (so counted here), the solve working
    // in its storage.
    std::vector<float> heights(z);
    Result<std::vector<float>> out = erode(std::move(heights), side, side, grid.cell_size, params);
    heap_peak = bench::heap_peak_since_reset();
    benchmark::DoNotOptimize(out.ok());
  }
  state.counters["heap_peak_MB"] = static_cast<double>(heap_peak) / (1024.0 * 1024.0);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  state.counters["peak_rss_MB"] = static_cast<double>(usage.ru_maxrss) / 1024.0;
  state.counters["cell_steps"] =
      static_cast<double>(erosion_work(side, side, params.iterations, params.diffusion));
  state.SetItemsProcessed(state.iterations() * side * side);
}
BENCHMARK(BM_Erosion)->Arg(512)->Arg(1024)->Arg(2048)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_Drainage(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  const std::vector<float> z = rough_land(side);
  const double cell = 4000.0 / (side - 1);
  const ElevationGrid grid{side, side, cell, z, std::nullopt, {}};
  RiverParams params;
  params.channel_area = 0.002 * 4000.0 * 4000.0;
  params.width = 8.0;
  params.depth = 1.0;
  std::int64_t channel_cells = 0;
  int lakes = 0;
  std::size_t heap_peak = 0;
  for (auto _ : state) {
    bench::reset_heap_peak();
    Result<RiverNetwork> out = carve_rivers(grid, params);
    heap_peak = bench::heap_peak_since_reset();
    benchmark::DoNotOptimize(out.ok());
    if (out) {
      lakes = out->lakes;
      channel_cells = 0;
      for (const std::uint8_t c : out->channel) channel_cells += c;
    }
  }
  state.counters["heap_peak_MB"] = static_cast<double>(heap_peak) / (1024.0 * 1024.0);
  state.counters["lakes"] = lakes;
  state.counters["channel_cells"] = static_cast<double>(channel_cells);
  state.SetItemsProcessed(state.iterations() * side * side);
}
BENCHMARK(BM_Drainage)
    ->Arg(512)
    ->Arg(1024)
    ->Arg(2048)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
