// `terrain export` and `planet export`: the options both share (output, zoom range, bbox,
// encoding or mesh format, threads, tile bound), checked before any work, and the run itself
// with its progress bar. The CLIs supply the tile source.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "cli_args.hpp"
#include "terrain/tile_pack.hpp"

namespace tools {

/// What a source allows.
struct ExportRules {
  std::string command;                              ///< "terrain export", for messages
  terrain::TileScheme png_scheme;                   ///< the scheme of height images
  std::function<int(terrain::TileScheme)> deepest;  ///< the max useful zoom per scheme
  /// The tiles of a zoom without --bbox (a scene's extent); null: the whole world.
  std::function<terrain::TileRange(terrain::TileScheme, int)> default_range;
};

/// The checked options of an export.
struct ExportRequest {
  std::string output;
  terrain::TileFormat format = terrain::TileFormat::terrain_rgb;
  terrain::TileScheme scheme = terrain::TileScheme::webmercator;
  std::vector<terrain::ZoomRange> zooms;
  terrain::TileBounds bounds;  ///< degrees
  int threads = 1;
  std::uint64_t commit_every = 256;  ///< tiles per transaction
};

/// Parses -o, --zoom Z0-Z1, --bbox W,S,E,N, --encoding, --format png|terrain, --threads and
/// --max-tiles and plans the tiles. Prints the error (naming the option) and returns nothing
/// on bad input; nothing is created.
std::optional<ExportRequest> parse_export(const CliArgs& args, const ExportRules& rules);

/// What the tiles are made from.
struct ExportSource {
  std::string name, description, source_id;
  nlohmann::json extra = nlohmann::json::object();
  terrain::MakeTileFactory factory;
};

/// Writes (or resumes) the pack with a progress bar on a terminal's stderr and prints a JSON
/// summary; returns the exit status.
int run_export(const ExportRules& rules, const ExportRequest& request, const ExportSource& source);

/// The usage lines of the export options, shared by both CLIs' help.
extern const char* const kExportOptionsUsage;

}  // namespace tools
