// Tiling schemes and height tiles: how a tile address (z, x, y) becomes sample positions in a
// scene's plane, and the grid of heights and slopes a tile carries to its encoders.
//
// Three schemes (docs/tiles.md):
//  - local: a quadtree over the scene's square extent in scene metres; (0, 0, 0) is the whole
//    square, x grows east, y grows south (row 0 of every image is north), as in XYZ.
//  - webmercator: EPSG:3857 XYZ (MapLibre, OpenStreetMap): y grows south.
//  - geographic: EPSG:4326 TMS with two root tiles (Cesium): x in [0, 2^(z+1)), y grows north.
// Geographic positions reach scene metres through the scene's georeference (tile_frame.hpp).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "terrain/result.hpp"

namespace terrain {

enum class TileScheme { local, webmercator, geographic };

/// "local", "webmercator", "geographic".
std::string_view scheme_name(TileScheme scheme);
/// Parses a scheme name; the error names the accepted values.
Result<TileScheme> parse_scheme(std::string_view name);

/// A tile address. Columns and rows are 64-bit so that validation sees what the user wrote.
struct TileAddress {
  int z = 0;
  std::int64_t x = 0;
  std::int64_t y = 0;
};

/// The deepest zoom level of a scheme (24 for local and webmercator, 23 for geographic).
int max_zoom(TileScheme scheme);
/// Number of tile columns and rows at a zoom level.
std::int64_t columns_at(TileScheme scheme, int z);
std::int64_t rows_at(TileScheme scheme, int z);
/// Checks z against max_zoom and x, y against the grid at z; the error names "z", "x" or "y".
Status validate_address(TileScheme scheme, const TileAddress& address);

/// A rectangle in the scheme's own coordinates: scene metres (local), EPSG:3857 metres
/// (webmercator) or degrees of longitude and latitude (geographic).
struct TileBounds {
  double west = 0.0;
  double south = 0.0;
  double east = 0.0;
  double north = 0.0;
};

/// A tile's footprint in its scheme's coordinates, given the footprint of the zoom-0 grid.
TileBounds tile_footprint(TileScheme scheme, const TileBounds& world, const TileAddress& address);

/// The sphere EPSG:3857 projects (WGS84's semi-major axis), in metres.
inline constexpr double kWebMercatorRadius = 6378137.0;
/// EPSG:3857 coordinates (metres) to longitude and latitude in degrees.
double web_mercator_longitude(double x);
double web_mercator_latitude(double y);

/// Where a tile's samples sit inside its bounds.
enum class SampleLayout {
  /// N×N samples at the centres of an N×N division of the tile (pixel-is-area), as height
  /// images expect; a one-sample border adds the ring of the neighbours' outermost samples.
  cell_centres,
  /// (N+1)×(N+1) samples on the corners of an N×N division (pixel-is-point), as meshes expect:
  /// neighbours share their edge samples.
  cell_corners,
};

/// A grid of heights over one tile: row 0 is the northern row, column 0 the western column.
/// Samples at the same geographic position in two tiles of the same zoom, size and scheme are
/// computed from the same numbers, so neighbours agree bit for bit on what they share.
struct HeightTile {
  TileScheme scheme = TileScheme::local;
  TileAddress address;
  SampleLayout layout = SampleLayout::cell_centres;
  int cells = 256;    ///< N: the division of the tile (samples per side without border)
  int border = 0;     ///< 0 or 1 extra sample on every side (cell_centres only)
  int width = 0;      ///< samples per row including border: N + 2·border, or N + 1 for corners
  int height = 0;     ///< rows, equal to width
  TileBounds world;   ///< footprint of the whole zoom-0 grid (local: the scene's square)
  TileBounds bounds;  ///< the tile's own footprint (without border)
  double ground_spacing = 0.0;  ///< metres between neighbouring samples (the LoD spacing)
  /// Metres the surface may rise between samples above their interpolation (planets: the
  /// refinement's displacement at its level's edge length); mesh error allowances leave room.
  double unseen_relief = 0.0;
  std::vector<float> elevation;    ///< metres, width·height, index row·width + column
  std::vector<float> slope_east;   ///< ∂h/∂east (dimensionless), same layout
  std::vector<float> slope_north;  ///< ∂h/∂north (dimensionless), same layout
  std::vector<double> scene_x;     ///< scene-plane position of each sample (metres)
  std::vector<double> scene_y;

  std::size_t index(int column, int row) const {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(width) +
           static_cast<std::size_t>(column);
  }
  /// The sample's position in the scheme's coordinates (see TileBounds), exact for the layout.
  double sample_crs_x(int column) const;
  double sample_crs_y(int row) const;
};

}  // namespace terrain
