// terrain: command-line access to the terrain model — validate, sample, grid, render, program.
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cli_args.hpp"
#include "export_command.hpp"
#include "gpu/backend.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/geomorphometry.hpp"
#include "terrain/geotiff.hpp"
#include "terrain/gzip.hpp"
#include "terrain/image_io.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"
#include "terrain/scene_analysis.hpp"
#include "terrain/sphere_trace.hpp"
#include "terrain/tile_products.hpp"

namespace {

using namespace terrain;

constexpr const char* kUsage = R"(terrain — procedural terrain construction trees

Usage:
  terrain validate SCENE.json            check a scene; print its hash and bounds
  terrain sample SCENE.json X Y [--lod S]
                                         elevation, weight, gradient and Lipschitz bound at (X, Y)
  terrain grid SCENE.json -o OUT [--size N] [--area X0,Y0,X1,Y1] [--lod S]
                                         heightmap: OUT.tif (float32 metres) or OUT.png (16-bit,
                                         scaled to the scene's elevation range, printed)
  terrain render SCENE.json -o OUT.png [--width W] [--height H] [--plain] [--water Z]
       [--no-shadows] [--no-occlusion]   sphere-traced picture: materials, soft sun shadows,
                                         sky occlusion, sky and aerial perspective
  terrain tile SCENE.json Z X Y -o OUT.{png,jpg,tif,terrain,glb,drc} [--scheme S] [--encoding E]
       [--size N] [--border] [--grid N] [--max-error M] [--regular] [--gunzip]
       [--backend auto|gpu|cpu]
                                         one tile: S = local (default), webmercator or
                                         geographic; E (PNG) = terrain-rgb (default), terrarium,
                                         gray16, normals, hillshade, color (imagery; also
                                         .jpg); .terrain (quantized-mesh,
                                         geographic only) is written gzipped as served unless
                                         --gunzip; prints what it wrote as JSON, with the
                                         evaluator (backend, default cpu; gpu = EGL compute)
  terrain layer-json SCENE.json          Cesium layer.json for the scene's geographic tiles
  terrain export SCENE.json              an offline pack (MBTiles 1.3 or PMTiles v3) of the tiles
                                         the server serves: PNG in Web Mercator XYZ, meshes
                                         geographic (docs/packs.md)
)";

constexpr const char* kUsageEnd =
    R"(  terrain analyze SCENE.json|DEM.{tif,png} [--size N] [--area X0,Y0,X1,Y1] [--cell M]
       [--z-scale F] [--sea-level Z] [--channel-area M2] [--picture FILE.png]
                                         geomorphometry as JSON: pits, closed depressions,
                                         Flint's law and the slope–area profile, Strahler
                                         orders, Horton ratio, drainage density, hypsometric
                                         integral; a picture of the drainage (docs/analysis.md)
  terrain program SCENE.json             the compiled program as JSON
  terrain nodes                          every node type: summary and example (JSON)
  terrain --help

Images referenced by a scene are read relative to the scene file.
)";

using Args = tools::CliArgs;
using tools::parse_number;

/// A scene file parsed and compiled; errors are printed with the file and JSON pointer.
struct Loaded {
  Scene scene;
  Program program;
};

std::optional<Loaded> load(const std::string& path) {
  Result<Scene> scene = load_scene_file(path);
  if (!scene) {
    std::cerr << path << ": "
              << (scene.error().pointer.empty() ? "(document)" : scene.error().pointer) << ": "
              << scene.error().message << "\n";
    return std::nullopt;
  }
  Result<Program> program = compile(*scene);
  if (!program) {
    std::cerr << path << ": " << program.error().pointer << ": " << program.error().message << "\n";
    return std::nullopt;
  }
  return Loaded{std::move(scene).value(), std::move(program).value()};
}

void progress_bar(float fraction) {
  static const bool tty = isatty(STDERR_FILENO) != 0;
  const int width = 40;
  const int filled = static_cast<int>(fraction * width);
  std::fprintf(stderr, "%s[%.*s%*s] %3d%%%s", tty ? "\r" : "", filled,
               "########################################", width - filled, "",
               static_cast<int>(fraction * 100.0f), (tty && fraction < 1.0f) ? "" : "\n");
  std::fflush(stderr);
}

int cmd_validate(const Args& args) {
  const auto loaded = load(args.positional.at(1));
  if (!loaded) return 1;
  const auto& [scene, program] = *loaded;
  const NodeBounds& b = program.bounds;
  std::cout << nlohmann::json{{"valid", true},
                              {"name", scene.name},
                              {"hash", scene.hash},
                              {"instructions", program.code.size()},
                              {"parameters", program.pool.size()},
                              {"support",
                               {b.support.lo.x, b.support.lo.y, b.support.hi.x, b.support.hi.y}},
                              {"elevation", {b.elevation.lo, b.elevation.hi}},
                              {"lipschitz", b.elevation_lipschitz}}
                   .dump(2)
            << "\n";
  return 0;
}

int cmd_sample(const Args& args) {
  if (args.positional.size() != 4) {
    std::cerr << "terrain sample: needs SCENE X Y\n";
    return 2;
  }
  const auto x = parse_number(args.positional[2]), y = parse_number(args.positional[3]);
  const auto lod = parse_number(args.get("--lod", "0"));
  if (!x || !y || !lod || *lod < 0) {
    std::cerr << "terrain sample: X, Y and --lod must be numbers (lod ≥ 0)\n";
    return 2;
  }
  const auto loaded = load(args.positional[1]);
  if (!loaded) return 1;
  const auto& [scene, program] = *loaded;
  Evaluator e(program);
  const Vec2 p{static_cast<float>(*x), static_cast<float>(*y)};
  const FieldSample s = e.sample(p, static_cast<float>(*lod));
  const NodeBounds local = e.bounds({Box2::around(p, 1.0f), static_cast<float>(*lod)});
  std::cout << nlohmann::json{{"x", *x},
                              {"y", *y},
                              {"elevation", s.elevation},
                              {"weight", s.weight},
                              {"gradient", {s.elevation_gradient.x, s.elevation_gradient.y}},
                              {"lipschitz_local", local.elevation_lipschitz},
                              {"lipschitz_global", program.bounds.elevation_lipschitz}}
                   .dump(2)
            << "\n";
  return 0;
}

std::optional<Box2> parse_area(const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ',')) {
    const auto n = parse_number(part);
    if (!n) return std::nullopt;
    v.push_back(*n);
  }
  if (v.size() != 4 || !(v[0] < v[2]) || !(v[1] < v[3])) return std::nullopt;
  return Box2{{static_cast<float>(v[0]), static_cast<float>(v[1])},
              {static_cast<float>(v[2]), static_cast<float>(v[3])}};
}

// The grid `terrain grid` and `terrain analyze` sample: N × N points over --area (the scene's
// area by default), a square of its larger side; nullopt, the refusal printed, for a bad --area.
std::optional<GridSpec> square_grid(const Args& args, const Scene& scene, int n,
                                    std::string_view command) {
  Box2 area = scene.area();
  if (args.has("--area")) {
    const auto a = parse_area(args.get("--area", ""));
    if (!a) {
      std::cerr << "terrain " << command
                << ": --area must be X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1\n";
      return std::nullopt;
    }
    area = *a;
  }
  const double side = std::max(area.size().x, area.size().y);
  return GridSpec{area.lo.x, area.lo.y, side / (n - 1), n, n, -1.0f};
}

int cmd_grid(const Args& args) {
  const std::string out = args.get("-o", "");
  const auto size = parse_number(args.get("--size", "512"));
  if (out.empty() || !size || *size < 2 || *size > 8192 || std::floor(*size) != *size) {
    std::cerr << "terrain grid: needs -o OUT.tif|OUT.png and --size from 2 to 8192\n";
    return 2;
  }
  const auto loaded = load(args.positional.at(1));
  if (!loaded) return 1;
  const auto& [scene, program] = *loaded;
  std::optional<GridSpec> square = square_grid(args, scene, static_cast<int>(*size), "grid");
  if (!square) return 2;
  GridSpec grid = *square;
  const int n = grid.width;
  if (args.has("--lod"))
    grid.lod_spacing = static_cast<float>(parse_number(args.get("--lod", "0")).value_or(0));
  const auto start = std::chrono::steady_clock::now();
  const GridResult result = evaluate_grid(program, grid);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  // Images store row 0 at the top (north); the grid's row 0 is the south.
  std::vector<float> north_up(result.elevation.size());
  for (int j = 0; j < n; ++j) {
    std::copy_n(result.elevation.begin() + static_cast<std::ptrdiff_t>(j) * n, n,
                north_up.begin() + static_cast<std::ptrdiff_t>(n - 1 - j) * n);
  }
  Status written = Status(Ok{});
  nlohmann::json info{{"output", out},
                      {"size", n},
                      {"step", grid.step},
                      {"milliseconds", ms},
                      {"origin", {grid.origin_x, grid.origin_y}}};
  if (out.ends_with(".png")) {
    const Interval z = program.bounds.elevation.hull(Interval::point(program.base_elevation));
    const float scale = z.width() > 0 ? z.width() / 65535.0f : 1.0f;
    std::vector<std::uint16_t> pixels(north_up.size());
    for (std::size_t i = 0; i < north_up.size(); ++i) {
      pixels[i] = static_cast<std::uint16_t>(
          std::lround(std::clamp((north_up[i] - z.lo) / scale, 0.0f, 65535.0f)));
    }
    written = write_png16(out, n, n, pixels.data());
    info["elevation_offset"] = z.lo;
    info["elevation_scale"] = scale;
  } else {
    // Georeferenced like local tiles: the scene's plane in metres (see geotiff.hpp), row 0 at
    // the grid's north edge.
    const double north = grid.origin_y + static_cast<double>(n - 1) * grid.step;
    Result<std::vector<std::uint8_t>> tiff = encode_scene_plane_geotiff(
        north_up.data(), n, n, grid.origin_x, north, grid.step, scene.georeference);
    if (!tiff) {
      written = tiff.error();
    } else {
      std::FILE* file = std::fopen(out.c_str(), "wb");
      if (file == nullptr || std::fwrite(tiff->data(), 1, tiff->size(), file) != tiff->size() ||
          std::fclose(file) != 0) {
        written = Error{"cannot write " + out, ""};
      }
    }
  }
  if (!written) {
    std::cerr << "terrain grid: " << written.error().message << "\n";
    return 1;
  }
  std::cout << info.dump(2) << "\n";
  return 0;
}

int cmd_render(const Args& args) {
  const std::string out = args.get("-o", "");
  const auto width = parse_number(args.get("--width", "960"));
  const auto height = parse_number(args.get("--height", "540"));
  if (out.empty() || !width || !height || *width < 1 || *height < 1 || *width > 8192 ||
      *height > 8192) {
    std::cerr << "terrain render: needs -o OUT.png; --width/--height from 1 to 8192\n";
    return 2;
  }
  const auto loaded = load(args.positional.at(1));
  if (!loaded) return 1;
  const auto& [scene, program] = *loaded;
  const Box2 area = scene.area();
  const Camera camera =
      default_camera(program, area, static_cast<int>(*width), static_cast<int>(*height));
  RenderOptions options;
  options.trace.accelerated = !args.has("--plain");
  options.shadows = !args.has("--no-shadows");
  options.occlusion = !args.has("--no-occlusion");
  options.material = scene.material;
  std::optional<WaterRaster> water;
  if (scene.water) {
    Result<Program> water_program = compile_water(scene);
    if (!water_program) {
      std::cerr << "terrain render: /water: " << water_program.error().message << "\n";
      return 1;
    }
    water = water_raster(*water_program, area);
    options.water = &*water;
  }
  if (args.has("--water"))
    options.water_level = static_cast<float>(parse_number(args.get("--water", "0")).value_or(-1e9));
  options.progress = progress_bar;
  const auto start = std::chrono::steady_clock::now();
  const Picture picture = render(program, area, camera, options);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const Status written = write_png_rgb8(out, picture.width, picture.height, picture.rgb.data(),
                                        terrain::PngKind::shaded);
  if (!written) {
    std::cerr << "terrain render: " << written.error().message << "\n";
    return 1;
  }
  std::cout << nlohmann::json{{"output", out},
                              {"milliseconds", ms},
                              {"steps_per_pixel", static_cast<double>(picture.total_steps) /
                                                      (picture.width * picture.height)}}
                   .dump(2)
            << "\n";
  return 0;
}

/// The pixel size of a classic little- or big-endian TIFF's first image: ModelPixelScaleTag's x
/// scale, or the length of ModelTransformationTag's first column (a rotated plane); nothing
/// without either (or for BigTIFF, not a TIFF, unreadable). Every read is bounds-checked.
std::optional<double> geotiff_pixel_size(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  auto bytes_at = [&in](std::uint64_t offset, std::size_t count) -> std::optional<std::string> {
    std::string buffer(count, '\0');
    in.clear();
    in.seekg(static_cast<std::streamoff>(offset));
    if (!in.read(buffer.data(), static_cast<std::streamsize>(count))) return std::nullopt;
    return buffer;
  };
  const auto header = bytes_at(0, 8);
  if (!header || ((*header)[0] != 'I' && (*header)[0] != 'M')) return std::nullopt;
  const bool little = (*header)[0] == 'I';
  auto number = [little](const std::string& b, std::size_t at, std::size_t size) {
    std::uint64_t v = 0;
    for (std::size_t k = 0; k < size; ++k) {
      const auto byte = static_cast<std::uint8_t>(b[at + (little ? size - 1 - k : k)]);
      v = (v << 8) | byte;
    }
    return v;
  };
  auto doubles_at = [&](std::uint64_t offset, std::size_t count) -> std::vector<double> {
    const auto raw = bytes_at(offset, count * 8);
    std::vector<double> values;
    for (std::size_t k = 0; raw && k < count; ++k) {
      const std::uint64_t bits = number(*raw, k * 8, 8);
      double v = 0.0;
      std::memcpy(&v, &bits, sizeof v);
      values.push_back(v);
    }
    return values;
  };
  if (number(*header, 2, 2) != 42) return std::nullopt;
  const std::uint64_t ifd = number(*header, 4, 4);
  const auto count_bytes = bytes_at(ifd, 2);
  if (!count_bytes) return std::nullopt;
  const std::uint64_t entries = number(*count_bytes, 0, 2);
  const auto table = bytes_at(ifd + 2, static_cast<std::size_t>(entries) * 12);
  if (!table) return std::nullopt;
  std::optional<double> size;
  for (std::size_t e = 0; e < entries; ++e) {
    const std::size_t at = e * 12;
    const std::uint64_t tag = number(*table, at, 2);
    const std::uint64_t count = number(*table, at + 4, 4);
    if (number(*table, at + 2, 2) != 12) continue;  // DOUBLEs, stored at an offset
    const std::uint64_t offset = number(*table, at + 8, 4);
    if (tag == 33550 && count >= 1) {  // ModelPixelScaleTag: (x, y, z)
      const std::vector<double> scale = doubles_at(offset, 1);
      if (!scale.empty()) size = scale[0];
    } else if (tag == 34264 && count == 16) {  // ModelTransformationTag: a 4 × 4 matrix
      const std::vector<double> m = doubles_at(offset, 16);
      if (m.size() == 16) size = std::hypot(m[0], m[4]);
    }
  }
  if (size && std::isfinite(*size) && *size > 0.0) return size;
  return std::nullopt;
}

bool is_raster_path(std::string path) {
  std::transform(path.begin(), path.end(), path.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* ext : {".tif", ".tiff", ".png", ".exr"}) {
    if (path.ends_with(ext)) return true;
  }
  return false;
}

int cmd_analyze(const Args& args) {
  const std::string path = args.positional.at(1);
  const auto size = tools::parse_integer(args.get("--size", "512"), 2, 4096);
  if (!size) {
    std::cerr << "terrain analyze: --size must be an integer from 2 to 4096\n";
    return 2;
  }
  AnalysisOptions options;
  if (args.has("--channel-area")) {
    const auto a = parse_number(args.get("--channel-area", ""));
    if (!a || *a <= 0) {
      std::cerr << "terrain analyze: --channel-area must be an area in m² greater than 0\n";
      return 2;
    }
    options.channel_area = *a;
  }
  std::optional<float> sea_level;
  if (args.has("--sea-level")) {
    const auto z = parse_number(args.get("--sea-level", ""));
    if (!z) {
      std::cerr << "terrain analyze: --sea-level must be an elevation in metres\n";
      return 2;
    }
    sea_level = static_cast<float>(*z);
  }
  AnalysisPicture picture;
  const std::string picture_path = args.get("--picture", "");
  const auto write_picture = [&] {
    if (picture_path.empty()) return true;
    const Status written = write_png_rgb8(picture_path, picture.width, picture.height,
                                          picture.rgb.data(), PngKind::shaded);
    if (!written)
      std::cerr << "terrain analyze: " << picture_path << ": " << written.error().message << "\n";
    return static_cast<bool>(written);
  };
  nlohmann::json input{{"path", path}};
  std::vector<float> elevation;
  std::vector<std::uint8_t> water;
  int width = 0, height = 0;
  double cell = 0.0;
  if (is_raster_path(path)) {
    const auto z_scale = parse_number(args.get("--z-scale", "1"));
    if (!z_scale || *z_scale <= 0) {
      std::cerr << "terrain analyze: --z-scale must be a number greater than 0\n";
      return 2;
    }
    Result<Raster> raster = read_heightfield(path);
    if (!raster) {
      std::cerr << path << ": " << raster.error().message << "\n";
      return 1;
    }
    width = raster->width;
    height = raster->height;
    elevation = std::move(raster->samples);
    for (float& z : elevation) z = static_cast<float>(z * *z_scale);
    const std::optional<double> pixel = geotiff_pixel_size(path);
    if (args.has("--cell")) {
      const auto c = parse_number(args.get("--cell", ""));
      if (!c || *c <= 0) {
        std::cerr << "terrain analyze: --cell must be a number of metres greater than 0\n";
        return 2;
      }
      cell = *c;
    } else if (pixel) {
      cell = *pixel;
    } else {
      std::cerr << "terrain analyze: " << path
                << " has no GeoTIFF pixel size: give the cell size with --cell M\n";
      return 2;
    }
    input["kind"] = "raster";
    input["cell_size_from"] = args.has("--cell") ? "--cell" : "GeoTIFF";
  } else {
    const auto loaded = load(path);
    if (!loaded) return 1;
    const auto& [scene, program] = *loaded;
    SceneAnalysisOptions scene_options;
    scene_options.size = static_cast<int>(*size);
    scene_options.sea_level = sea_level;
    scene_options.analysis = options;
    if (args.has("--area")) {
      scene_options.area = parse_area(args.get("--area", ""));
      if (!scene_options.area) {
        std::cerr << "terrain analyze: --area must be X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1\n";
        return 2;
      }
    }
    Result<nlohmann::json> analysis =
        analyze_scene(scene, program, scene_options, picture_path.empty() ? nullptr : &picture);
    if (!analysis) {
      std::cerr << "terrain analyze: " << path << ": " << analysis.error().pointer << ": "
                << analysis.error().message << "\n";
      return 1;
    }
    if (!write_picture()) return 1;
    (*analysis)["input"]["path"] = path;
    std::cout << analysis->dump(2) << "\n";
    return 0;
  }
  ElevationGrid grid{width, height, cell, elevation, sea_level, water};
  Result<Geomorphometry> figures =
      analyze(grid, options, picture_path.empty() ? nullptr : &picture);
  if (!figures) {
    std::cerr << "terrain analyze: " << figures.error().pointer << ": " << figures.error().message
              << "\n";
    return 1;
  }
  if (!write_picture()) return 1;
  nlohmann::json out = to_json(*figures);
  out["input"] = input;
  if (sea_level) out["input"]["sea_level_m"] = *sea_level;
  std::cout << out.dump(2) << "\n";
  return 0;
}

int cmd_program(const Args& args) {
  const auto loaded = load(args.positional.at(1));
  if (!loaded) return 1;
  const auto& [scene, program] = *loaded;
  std::cout << program.to_json().dump(2) << "\n";
  return 0;
}

int cmd_nodes() {
  nlohmann::json out = nlohmann::json::array();
  for (const NodeType* t : node_types()) {
    out.push_back({{"type", t->name},
                   {"id", t->id},
                   {"category", category_name(t->category)},
                   {"summary", t->summary},
                   {"example", nlohmann::json::parse(t->example_json)}});
  }
  std::cout << out.dump(2) << "\n";
  return 0;
}

std::optional<std::int64_t> to_integer(const std::string& text) {
  std::int64_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return v;
}

std::unique_ptr<ProductMaker> product_maker(const std::string& path) {
  Result<Scene> scene = load_scene_file(path);
  if (!scene) {
    std::cerr << path << ": " << scene.error().pointer << ": " << scene.error().message << "\n";
    return nullptr;
  }
  Result<TileSource> source = TileSource::from_scene(*scene);
  if (!source) {
    std::cerr << path << ": " << source.error().pointer << ": " << source.error().message << "\n";
    return nullptr;
  }
  return std::make_unique<ProductMaker>(std::move(source).value());
}

int cmd_tile(const Args& args) {
  if (args.positional.size() != 5 || !args.has("-o")) {
    std::cerr << "terrain tile: needs SCENE Z X Y -o OUT\n";
    return 2;
  }
  const auto z = to_integer(args.positional[2]);
  const auto x = to_integer(args.positional[3]);
  const auto y = to_integer(args.positional[4]);
  if (!z || !x || !y || *z < -1000 || *z > 1000) {
    std::cerr << "terrain tile: Z X Y must be integers\n";
    return 2;
  }
  const std::string out = args.get("-o", "");
  const std::size_t dot = out.rfind('.');
  Result<TileFormat> format =
      parse_tile_format(dot == std::string::npos ? "" : std::string_view(out).substr(dot + 1),
                        args.get("--encoding", ""));
  Result<TileScheme> scheme = parse_scheme(args.get("--scheme", "local"));
  for (const Error* e :
       {format.ok() ? nullptr : &format.error(), scheme.ok() ? nullptr : &scheme.error()}) {
    if (e != nullptr) {
      std::cerr << "terrain tile: " << e->pointer << ": " << e->message << "\n";
      return 2;
    }
  }
  ProductOptions options;
  const auto size = to_integer(args.get("--size", "256"));
  const auto grid = to_integer(args.get("--grid", "65"));
  if (!size || !grid || *size > 4096 || *grid > 4096) {
    std::cerr << "terrain tile: --size and --grid take integers\n";
    return 2;
  }
  options.size = static_cast<int>(*size);
  options.grid = static_cast<int>(*grid);
  options.border = args.has("--border");
  options.regular = args.has("--regular");
  if (args.has("--max-error")) {
    options.max_error = parse_number(args.get("--max-error", ""));
    if (!options.max_error) {
      std::cerr << "terrain tile: --max-error takes a number of metres\n";
      return 2;
    }
  }
  auto maker = product_maker(args.positional[1]);
  if (!maker) return 1;
  Result<gpu::BackendChoice> backend = gpu::choose_backend(args.get("--backend", "cpu"));
  if (!backend) {
    std::cerr << "terrain tile: --backend: " << backend.error().message << "\n";
    return 2;
  }
  maker->set_backend(backend->backend);
  const auto start = std::chrono::steady_clock::now();
  Result<Product> product = maker->make(*scheme, {static_cast<int>(*z), *x, *y}, *format, options);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!product) {
    std::cerr << "terrain tile: " << product.error().pointer << ": " << product.error().message
              << "\n";
    return 1;
  }
  std::vector<std::uint8_t> bytes = std::move(product->bytes);
  std::string encoding = product->content_encoding;
  if (args.has("--gunzip") && encoding == "gzip") {
    Result<std::vector<std::uint8_t>> raw = gzip_decompress(bytes, std::size_t{1} << 30);
    if (!raw) {
      std::cerr << "terrain tile: " << raw.error().message << "\n";
      return 1;
    }
    bytes = std::move(*raw);
    encoding.clear();
  }
  std::FILE* file = std::fopen(out.c_str(), "wb");
  if (file == nullptr || std::fwrite(bytes.data(), 1, bytes.size(), file) != bytes.size() ||
      std::fclose(file) != 0) {
    std::cerr << "terrain tile: cannot write " << out << "\n";
    return 1;
  }
  nlohmann::json report{{"file", out},
                        {"bytes", bytes.size()},
                        {"media_type", product->media_type},
                        {"backend", product->backend},
                        {"milliseconds", std::round(ms * 100.0) / 100.0}};
  if (!encoding.empty()) report["content_encoding"] = encoding;
  if (*format == TileFormat::gray16) {
    report["gray16"] = {{"offset", maker->constants().gray16.offset},
                        {"scale", maker->constants().gray16.scale},
                        {"height", "offset + scale * value"}};
  }
  std::cout << report.dump(2) << "\n";
  return 0;
}

int cmd_layer_json(const Args& args) {
  auto maker = product_maker(args.positional.at(1));
  if (!maker) return 1;
  LayerJsonOptions options;
  options.name = maker->source().terrain->scene_hash;
  std::cout << maker->layer_json(options).dump(2) << "\n";
  return 0;
}

int cmd_export(const Args& args) {
  auto maker = product_maker(args.positional.at(1));
  if (!maker) return 1;
  const ProductConstants constants = maker->constants();
  const TileSource source = maker->source();
  tools::ExportRules rules;
  rules.command = "terrain export";
  rules.png_scheme = TileScheme::webmercator;
  rules.deepest = [constants](TileScheme scheme) {
    return constants.max_useful_zoom[static_cast<int>(scheme)];
  };
  // Without --bbox: the tiles over the scene's area; geographic zoom 0 whole, as layer.json
  // lists both root tiles (CesiumJS needs them).
  rules.default_range = [source](TileScheme scheme, int z) {
    if (scheme == TileScheme::geographic && z == 0) return TileRange{0, 0, 1, 0};
    return tiles_covering_area(source, scheme, z);
  };
  const std::optional<tools::ExportRequest> request = tools::parse_export(args, rules);
  if (!request) return 2;
  tools::ExportSource pack;
  const std::string& hash = source.terrain->scene_hash;
  pack.source_id = hash;
  Result<Scene> scene = load_scene_file(args.positional[1]);
  pack.name = scene && !scene->name.empty() ? scene->name : hash;
  pack.description = "terrain export of scene " + hash;
  if (request->format == TileFormat::quantized_mesh) {
    // What the server's layer.json says, trimmed to the pack's zooms.
    LayerJsonOptions options;
    options.name = pack.name;
    nlohmann::json layer = maker->layer_json(options);
    const int last = request->zooms.back().z;
    layer["maxzoom"] = last;
    if (layer.contains("available") &&
        layer["available"].size() > static_cast<std::size_t>(last) + 1) {
      layer["available"].erase(layer["available"].begin() + last + 1, layer["available"].end());
    }
    pack.extra["layer_json"] = layer;
  }
  const TileScheme scheme = request->scheme;
  const TileFormat format = request->format;
  // One ProductMaker per thread, with the server's default options (for quantized-mesh those
  // are what a default CesiumJS client asks for: normals, water mask and metadata).
  pack.factory = [source, scheme, format]() -> MakeTile {
    auto tiles = std::make_shared<ProductMaker>(source);
    return
        [tiles, scheme, format](const TileAddress& address) -> Result<std::vector<std::uint8_t>> {
          Result<Product> product = tiles->make(scheme, address, format, ProductOptions{});
          if (!product) return product.error();
          return std::move(product->bytes);
        };
  };
  return tools::run_export(rules, *request, pack);
}

}  // namespace

int main(int argc, char** argv) {
  const auto args = tools::parse_cli_args(argc, argv,
                                          {"--plain", "--no-shadows", "--no-occlusion", "--help",
                                           "-h", "--border", "--regular", "--gunzip"});
  if (!args) {
    std::cerr << "terrain: " << args.error().message << "\n";
    return 2;
  }
  if (args->has("--help") || args->has("-h") || args->positional.empty()) {
    std::cout << kUsage << tools::kExportOptionsUsage << kUsageEnd;
    return args->positional.empty() && !args->has("--help") && !args->has("-h") ? 2 : 0;
  }
  const std::string& command = args->positional[0];
  if (command == "nodes") return cmd_nodes();
  if (args->positional.size() < 2) {
    std::cerr << "terrain " << command << ": needs a scene file\n" << kUsage;
    return 2;
  }
  if (command == "validate") return cmd_validate(*args);
  if (command == "sample") return cmd_sample(*args);
  if (command == "grid") return cmd_grid(*args);
  if (command == "render") return cmd_render(*args);
  if (command == "program") return cmd_program(*args);
  if (command == "analyze") return cmd_analyze(*args);
  if (command == "tile") return cmd_tile(*args);
  if (command == "layer-json") return cmd_layer_json(*args);
  if (command == "export") return cmd_export(*args);
  std::cerr << "terrain: unknown command '" << command << "'\n" << kUsage;
  return 2;
}
