// The shared half of `terrain export` and `planet export` (see export_command.hpp).
#include "export_command.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <thread>

namespace tools {

const char* const kExportOptionsUsage =
    R"(       -o OUT.{mbtiles,pmtiles} --zoom Z0-Z1 [--bbox W,S,E,N] [--encoding E] [--format F]
       [--threads N] [--max-tiles N] [--commit-every N]
                                         E = terrain-rgb (default), terrarium or color
                                         (imagery); F = png (default), jpg (color) or terrain
                                         (quantized-mesh, gzipped, with normals, water mask and
                                         metadata: geographic scheme);
                                         bbox in degrees (default: the whole source); an
                                         interrupted export resumes when rerun; N threads
                                         (default: every core); --max-tiles (default 1000000);
                                         a kill loses at most --commit-every tiles (256)
)";

namespace {

// The option a library error's pointer stands for.
std::string option_of(const std::string& pointer) {
  if (pointer == "/zoom") return "--zoom";
  if (pointer == "/bbox") return "--bbox";
  if (pointer == "/max_tiles") return "--max-tiles";
  if (pointer == "/format") return "--format";
  if (pointer == "/encoding") return "--encoding";
  if (pointer == "/output") return "-o";
  return pointer;
}

void print_error(const ExportRules& rules, const terrain::Error& e) {
  std::cerr << rules.command << ": " << option_of(e.pointer) << ": " << e.message << "\n";
}

std::optional<std::vector<double>> numbers(const std::string& text, char separator) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, separator)) {
    const auto v = parse_number(part);
    if (!v) return std::nullopt;
    out.push_back(*v);
  }
  return out;
}

std::string duration_text(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--";
  const auto s = static_cast<long long>(seconds + 0.5);
  char text[32];
  if (s >= 3600) {
    std::snprintf(text, sizeof text, "%lldh%02lldm", s / 3600, (s / 60) % 60);
  } else {
    std::snprintf(text, sizeof text, "%lldm%02llds", s / 60, s % 60);
  }
  return text;
}

void draw_progress(const terrain::PackProgress& p) {
  const double fraction =
      p.total > 0 ? static_cast<double>(p.done) / static_cast<double>(p.total) : 1;
  const double made = static_cast<double>(p.done - p.resumed);
  const double rate = p.seconds > 0 ? made / p.seconds : 0.0;
  const double eta = rate > 0 ? static_cast<double>(p.total - p.done) / rate : -1.0;
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(fraction * kWidth);
  std::fprintf(stderr, "\r[%.*s%*s] %llu/%llu tiles  %.1f tiles/s  ETA %s  ", filled,
               "##############################", kWidth - filled, "",
               static_cast<unsigned long long>(p.done), static_cast<unsigned long long>(p.total),
               rate, duration_text(eta).c_str());
  std::fflush(stderr);
}

}  // namespace

std::optional<ExportRequest> parse_export(const CliArgs& args, const ExportRules& rules) {
  auto fail = [&](const std::string& option, const std::string& message) {
    std::cerr << rules.command << ": " << option << ": " << message << "\n";
    return std::nullopt;
  };
  ExportRequest request;
  request.output = args.get("-o", "");
  if (request.output.empty())
    return fail("-o", "needs the output file, OUT.mbtiles or OUT.pmtiles");
  if (auto format = terrain::pack_format_for_path(request.output); !format) {
    return fail("-o", format.error().message);
  }
  const std::string format = args.get("--format", "png");
  if (format == "terrain") {
    if (args.has("--encoding")) return fail("--encoding", "only image packs have an encoding");
    request.format = terrain::TileFormat::quantized_mesh;
    request.scheme = terrain::TileScheme::geographic;
  } else if (format == "png") {
    const std::string encoding = args.get("--encoding", "terrain-rgb");
    if (encoding == "terrain-rgb") {
      request.format = terrain::TileFormat::terrain_rgb;
    } else if (encoding == "terrarium") {
      request.format = terrain::TileFormat::terrarium;
    } else if (encoding == "color") {
      request.format = terrain::TileFormat::color_png;
    } else {
      return fail("--encoding", "must be terrain-rgb, terrarium or color, not '" + encoding + "'");
    }
    request.scheme = rules.png_scheme;
  } else if (format == "jpg") {
    if (args.get("--encoding", "color") != "color") {
      return fail("--encoding", "JPEG packs hold colour imagery: color");
    }
    request.format = terrain::TileFormat::color_jpeg;
    request.scheme = rules.png_scheme;
  } else {
    return fail("--format", "must be png, jpg or terrain, not '" + format + "'");
  }

  terrain::PackArea area;
  area.scheme = request.scheme;
  if (!args.has("--zoom")) return fail("--zoom", "needs a zoom level or range, e.g. --zoom 0-8");
  const std::string zoom = args.get("--zoom", "");
  const std::size_t dash = zoom.find('-', 1);
  const auto z0 = parse_integer(zoom.substr(0, dash), -1000, 1000);
  const auto z1 =
      dash == std::string::npos ? z0 : parse_integer(zoom.substr(dash + 1), -1000, 1000);
  if (!z0 || !z1) return fail("--zoom", "must be Z or Z0-Z1 with integers, not '" + zoom + "'");
  area.min_zoom = static_cast<int>(*z0);
  area.max_zoom = static_cast<int>(*z1);
  area.max_useful_zoom = rules.deepest(request.scheme);
  if (args.has("--bbox")) {
    const auto v = numbers(args.get("--bbox", ""), ',');
    if (!v || v->size() != 4) return fail("--bbox", "must be four numbers W,S,E,N in degrees");
    area.bbox = terrain::TileBounds{(*v)[0], (*v)[1], (*v)[2], (*v)[3]};
  } else if (rules.default_range) {
    const terrain::TileScheme scheme = request.scheme;
    area.default_range = [&rules, scheme](int z) { return rules.default_range(scheme, z); };
  }
  const auto max_tiles = parse_integer(args.get("--max-tiles", "1000000"), 1, 1LL << 40);
  if (!max_tiles) return fail("--max-tiles", "must be a positive integer");
  area.max_tiles = static_cast<std::uint64_t>(*max_tiles);
  const auto commit_every = parse_integer(args.get("--commit-every", "256"), 1, 1LL << 30);
  if (!commit_every) return fail("--commit-every", "must be a positive integer");
  request.commit_every = static_cast<std::uint64_t>(*commit_every);
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const auto threads = parse_integer(args.get("--threads", std::to_string(cores)), 1, 256);
  if (!threads) return fail("--threads", "must be an integer from 1 to 256");
  request.threads = static_cast<int>(*threads);

  terrain::Result<std::vector<terrain::ZoomRange>> zooms = terrain::plan_zoom_ranges(area);
  if (!zooms) {
    print_error(rules, zooms.error());
    return std::nullopt;
  }
  request.zooms = std::move(zooms).value();
  request.bounds = area.bbox ? *area.bbox
                             : terrain::range_bounds_degrees(request.scheme, request.zooms.back().z,
                                                             request.zooms.back().range);
  return request;
}

int run_export(const ExportRules& rules, const ExportRequest& request, const ExportSource& source) {
  terrain::PackPlan plan;
  plan.scheme = request.scheme;
  plan.format = request.format;
  plan.zooms = request.zooms;
  plan.bounds = request.bounds;
  plan.name = source.name;
  plan.description = source.description;
  plan.source_id = source.source_id;
  plan.extra = source.extra;
  terrain::PackOptions options;
  options.threads = request.threads;
  options.commit_every = request.commit_every;
  const bool tty = isatty(STDERR_FILENO) != 0;
  if (tty) options.progress = draw_progress;
  terrain::Result<terrain::PackReport> report =
      terrain::write_pack(request.output, plan, source.factory, options);
  if (tty) std::fputc('\n', stderr);
  if (!report) {
    print_error(rules, report.error());
    return 1;
  }
  nlohmann::json ranges = nlohmann::json::array();
  for (const terrain::ZoomRange& zoom : request.zooms) {
    ranges.push_back(
        {zoom.z, zoom.range.min_x, zoom.range.min_y, zoom.range.max_x, zoom.range.max_y});
  }
  const double rate = report->seconds > 0 ? static_cast<double>(report->made) / report->seconds : 0;
  std::cout << nlohmann::json{{"file", request.output},
                              {"encoding", terrain::format_info(request.format).encoding.empty()
                                               ? "quantized-mesh"
                                               : terrain::format_info(request.format).encoding},
                              {"scheme", terrain::scheme_name(request.scheme)},
                              {"zooms", {request.zooms.front().z, request.zooms.back().z}},
                              {"ranges", ranges},
                              {"tiles", report->tiles},
                              {"made", report->made},
                              {"resumed", report->resumed},
                              {"unique_contents", report->unique_contents},
                              {"bytes", report->bytes},
                              {"threads", request.threads},
                              {"seconds", std::round(report->seconds * 1000.0) / 1000.0},
                              {"tiles_per_second", std::round(rate * 10.0) / 10.0}}
                   .dump()
            << "\n";
  return 0;
}

}  // namespace tools
