// Seeded planets: base mesh generation (Derzapf et al. report 0.27 s for ~5000 faces on a GTX
// 580 system; the target here is ≤ 50 ms on one core), refinement throughput (new triangles per
// second of lazy diamond splitting) and tile latency at zooms 2, 10 and 18.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <random>
#include <string>

#include "example_scenes.hpp"
#include "planet/planet.hpp"
#include "planet/tiles.hpp"
#include "terrain/tile_products.hpp"

namespace {

using namespace planet;

PlanetDefinition default_definition() {
  Result<PlanetDefinition> d = load_planet_file(TERRAIN_SOURCE_DIR "/config/planets/default.json");
  return d.value();
}

const std::shared_ptr<const Planet>& default_planet() {
  static const std::shared_ptr<const Planet> planet = Planet::create(default_definition());
  return planet;
}

// The same definition with the displacement relief model, the default until generation 16
// (planet.md "Relief models").
const std::shared_ptr<const Planet>& displacement_planet() {
  static const std::shared_ptr<const Planet> planet = [] {
    PlanetDefinition d = default_definition();
    d.relief_model = ReliefModel::displacement;
    return Planet::create(d);
  }();
  return planet;
}

// The same definition with its valleys winding through a domain warp of 0.1 (planet.md
// "Winding valleys"; off by default): the warp's noise per sample, and floors drawn by bins.
const std::shared_ptr<const Planet>& warped_planet() {
  static const std::shared_ptr<const Planet> planet = [] {
    PlanetDefinition d = default_definition();
    d.warp = 0.1;
    return Planet::create(d);
  }();
  return planet;
}

void BM_PlanetBaseMesh(benchmark::State& state) {
  const PlanetDefinition d = default_definition();
  int faces = 0;
  for (auto _ : state) {
    const auto mesh = build_base_mesh(d);
    faces = mesh->stats.river_faces;
    benchmark::DoNotOptimize(mesh->leaves.data());
  }
  state.counters["river_faces"] = faces;
}
BENCHMARK(BM_PlanetBaseMesh)->Unit(benchmark::kMillisecond);

// Lazy refinement from the base mesh to `extra` levels deeper around random points: triangles
// created per second (each split makes four).
void BM_PlanetRefinement(benchmark::State& state) {
  const auto& world = default_planet();
  const int level = world->rules().mesh_level + static_cast<int>(state.range(0));
  std::mt19937_64 random(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3d> points;
  for (int i = 0; i < 256; ++i) points.push_back(normalize({u(random), u(random), u(random)}));
  std::size_t created = 0;
  for (auto _ : state) {
    Hierarchy h = world->base_mesh().hierarchy;
    const std::size_t before = h.tris.size();
    for (const Vec3d& p : points) benchmark::DoNotOptimize(h.locate(p, level));
    created += h.tris.size() - before;
  }
  state.counters["triangles_per_second"] =
      benchmark::Counter(static_cast<double>(created), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PlanetRefinement)->Arg(10)->Arg(20)->Unit(benchmark::kMillisecond);

// The zoom-z tile over land at about 20° N, 20° E (this planet's central continent).
terrain::TileAddress central_tile(int z) {
  return {z, static_cast<std::int64_t>((200.0 / 180.0) * std::ldexp(1.0, z)),
          static_cast<std::int64_t>((110.0 / 180.0) * std::ldexp(1.0, z))};
}

// Keeps a made product from being optimised away; false, the benchmark skipped, on an error.
bool consume(benchmark::State& state, const Result<terrain::Product>& product) {
  if (!product) {
    state.SkipWithError(product.error().message.c_str());
    return false;
  }
  benchmark::DoNotOptimize(product->bytes.data());
  return true;
}

// One tile of `format` over the central continent, a fresh PlanetTiles each time so that no
// refinement is reused: the latency of a cache miss.
void run_planet_tile(benchmark::State& state, terrain::TileFormat format,
                     const std::shared_ptr<const Planet>& world = default_planet()) {
  const int z = static_cast<int>(state.range(0));
  const terrain::TileAddress a = central_tile(z);
  for (auto _ : state) {
    PlanetTiles tiles(world);
    if (!consume(state, tiles.make(a, format))) return;
  }
}

// One 256² terrain-RGB tile (height evaluation and encoding).
void BM_PlanetTile(benchmark::State& state) {
  run_planet_tile(state, terrain::TileFormat::terrain_rgb);
}
BENCHMARK(BM_PlanetTile)->Arg(2)->Arg(10)->Arg(18)->Unit(benchmark::kMillisecond);

// A fresh zoom-18 tile with a corner at one of the octahedron's six vertices, north-east of
// those on the equator (0°, 90° E, 180°, 90° W), and a needle-thin tile of each pole's row:
// where tiles took seconds while the base shape drifted towards the vertices and a grid beside
// a pole found its rows by z alone (planet.md "Tiles at the octahedron's vertices"). Compare
// BM_PlanetTile/18, a fresh tile on plain land.
void BM_PlanetTileAtOctahedronVertex(benchmark::State& state) {
  constexpr int z = 18;
  const std::int64_t n = std::int64_t{1} << z;  // geographic: 2n columns, n rows
  const terrain::TileAddress vertices[] = {{z, n, n / 2},         {z, n + n / 2, n / 2},
                                           {z, 0, n / 2},         {z, n / 2, n / 2},
                                           {z, n + n / 3, n - 1}, {z, n + n / 3, 0}};
  const terrain::TileAddress a = vertices[state.range(0)];
  for (auto _ : state) {
    PlanetTiles tiles(default_planet());
    if (!consume(state, tiles.make(a, terrain::TileFormat::terrain_rgb))) return;
  }
}
BENCHMARK(BM_PlanetTileAtOctahedronVertex)->DenseRange(0, 5)->Unit(benchmark::kMillisecond);

// A fresh tile of the open sea beside the cone point at 0° N 180°, where every level's triangles
// are twenty times smaller than elsewhere (planet.md "The cone points"): 0.2 s at zooms 10–14
// until the open sea's floor stopped at edges of about 2 km (generation 22).
void BM_PlanetTileBesideAConePoint(benchmark::State& state) {
  const int z = static_cast<int>(state.range(0));
  const std::int64_t n = std::int64_t{1} << z;  // geographic: 2n columns, n rows
  const terrain::TileAddress a{z, 2 * n - 1, n / 2};
  for (auto _ : state) {
    PlanetTiles tiles(default_planet());
    if (!consume(state, tiles.make(a, terrain::TileFormat::terrain_rgb))) return;
  }
}
BENCHMARK(BM_PlanetTileBesideAConePoint)->Arg(8)->Arg(12)->Arg(16)->Unit(benchmark::kMillisecond);

// The same tile from a PlanetTiles that has made it once, every triangle it needs already split:
// what a server thread's cached refinement saves (the product cache aside), and what a tile costs
// beyond its splits (descent, cubic, detail noise, encoding).
void run_planet_tile_refined(benchmark::State& state, const std::shared_ptr<const Planet>& world) {
  const int z = static_cast<int>(state.range(0));
  const terrain::TileAddress a = central_tile(z);
  PlanetTiles tiles(world);
  (void)tiles.make(a, terrain::TileFormat::terrain_rgb);
  for (auto _ : state) {
    if (!consume(state, tiles.make(a, terrain::TileFormat::terrain_rgb))) return;
  }
}
void BM_PlanetTileRefined(benchmark::State& state) {
  run_planet_tile_refined(state, default_planet());
}
BENCHMARK(BM_PlanetTileRefined)->Arg(2)->Arg(10)->Arg(18)->Unit(benchmark::kMillisecond);

// A server's thread keeps its PlanetTiles, so while a user pans, each new tile finds the
// refinement of the tiles beside it made: each iteration makes the next tile east along the row
// (the sampler trims itself back to the base mesh now and then, as in a server). What a tile not
// in the product cache costs in the steady state: timing starts after kWarmUpTiles, past the
// first trims (about every 12 tiles at zoom 10), whose fresh pages a long-lived thread has
// faulted in long before.
void BM_PlanetTilePanning(benchmark::State& state) {
  constexpr int kWarmUpTiles = 30;
  const int z = static_cast<int>(state.range(0));
  const std::int64_t columns = std::int64_t{2} << z;
  const terrain::TileAddress start = central_tile(z);
  const std::int64_t y = start.y;
  std::int64_t x = start.x;
  PlanetTiles tiles(default_planet());
  for (int i = 0; i < kWarmUpTiles; ++i) {
    x = (x + 1) % columns;
    (void)tiles.make({z, x, y}, terrain::TileFormat::terrain_rgb);
  }
  for (auto _ : state) {
    x = (x + 1) % columns;
    if (!consume(state, tiles.make({z, x, y}, terrain::TileFormat::terrain_rgb))) return;
  }
}
BENCHMARK(BM_PlanetTilePanning)->Arg(2)->Arg(10)->Arg(18)->Unit(benchmark::kMillisecond);

// The same two with the displacement relief model, which draws no floors along the drains.
void BM_PlanetTileDisplacement(benchmark::State& state) {
  run_planet_tile(state, terrain::TileFormat::terrain_rgb, displacement_planet());
}
BENCHMARK(BM_PlanetTileDisplacement)->Arg(2)->Arg(10)->Arg(18)->Unit(benchmark::kMillisecond);
void BM_PlanetTileDisplacementRefined(benchmark::State& state) {
  run_planet_tile_refined(state, displacement_planet());
}
BENCHMARK(BM_PlanetTileDisplacementRefined)
    ->Arg(2)
    ->Arg(10)
    ->Arg(18)
    ->Unit(benchmark::kMillisecond);

void BM_PlanetTileWarpedRefined(benchmark::State& state) {
  run_planet_tile_refined(state, warped_planet());
}
BENCHMARK(BM_PlanetTileWarpedRefined)->Arg(2)->Arg(10)->Arg(18)->Unit(benchmark::kMillisecond);

// Issue 20 asks that a planet tile be no slower than a scene tile of the same size, so the same
// product of every example scene runs in the same process: a 256² terrain-RGB tile (generation
// and encoding, no cache) at the scene's local zoom 2 (5–9 m per sample). An erosion scene's grid
// is computed once before timing, as a server does once per scene version.
void scene_tile(benchmark::State& state, const std::string& name) {
  static std::map<std::string, std::unique_ptr<terrain::ProductMaker>> makers;
  const terrain::TileAddress address{2, 1, 1};
  auto& maker = makers[name];
  if (!maker) {
    terrain::Scene scene = terrain::load_scene_file(bench::example_file(name)).value();
    maker = std::make_unique<terrain::ProductMaker>(terrain::TileSource::from_scene(scene).value());
    (void)maker->make(terrain::TileScheme::local, address, terrain::TileFormat::terrain_rgb);
  }
  for (auto _ : state) {
    if (!consume(state, maker->make(terrain::TileScheme::local, address,
                                    terrain::TileFormat::terrain_rgb))) {
      return;
    }
  }
}

const int scene_tiles_registered = [] {
  for (const std::string& name : bench::example_names()) {
    benchmark::RegisterBenchmark(("BM_SceneTile/" + name).c_str(), [name](benchmark::State& s) {
      scene_tile(s, name);
    })->Unit(benchmark::kMillisecond);
  }
  return 0;
}();

// One 65² quantized-mesh tile with every extension (heights, water mask, triangulation on the
// ellipsoid, encoding, gzip): coarse zooms are where the curvature of the globe adds vertices,
// deep ones where it should cost nothing.
void BM_PlanetQuantizedMesh(benchmark::State& state) {
  run_planet_tile(state, terrain::TileFormat::quantized_mesh);
}
BENCHMARK(BM_PlanetQuantizedMesh)->Arg(1)->Arg(4)->Arg(10)->Unit(benchmark::kMillisecond);

}  // namespace
