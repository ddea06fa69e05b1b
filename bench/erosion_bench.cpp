// The erosion solver on one core (issue target: a 1024² grid ≤ 2 s): rough value-noise land of
// 1 km relief over a 4 km square at 512², 1024² and 2048², default parameters; and the peak
// resident set after the largest (a counter, from getrusage). The drainage's lakes, channels and
// carving on the same land (noise: many depressions, so the lake search works hardest).
#include <benchmark/benchmark.h>

#include <sys/resource.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "terrain/erosion.hpp"
#include "terrain/rivers.hpp"

namespace {

using namespace terrain;

double lattice(int i, int j, int seed) {
  std::uint32_t x = static_cast<std::uint32_t>(i) * 73856093u ^
                    static_cast<std::uint32_t>(j) * 19349663u ^
                    static_cast<std::uint32_t>(seed) * 83492791u;
  x ^= x >> 13;
  x *= 0x5bd1e995u;
  x ^= x >> 15;
  return static_cast<double>(x & 0xffffffu) / 16777215.0;
}

std::vector<float> rough_land(int side) {
  std::vector<float> z(static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  const double cell = 4000.0 / (side - 1);
  for (int j = 0; j < side; ++j) {
    for (int i = 0; i < side; ++i) {
      double e = 0.0, amplitude = 1.0, frequency = 1.0 / 1500.0;
      for (int o = 0; o < 8; ++o) {
        const double x = i * cell * frequency, y = j * cell * frequency;
        const double fi = std::floor(x), fj = std::floor(y);
        double fx = x - fi, fy = y - fj;
        fx = fx * fx * (3 - 2 * fx);
        fy = fy * fy * (3 - 2 * fy);
        const int a = static_cast<int>(fi), b = static_cast<int>(fj);
        e += amplitude * ((lattice(a, b, o) * (1 - fx) + lattice(a + 1, b, o) * fx) * (1 - fy) +
                          (lattice(a, b + 1, o) * (1 - fx) + lattice(a + 1, b + 1, o) * fx) * fy);
        amplitude *= 0.5;
        frequency *= 2.0;
      }
      z[static_cast<std::size_t>(j) * static_cast<std::size_t>(side) +
        static_cast<std::size_t>(i)] = static_cast<float>(100.0 + 500.0 * e);
    }
  }
  return z;
}

void BM_Erosion(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  const std::vector<float> z = rough_land(side);
  const ElevationGrid grid{side, side, 4000.0 / (side - 1), z, std::nullopt, {}};
  for (auto _ : state) {
    Result<std::vector<float>> out = erode(grid, {});
    benchmark::DoNotOptimize(out.ok());
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  state.counters["peak_rss_MB"] = static_cast<double>(usage.ru_maxrss) / 1024.0;
  state.counters["cell_steps"] = static_cast<double>(erosion_work(side, side, 24));
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
  for (auto _ : state) {
    Result<RiverNetwork> out = carve_rivers(grid, params);
    benchmark::DoNotOptimize(out.ok());
    if (out) {
      lakes = out->lakes;
      channel_cells = 0;
      for (const std::uint8_t c : out->channel) channel_cells += c;
    }
  }
  state.counters["lakes"] = lakes;
  state.counters["channel_cells"] = static_cast<double>(channel_cells);
  state.SetItemsProcessed(state.iterations() * side * side);
}
BENCHMARK(BM_Drainage)->Arg(512)->Arg(1024)->Arg(2048)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
