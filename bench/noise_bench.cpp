// Noise throughput per core. The batch benchmarks report `evals/s`: octaves × points per second
// (value + gradient), the figure docs/noise.md quotes; the target is ≥ 100 M/s for one-octave
// gradient fBm in 2D. Points are a 64×64 tile with 0.37 m spacing, as a block evaluator sees them.
#include <benchmark/benchmark.h>

#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include "terrain/noise.hpp"

namespace {

using namespace terrain;
using namespace terrain::noise;

constexpr std::size_t kTile = 64 * 64;

struct Points {
  std::vector<float> x, y, z;
};

const Points& tile() {
  static const Points points = [] {
    Points p;
    for (std::size_t i = 0; i < kTile; ++i) {
      p.x.push_back(1234.5f + 0.37f * static_cast<float>(i % 64));
      p.y.push_back(-987.25f + 0.37f * static_cast<float>(i / 64));
      p.z.push_back(17.0f + 0.11f * static_cast<float>(i % 7));
    }
    return p;
  }();
  return points;
}

FractalParams params(Fractal kind, Basis basis) {
  FractalParams p;
  p.kind = kind;
  p.basis = basis;
  p.seed = 1234;
  p.octaves = 24;
  p.frequency = 1.0f / 64.0f;
  p.amplitude = 40.0f;
  p.warp_c1 = 0.35f;
  p.warp_c2 = 0.13f;
  p.warp_c3 = {0.11f, 0.17f};
  return p;
}

// Arguments: kind, basis, octaves.
void BM_Fractal2Batch(benchmark::State& state) {
  const FractalParams p =
      params(static_cast<Fractal>(state.range(0)), static_cast<Basis>(state.range(1)));
  const auto octaves = static_cast<float>(state.range(2));
  const Points& pts = tile();
  std::vector<float> v(kTile), dx(kTile), dy(kTile);
  for (auto _ : state) {
    fractal2(p, pts.x.data(), pts.y.data(), kTile, octaves, v.data(), dx.data(), dy.data());
    benchmark::DoNotOptimize(v.data());
    benchmark::ClobberMemory();
  }
  state.counters["evals/s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(kTile) * octaves,
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Fractal2Batch)
    ->ArgNames({"kind", "basis", "octaves"})
    ->Args({0, 0, 1})
    ->Args({0, 0, 8})
    ->Args({0, 1, 1})
    ->Args({0, 1, 8})
    ->Args({1, 0, 8})
    ->Args({2, 0, 8})
    ->Args({3, 0, 8})
    ->Args({3, 1, 8});

void BM_Fractal3Batch(benchmark::State& state) {
  const FractalParams p =
      params(static_cast<Fractal>(state.range(0)), static_cast<Basis>(state.range(1)));
  const auto octaves = static_cast<float>(state.range(2));
  const Points& pts = tile();
  std::vector<float> v(kTile), dx(kTile), dy(kTile), dz(kTile);
  for (auto _ : state) {
    fractal3(p, pts.x.data(), pts.y.data(), pts.z.data(), kTile, octaves, v.data(), dx.data(),
             dy.data(), dz.data());
    benchmark::DoNotOptimize(v.data());
    benchmark::ClobberMemory();
  }
  state.counters["evals/s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(kTile) * octaves,
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Fractal3Batch)
    ->ArgNames({"kind", "basis", "octaves"})
    ->Args({0, 0, 1})
    ->Args({0, 1, 1})
    ->Args({1, 0, 8});

// The scalar entry points, one call per sample (the sphere tracer's access pattern).
void BM_Gradient2Scalar(benchmark::State& state) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1000.0f, 1000.0f);
  std::vector<float> xs(1024), ys(1024);
  for (std::size_t i = 0; i < xs.size(); ++i) {
    xs[i] = u(rng);
    ys[i] = u(rng);
  }
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(gradient2(xs[i & 1023], ys[i & 1023], 99u));
    ++i;
  }
  state.counters["evals/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Gradient2Scalar);

void BM_Simplex2Scalar(benchmark::State& state) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1000.0f, 1000.0f);
  std::vector<float> xs(1024), ys(1024);
  for (std::size_t i = 0; i < xs.size(); ++i) {
    xs[i] = u(rng);
    ys[i] = u(rng);
  }
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(simplex2(xs[i & 1023], ys[i & 1023], 99u));
    ++i;
  }
  state.counters["evals/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Simplex2Scalar);

void BM_Fractal2Point(benchmark::State& state) {
  const FractalParams p = params(Fractal::fbm, Basis::gradient);
  const Points& pts = tile();
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t k = i++ % kTile;
    benchmark::DoNotOptimize(fractal2(p, Vec2{pts.x[k], pts.y[k]}, 8.0f));
  }
  state.counters["evals/s"] = benchmark::Counter(static_cast<double>(state.iterations()) * 8.0,
                                                 benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Fractal2Point);

}  // namespace
