// f(p)/s per core for every example scene: single points (the sphere tracer's access pattern)
// and 8×8-block grids (tiles), at full detail and at a typical tile's sample spacing; and the
// local scheme's zoom-0 tile (the whole scene, 256² cell centres) generated alone and generated
// and encoded as a float TIFF.
#include <benchmark/benchmark.h>

#include <fstream>
#include <random>
#include <sstream>

#include "terrain/evaluate.hpp"
#include "terrain/image_io.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"
#include "terrain/tile_source.hpp"

#include "example_scenes.hpp"

namespace {

using namespace terrain;

void points(benchmark::State& state, const std::string& name, float spacing) {
  const bench::LoadedExample& l = bench::load_example(name);
  Evaluator e(l.program);
  const Box2 area = l.scene.area();
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> ux(area.lo.x, area.hi.x), uy(area.lo.y, area.hi.y);
  std::vector<Vec2> ps(4096);
  for (Vec2& p : ps) p = {ux(rng), uy(rng)};
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(e.sample(ps[k++ & 4095], spacing));
  }
  state.SetItemsProcessed(state.iterations());
}

void grid(benchmark::State& state, const std::string& name, int size) {
  const bench::LoadedExample& l = bench::load_example(name);
  const Box2 area = l.scene.area();
  const double step = static_cast<double>(std::max(area.size().x, area.size().y)) / (size - 1);
  const GridSpec spec{area.lo.x, area.lo.y, step, size, size, -1.0f};
  for (auto _ : state) {
    GridResult r = evaluate_grid(l.program, spec, 1);
    benchmark::DoNotOptimize(r.elevation.data());
  }
  state.SetItemsProcessed(state.iterations() * size * size);
  state.counters["spacing_m"] = step;
}

void tile(benchmark::State& state, const std::string& name, bool encode) {
  const bench::LoadedExample& l = bench::load_example(name);
  TileGenerator generator(TileSource::from_scene(l.scene).value());
  const TileRequest request{TileScheme::local, {0, 0, 0}, SampleLayout::cell_centres, 256, 0};
  for (auto _ : state) {
    const HeightTile t = generator.height_tile(request).value();
    if (encode) {
      const std::vector<std::uint8_t> bytes =
          encode_float_tiff(t.width, t.height, t.elevation.data()).value();
      benchmark::DoNotOptimize(bytes.data());
    } else {
      benchmark::DoNotOptimize(t.elevation.data());
    }
  }
  state.SetItemsProcessed(state.iterations() * 256 * 256);
}

int register_all() {
  for (const std::string& name : bench::example_names()) {
    benchmark::RegisterBenchmark(("Point/" + name + "/full_detail").c_str(),
                                 [name](benchmark::State& s) { points(s, name, 0.0f); });
    benchmark::RegisterBenchmark(("Point/" + name + "/spacing_10m").c_str(),
                                 [name](benchmark::State& s) { points(s, name, 10.0f); });
    benchmark::RegisterBenchmark(("Grid256/" + name).c_str(),
                                 [name](benchmark::State& s) { grid(s, name, 256); });
    benchmark::RegisterBenchmark(("Grid1024/" + name).c_str(),
                                 [name](benchmark::State& s) { grid(s, name, 1024); });
    benchmark::RegisterBenchmark(("Tile256/" + name).c_str(),
                                 [name](benchmark::State& s) { tile(s, name, false); });
    benchmark::RegisterBenchmark(("Tile256Tiff/" + name).c_str(),
                                 [name](benchmark::State& s) { tile(s, name, true); });
  }
  return 0;
}

const int registered = register_all();

}  // namespace
