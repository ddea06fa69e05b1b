// planet: command-line access to seeded planets — id, base mesh, samples, pictures and tiles.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cli_args.hpp"
#include "export_command.hpp"
#include "planet/analysis.hpp"
#include "planet/continent_map.hpp"
#include "planet/picture.hpp"
#include "planet/planet.hpp"
#include "planet/tiles.hpp"
#include "terrain/gzip.hpp"
#include "terrain/image_io.hpp"

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
       [--grid N] [--gunzip] [--scheme S]
                                         one tile: S = geographic (EPSG:4326, TMS; default) or
                                         webmercator (EPSG:3857 XYZ, height images)
  planet layer-json PLANET.json          Cesium layer.json for the planet's tiles
  planet analyze PLANET.json LAT LON [--zoom Z | --cell M] [--size N] [--margin K]
       [--channel-area A] [--picture FILE.png]
                                         geomorphometry of N × N samples (default 512) around
                                         LAT, LON, M metres apart (default: a zoom-Z tile's
                                         spacing, Z = 8), drained with K more on every side
                                         (default 0), and a picture of its drainage:
                                         docs/analysis.md
  planet survey PLANET.json [--points N] [--zoom Z] [--size S] [--margin K]
                                         geomorphometry of S × S land squares at the land
                                         points of an N-point equal-area lattice (default 64,
                                         zoom 8, 512, margin 0), against issue 20's targets
  planet hypsometry PLANET.json [--samples N] [--cell M]
                                         the land's altitudes over the whole planet: N points
                                         (default 20 000) at M metres' detail (default 200)
  planet export [PLANET.json|default]    an offline pack (MBTiles 1.3 or PMTiles v3) of the
                                         planet's geographic tiles as the server serves them
                                         (docs/packs.md); default: config/planets/default.json
)";

constexpr const char* kUsageEnd = R"(  planet --help

  --continent-map MAP.png (any command): continents from a greyscale equirectangular PNG
  (white = land, at least 0.5) instead of random ones. The definition's continent_map becomes
  the file's hash; a definition that names another hash is refused, and one that names a map
  needs this option.
)";

using Args = tools::CliArgs;

// An integer option or positional; a bad one is reported and ends the command.
std::optional<long long> integer_arg(const std::string& what, const std::string& text, long long lo,
                                     long long hi) {
  const auto v = tools::parse_integer(text, lo, hi);
  if (!v)
    std::cerr << "planet: " << what << " must be an integer from " << lo << " to " << hi << "\n";
  return v;
}

// A positive number option (`--cell` metres, `--channel-area` m²), if given: false when it was
// given badly (reported), else true with `value` set or left as it was.
bool positive_arg(const Args& args, const std::string& command, const std::string& option,
                  const char* unit, double& value) {
  if (!args.has(option)) return true;
  const auto v = tools::parse_number(args.get(option, ""));
  if (!v || !(*v > 0)) {
    std::cerr << "planet " << command << ": " << option << " must be " << unit
              << " greater than 0\n";
    return false;
  }
  value = *v;
  return true;
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

std::optional<std::vector<std::uint8_t>> read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
  if (in.bad()) return std::nullopt;
  return bytes;
}

// The tiles are planned and checked before the planet is built (which takes a while).
int cmd_export(const Args& args, const PlanetDefinition& definition, const ContinentMap* map) {
  tools::ExportRules rules;
  rules.command = "planet export";
  // Height images on Web Mercator, as MBTiles 1.3 and MapLibre expect; meshes geographic.
  rules.png_scheme = terrain::TileScheme::webmercator;
  rules.deepest = [](terrain::TileScheme scheme) { return terrain::max_zoom(scheme); };
  const std::optional<tools::ExportRequest> request = tools::parse_export(args, rules);
  if (!request) return 2;
  Result<std::shared_ptr<const Planet>> built =
      Planet::build(definition, map, {std::max(request->threads, 1)});
  if (!built) {
    std::cerr << "planet export: " << built.error().pointer << ": " << built.error().message
              << "\n";
    return 1;
  }
  const std::shared_ptr<const Planet> world = std::move(built).value();
  tools::ExportSource pack;
  pack.source_id = world->id();
  pack.name = "planet " + world->id();
  const terrain::TileFormat format = request->format;
  const terrain::TileScheme scheme = request->scheme;
  pack.description =
      "planet export of " + world->id() +
      (scheme == terrain::TileScheme::geographic
           ? ": geographic tiles (EPSG:4326, TMS rows, two root tiles), not Web Mercator"
           : ": Web Mercator (EPSG:3857) XYZ height tiles");
  if (format == terrain::TileFormat::quantized_mesh) {
    terrain::LayerJsonOptions options;
    options.name = world->id();
    nlohmann::json layer = PlanetTiles::layer_json(options);
    layer["maxzoom"] = request->zooms.back().z;
    pack.extra["layer_json"] = layer;
  }
  // One PlanetTiles per thread, with the server's default options.
  pack.factory = [world, format, scheme]() -> terrain::MakeTile {
    auto tiles = std::make_shared<PlanetTiles>(world);
    return [tiles, format,
            scheme](const terrain::TileAddress& address) -> Result<std::vector<std::uint8_t>> {
      Result<terrain::Product> product =
          tiles->make(scheme, address, format, terrain::ProductOptions{});
      if (!product) return product.error();
      return std::move(product->bytes);
    };
  };
  return tools::run_export(rules, *request, pack);
}

int run(const Args& args) {
  const std::string& command = args.positional[0];
  Result<PlanetDefinition> definition = load_planet_file(args.positional[1]);
  if (!definition) {
    std::cerr << "planet " << command << ": " << definition.error().pointer << ": "
              << definition.error().message << "\n";
    return 1;
  }
  // The CLI reads a local map file; the planet library and the server never open one.
  std::optional<ContinentMap> map;
  if (args.has("--continent-map")) {
    const std::string path = args.get("--continent-map", "");
    const auto bytes = read_file(path);
    if (!bytes) {
      std::cerr << "planet " << command << ": cannot read " << path << "\n";
      return 1;
    }
    Result<ContinentMap> decoded = decode_continent_map(*bytes);
    if (!decoded) {
      std::cerr << "planet " << command << ": " << path << ": " << decoded.error().message << "\n";
      return 1;
    }
    if (!definition->continent_map.empty() && definition->continent_map != decoded->hash) {
      std::cerr << "planet " << command << ": /continent_map: the definition names "
                << definition->continent_map << " but " << path << " is " << decoded->hash << "\n";
      return 1;
    }
    definition->continent_map = decoded->hash;
    map = std::move(decoded).value();
  } else if (!definition->continent_map.empty() && command != "id") {
    std::cerr << "planet " << command << ": /continent_map: the definition names "
              << definition->continent_map << "; give the image with --continent-map FILE.png\n";
    return 1;
  }
  if (command == "export") return cmd_export(args, *definition, map ? &*map : nullptr);
  if (command == "id") {
    std::cout << nlohmann::json{{"id", planet_id(*definition)},
                                {"definition", canonical_json(*definition)}}
                     .dump(2)
              << "\n";
    return 0;
  }
  const auto threads = integer_arg("--threads", args.get("--threads", "1"), 1, 256);
  if (!threads) return 2;
  const auto start = std::chrono::steady_clock::now();
  Result<std::shared_ptr<const Planet>> built =
      Planet::build(*definition, map ? &*map : nullptr, {static_cast<int>(*threads)});
  const double build_ms = elapsed_ms(start);
  if (!built) {
    std::cerr << "planet " << command << ": " << built.error().pointer << ": "
              << built.error().message << "\n";
    return 1;
  }
  map.reset();  // the base mesh holds what it needs; the pixels may be large
  const std::shared_ptr<const Planet> world = std::move(built).value();
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
                                {"lakes", s.lakes},
                                {"closed_lakes", s.closed_lakes},
                                {"longest_river_km", s.longest_river / 1000.0},
                                {"largest_drainage_area_km2", s.largest_drainage_area / 1e6}}
                     .dump(2)
              << "\n";
    return 0;
  }
  if (command == "sample" && args.positional.size() >= 4) {
    const auto lat = tools::parse_number(args.positional[2]);
    const auto lon = tools::parse_number(args.positional[3]);
    if (!lat || !lon || std::abs(*lat) > 90 || std::abs(*lon) > 180) {
      std::cerr << "planet sample: LAT must be -90 to 90 and LON -180 to 180 degrees\n";
      return 2;
    }
    Sampler sampler(world);
    std::cout << sample_json(*lat, *lon, sampler.sample(*lat, *lon)).dump(2) << "\n";
    return 0;
  }
  if (command == "picture" && args.has("-o")) {
    PictureOptions options;
    const auto width = integer_arg("--width", args.get("--width", "2048"), 16, 16384);
    if (!width) return 2;
    options.width = static_cast<int>(*width);
    options.threads = static_cast<int>(*threads);
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
    const auto size = integer_arg("--size", args.get("--size", "256"), 1, 4096);
    const auto grid = integer_arg("--grid", args.get("--grid", "65"), 2, 4097);
    const auto z = integer_arg("Z", args.positional[2], 0, 30);
    const auto x = integer_arg("X", args.positional[3], 0, (1LL << 32));
    const auto y = integer_arg("Y", args.positional[4], 0, (1LL << 31));
    if (!size || !grid || !z || !x || !y) return 2;
    options.size = static_cast<int>(*size);
    options.grid = static_cast<int>(*grid);
    PlanetTiles tiles(world);
    const terrain::TileAddress address{static_cast<int>(*z), static_cast<std::int64_t>(*x),
                                       static_cast<std::int64_t>(*y)};
    const auto t0 = std::chrono::steady_clock::now();
    Result<terrain::TileScheme> scheme = terrain::parse_scheme(args.get("--scheme", "geographic"));
    if (!scheme) {
      std::cerr << "planet tile: --scheme: " << scheme.error().message << "\n";
      return 2;
    }
    Result<terrain::Product> product = tiles.make(*scheme, address, *format, options);
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
  if (command == "analyze" && args.positional.size() >= 4) {
    PlanetAnalysisOptions options;
    const auto lat = tools::parse_number(args.positional[2]);
    const auto lon = tools::parse_number(args.positional[3]);
    const auto size = integer_arg("--size", args.get("--size", "512"), 2, kMaxPlanetAnalysisSide);
    const auto zoom = integer_arg("--zoom", args.get("--zoom", "8"), 0, PlanetTiles::max_zoom());
    const auto margin =
        integer_arg("--margin", args.get("--margin", "0"), 0, kMaxPlanetAnalysisSide / 2);
    if (!lat || !lon) {
      std::cerr << "planet analyze: LAT and LON must be numbers of degrees\n";
      return 2;
    }
    if (!size || !zoom || !margin) return 2;
    options.latitude = *lat;
    options.longitude = *lon;
    options.size = static_cast<int>(*size);
    options.zoom = static_cast<int>(*zoom);
    options.margin = static_cast<int>(*margin);
    if (!positive_arg(args, "analyze", "--cell", "a number of metres", options.cell_size) ||
        !positive_arg(args, "analyze", "--channel-area", "an area in m²",
                      options.analysis.channel_area)) {
      return 2;
    }
    terrain::AnalysisPicture picture;
    const std::string picture_path = args.get("--picture", "");
    Result<nlohmann::json> figures =
        analyze_planet(world, options, picture_path.empty() ? nullptr : &picture);
    if (!figures) {
      std::cerr << "planet analyze: " << figures.error().pointer << ": " << figures.error().message
                << "\n";
      return 2;
    }
    if (!picture_path.empty()) {
      if (terrain::Status written =
              terrain::write_png_rgb8(picture_path, picture.width, picture.height,
                                      picture.rgb.data(), terrain::PngKind::shaded);
          !written) {
        std::cerr << "planet analyze: " << picture_path << ": " << written.error().message << "\n";
        return 1;
      }
    }
    std::cout << figures->dump(2) << "\n";
    return 0;
  }
  if (command == "survey") {
    PlanetSurveyOptions options;
    const auto points = integer_arg("--points", args.get("--points", "64"), 1, kMaxSurveyPoints);
    const auto zoom = integer_arg("--zoom", args.get("--zoom", "8"), 0, PlanetTiles::max_zoom());
    const auto size = integer_arg("--size", args.get("--size", "512"), 2, kMaxPlanetAnalysisSide);
    const auto margin =
        integer_arg("--margin", args.get("--margin", "0"), 0, kMaxPlanetAnalysisSide / 2);
    if (!points || !zoom || !size || !margin) return 2;
    options.points = static_cast<int>(*points);
    options.zoom = static_cast<int>(*zoom);
    options.size = static_cast<int>(*size);
    options.margin = static_cast<int>(*margin);
    Result<nlohmann::json> figures = planet_realism_survey(world, options);
    if (!figures) {
      std::cerr << "planet survey: " << figures.error().pointer << ": " << figures.error().message
                << "\n";
      return 2;
    }
    std::cout << figures->dump(2) << "\n";
    return 0;
  }
  if (command == "hypsometry") {
    PlanetHypsometryOptions options;
    const auto samples =
        integer_arg("--samples", args.get("--samples", "20000"), 100, kMaxHypsometrySamples);
    if (!samples) return 2;
    options.samples = static_cast<int>(*samples);
    if (!positive_arg(args, "hypsometry", "--cell", "a number of metres", options.cell_size)) {
      return 2;
    }
    Result<nlohmann::json> figures = planet_hypsometry(world, options);
    if (!figures) {
      std::cerr << "planet hypsometry: " << figures.error().pointer << ": "
                << figures.error().message << "\n";
      return 2;
    }
    std::cout << figures->dump(2) << "\n";
    return 0;
  }
  if (command == "layer-json") {
    PlanetTiles tiles(world);
    terrain::LayerJsonOptions options;
    options.name = world->id();
    std::cout << tiles.layer_json(options).dump(2) << "\n";
    return 0;
  }
  std::cerr << kUsage << tools::kExportOptionsUsage << kUsageEnd;
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  const auto parsed = tools::parse_cli_args(argc, argv, {"--help", "--gunzip"});
  if (!parsed) {
    std::cerr << "planet: " << parsed.error().message << "\n";
    return 2;
  }
  const Args& args = *parsed;
  if (args.has("--help")) {
    std::cout << kUsage << tools::kExportOptionsUsage << kUsageEnd;
    return 0;
  }
  Args with_planet = args;
  if (!args.positional.empty() && args.positional[0] == "export" &&
      (args.positional.size() == 1 || args.positional[1] == "default")) {
    with_planet.positional.resize(1);
    with_planet.positional.push_back(TERRAIN_DEFAULT_PLANET);
  }
  if (with_planet.positional.size() < 2) {
    std::cerr << kUsage;
    return 2;
  }
  return run(with_planet);
}
