// Tiles per second per core, for every product format on every example scene: generation and
// encoding together, as the server does on a cache miss. Counters give bytes per tile.
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <memory>

#include "terrain/tile_products.hpp"

#include "example_scenes.hpp"

namespace {

using namespace terrain;

ProductMaker& maker(const std::string& name) {
  static std::map<std::string, std::unique_ptr<ProductMaker>> makers;
  auto& m = makers[name];
  if (!m) {
    Scene scene = load_scene_file(bench::example_file(name)).value();
    m = std::make_unique<ProductMaker>(TileSource::from_scene(scene).value());
  }
  return *m;
}

// A local tile at zoom z: 0 is the whole scene in one tile (22–35 m per sample), 2 a quarter of
// its side (5–9 m per sample: more octaves); quantized-mesh takes the geographic zoom-13 tile at
// the origin instead (65² grid over about 2 km).
void tile(benchmark::State& state, const std::string& name, TileFormat format, int z) {
  ProductMaker& m = maker(name);
  TileScheme scheme = TileScheme::local;
  TileAddress address{z, z == 0 ? 0 : 1, z == 0 ? 0 : 1};
  if (format == TileFormat::quantized_mesh) {
    const Georeference& g = m.source().georeference;
    scheme = TileScheme::geographic;
    address = {13, static_cast<std::int64_t>((g.longitude + 180.0) / 180.0 * 8192.0),
               static_cast<std::int64_t>((g.latitude + 90.0) / 180.0 * 8192.0)};
  }
  std::size_t bytes = 0;
  for (auto _ : state) {
    Result<Product> p = m.make(scheme, address, format);
    if (!p) {
      state.SkipWithError(p.error().message.c_str());
      return;
    }
    bytes = p->bytes.size();
    benchmark::DoNotOptimize(p->bytes.data());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["bytes"] = static_cast<double>(bytes);
}

int register_all() {
  for (const std::string& name : bench::example_names()) {
    for (const TileFormatInfo& info : tile_formats()) {
      const std::string label = name + "/" + std::string(info.extension) +
                                (info.encoding.empty() ? "" : "-" + std::string(info.encoding));
      const TileFormat format = info.format;
      for (int z : {0, 2}) {
        if (z == 2 && format == TileFormat::quantized_mesh) continue;
        benchmark::RegisterBenchmark(
            ("TileZ" + std::to_string(z) + "/" + label).c_str(),
            [name, format, z](benchmark::State& s) { tile(s, name, format, z); })
            ->Unit(benchmark::kMillisecond);
      }
    }
  }
  return 0;
}

const int registered = register_all();

}  // namespace
