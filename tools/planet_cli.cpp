// planet: command-line access to seeded planets — id, base mesh, samples, pictures and tiles.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "planet/picture.hpp"
#include "planet/planet.hpp"
#include "planet/tiles.hpp"
#include "terrain/gzip.hpp"

namespace {

using namespace planet;

constexpr const char* kUsage = R"(planet — seeded planets with river networks (Derzapf et al. 2011)

Usage:
  planet id PLANET.json                  canonical JSON and id of a definition
  planet mesh PLANET.json [--threads N]  build the base mesh: statistics, hash, milliseconds
  planet sample PLANET.json LAT LON      ground, water and surface type at full detail
  planet picture PLANET.json -o OUT.png [--width W] [--threads N]
                                         equirectangular picture, hillshaded and coloured
  planet tile PLANET.json Z X Y -o OUT.{png,tif,terrain,glb,drc} [--encoding E] [--size N]
       [--grid N] [--gunzip]             one geographic (EPSG:4326, TMS) tile
  planet layer-json PLANET.json          Cesium layer.json for the planet's tiles
  planet --help
)";

struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;
  bool has(const std::string& k) const { return options.contains(k); }
  std::string get(const std::string& k, const std::string& fallback) const {
    auto it = options.find(k);
    return it == options.end() ? fallback : it->second;
  }
};

Args parse_args(int argc, char** argv) {
  Args args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--", 0) == 0 || a == "-o") {
      const bool flag = a == "--help" || a == "--gunzip";
      if (!flag && i + 1 < argc) {
        args.options[a] = argv[++i];
      } else {
        args.options[a] = "";
      }
    } else {
      args.positional.push_back(a);
    }
  }
  return args;
}

bool write_file(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  return file != nullptr && std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size() &&
         std::fclose(file) == 0;
}

double elapsed_ms(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

int run(const Args& args) {
  const std::string& command = args.positional[0];
  Result<PlanetDefinition> definition = load_planet_file(args.positional[1]);
  if (!definition) {
    std::cerr << "planet " << command << ": " << definition.error().pointer << ": "
              << definition.error().message << "\n";
    return 1;
  }
  if (command == "id") {
    std::cout << nlohmann::json{{"id", planet_id(*definition)},
                                {"definition", canonical_json(*definition)}}
                     .dump(2)
              << "\n";
    return 0;
  }
  const int threads = std::stoi(args.get("--threads", "1"));
  const auto start = std::chrono::steady_clock::now();
  std::shared_ptr<const Planet> world = Planet::create(*definition, {threads});
  const double build_ms = elapsed_ms(start);
  if (command == "mesh") {
    const BaseMeshStats& s = world->base_mesh().stats;
    std::cout << nlohmann::json{{"id", world->id()},
                                {"hash", world->base_mesh().hash()},
                                {"milliseconds", build_ms},
                                {"river_faces", s.river_faces},
                                {"mesh_faces", s.mesh_faces},
                                {"land_fraction", s.land_fraction},
                                {"continents", s.continents},
                                {"mouths", s.mouths},
                                {"river_vertices", s.river_vertices},
                                {"endorheic", s.endorheic},
                                {"longest_river_km", s.longest_river / 1000.0}}
                     .dump(2)
              << "\n";
    return 0;
  }
  if (command == "sample" && args.positional.size() >= 4) {
    const double lat = std::stod(args.positional[2]), lon = std::stod(args.positional[3]);
    Sampler sampler(world);
    std::cout << sample_json(lat, lon, sampler.sample(lat, lon)).dump(2) << "\n";
    return 0;
  }
  if (command == "picture" && args.has("-o")) {
    PictureOptions options;
    options.width = std::stoi(args.get("--width", "2048"));
    options.threads = threads;
    const auto t0 = std::chrono::steady_clock::now();
    Result<std::vector<std::uint8_t>> png = planet_picture_png(world, options);
    if (!png || !write_file(args.get("-o", ""), *png)) {
      std::cerr << "planet picture: cannot write " << args.get("-o", "") << "\n";
      return 1;
    }
    std::cout << nlohmann::json{{"file", args.get("-o", "")},
                                {"build_milliseconds", build_ms},
                                {"picture_milliseconds", elapsed_ms(t0)}}
                     .dump(2)
              << "\n";
    return 0;
  }
  if (command == "tile" && args.positional.size() >= 5 && args.has("-o")) {
    const std::string out = args.get("-o", "");
    const std::string extension = out.substr(out.find_last_of('.') + 1);
    Result<terrain::TileFormat> format =
        terrain::parse_tile_format(extension, args.get("--encoding", ""));
    if (!format) {
      std::cerr << "planet tile: " << format.error().message << "\n";
      return 2;
    }
    terrain::ProductOptions options;
    options.size = std::stoi(args.get("--size", "256"));
    options.grid = std::stoi(args.get("--grid", "65"));
    PlanetTiles tiles(world);
    const terrain::TileAddress address{std::stoi(args.positional[2]),
                                       std::stoll(args.positional[3]),
                                       std::stoll(args.positional[4])};
    const auto t0 = std::chrono::steady_clock::now();
    Result<terrain::Product> product = tiles.make(address, *format, options);
    const double ms = elapsed_ms(t0);
    if (!product) {
      std::cerr << "planet tile: " << product.error().pointer << ": " << product.error().message
                << "\n";
      return 1;
    }
    std::vector<std::uint8_t> bytes = std::move(product->bytes);
    if (args.has("--gunzip") && product->content_encoding == "gzip") {
      bytes = terrain::gzip_decompress(bytes, std::size_t{1} << 30).value();
    }
    if (!write_file(out, bytes)) {
      std::cerr << "planet tile: cannot write " << out << "\n";
      return 1;
    }
    std::cout << nlohmann::json{{"file", out},
                                {"bytes", bytes.size()},
                                {"media_type", product->media_type},
                                {"milliseconds", ms}}
                     .dump(2)
              << "\n";
    return 0;
  }
  if (command == "layer-json") {
    PlanetTiles tiles(world);
    terrain::LayerJsonOptions options;
    options.name = world->id();
    std::cout << tiles.layer_json(options).dump(2) << "\n";
    return 0;
  }
  std::cerr << kUsage;
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse_args(argc, argv);
  if (args.has("--help")) {
    std::cout << kUsage;
    return 0;
  }
  if (args.positional.size() < 2) {
    std::cerr << kUsage;
    return 2;
  }
  return run(args);
}
