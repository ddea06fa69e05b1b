// Image encodings of a height tile (docs/tile-encodings.md): terrain-RGB, Terrarium and 16-bit
// grey PNGs for clients that decode heights, a georeferenced float GeoTIFF for GIS tools, and
// normal-map and hillshade PNGs for shading.
//
// Every encoder writes the whole grid the tile carries, border included, row 0 (north) first.
// Quantised formats round to the nearest code and saturate at the ends of their range. The same
// tile always gives the same bytes. Nothing throws: an empty or inconsistent tile, a non-finite
// sample or a bad option comes back as an Error whose pointer names the field ("/width",
// "/elevation/17", "/slope_east", "/address/z", "/gray16/scale", "/georeference/latitude",
// "/hillshade/altitude_deg").
#pragma once

#include <cstdint>
#include <vector>

#include "terrain/math.hpp"
#include "terrain/result.hpp"
#include "terrain/tile.hpp"

namespace terrain {

struct Georeference;  // terrain/scene.hpp

/// Heights the terrain-RGB code space can represent; others saturate to these.
inline constexpr double kTerrainRgbLowest = -10000.0;
inline constexpr double kTerrainRgbHighest = 1667721.5;  // −10000 + (2^24 − 1)·0.1
/// Heights the Terrarium code space can represent; others saturate to these.
inline constexpr double kTerrariumLowest = -32768.0;
inline constexpr double kTerrariumHighest = 32767.0 + 255.0 / 256.0;

/// Mapbox terrain-RGB, an 8-bit RGB PNG: h = −10000 + (R·65536 + G·256 + B)·0.1 metres.
Result<std::vector<std::uint8_t>> encode_terrain_rgb(const HeightTile& tile);

/// Terrarium (Mapzen), an 8-bit RGB PNG: h = R·256 + G + B/256 − 32768 metres.
Result<std::vector<std::uint8_t>> encode_terrarium(const HeightTile& tile);

/// A 16-bit grey code v stands for the height offset + scale·v metres.
struct Gray16Encoding {
  double offset = 0.0;
  double scale = 1.0;
};

/// The encoding for a scene whose heights lie in `elevation_range`: scale is the smallest of
/// 0.001, 0.002, 0.005, 0.01, ... metres whose 65535 steps from offset reach the maximum, and
/// offset the largest multiple of scale at or below the minimum. Round numbers let one encoding
/// serve every tile of a scene, so neighbours decode their shared samples alike. An empty or
/// non-finite range is treated as [0, 0].
Gray16Encoding gray16_encoding_for(Interval elevation_range);

/// 16-bit grey PNG of v = round((h − offset) / scale), clamped to [0, 65535].
Result<std::vector<std::uint8_t>> encode_gray16(const HeightTile& tile,
                                                const Gray16Encoding& encoding);

/// Single-channel float32 GeoTIFF (deflate), heights exact. Georeferenced in EPSG:3857
/// (webmercator), EPSG:4326 (geographic) or, for local tiles, an orthographic projection on
/// WGS 84 centred on the georeference, rotated by its heading. cell_centres tiles are
/// pixel-is-area, cell_corners tiles pixel-is-point. The georeference is used by local tiles only.
Result<std::vector<std::uint8_t>> encode_geotiff(const HeightTile& tile,
                                                 const Georeference& georeference);

/// 8-bit RGB PNG of the unit normal n = normalize(−∂h/∂east, −∂h/∂north, 1) as round((n+1)/2·255):
/// red east, green north, blue up (OpenGL convention), from the slopes the tile carries.
Result<std::vector<std::uint8_t>> encode_normal_map(const HeightTile& tile);

/// Light for a hillshade, as in gdaldem.
struct HillshadeOptions {
  double azimuth_deg = 315.0;  ///< where the light comes from, degrees clockwise from north
  double altitude_deg = 45.0;  ///< light elevation above the horizon, degrees in [0, 90]
  double z_factor = 1.0;       ///< vertical exaggeration applied to the slopes, > 0
};

/// 8-bit grey PNG of round(255·max(0, n·l)), n the unit normal of the slopes times z_factor and l
/// the unit vector towards the light.
Result<std::vector<std::uint8_t>> encode_hillshade(const HeightTile& tile,
                                                   const HillshadeOptions& options = {});

}  // namespace terrain
