// A continent bitmap (Derzapf et al. 2011, Table 2's "Bitmap: alternatively, to define the
// continents"): an equirectangular greyscale image whose bright pixels are land. The planet
// library never reads files or fetches anything for it; the caller hands over the image's bytes
// (the server from its image store, the CLI from a local file) and decode_continent_map checks
// and decodes them through terrain's OpenImageIO reader.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "terrain/result.hpp"

namespace planet {

using terrain::Error;
using terrain::Result;

/// The decoded map. Equirectangular and pixel-is-area: pixel (x, y) covers longitudes
/// −180 + 360·[x, x + 1)/width and latitudes 90 − 180·[y, y + 1)/height (row 0 north), and its
/// value is taken at the pixel's centre.
struct ContinentMap {
  int width = 0;
  int height = 0;
  std::vector<float> values;  ///< width·height grey values in [0, 1], index y·width + x
  /// "sha256:<hex>" of the image bytes the map was decoded from (what a definition's
  /// continent_map names); empty for a map made from pixels in memory.
  std::string hash;

  /// A point is land where the map's value is at least this: the middle of the grey range, so
  /// black/white masks, anti-aliased edges and 16-bit masks all mean what they look like.
  static constexpr double kLandThreshold = 0.5;

  // Dimensions accepted by decode_continent_map and Planet::build: large enough for a useful
  // mask, at most 8192 × 4096 (32 Mi samples, 128 MiB as floats while the base mesh is built),
  // and 2:1 within 1 % (equirectangular; grid-registered 2n+1 × n+1 images pass).
  static constexpr int kMinWidth = 16;
  static constexpr int kMinHeight = 8;
  static constexpr int kMaxWidth = 8192;
  static constexpr int kMaxHeight = 4096;
  static constexpr double kAspectTolerance = 0.01;

  /// Bilinear value at a geographic position in degrees: wraps across the antimeridian and is
  /// clamped to the first and last rows' centres towards the poles.
  double sample(double latitude, double longitude) const;
  bool land(double latitude, double longitude) const {
    return sample(latitude, longitude) >= kLandThreshold;
  }
  /// The land share of the map's area (rows weighted by the area of their latitude band).
  double land_fraction() const;

  /// Dimensions within the limits above and values.size() == width·height, every value finite
  /// and in [0, 1]; the error's pointer is "/continent_map".
  terrain::Status validate() const;
};

/// "sha256:<hex>" of the bytes: the value of continent_map that names this image (the hash the
/// server's image store keeps it under).
std::string continent_map_reference(std::span<const std::uint8_t> bytes);

/// Checks and decodes a continent map: a PNG, greyscale (with or without alpha, which is
/// ignored), 8 or 16 bits per sample, dimensions as ContinentMap's limits say. Signature,
/// dimensions, bit depth and colour type are read from the PNG header and checked before any
/// pixel is decoded; the pixels are then decoded by terrain's OpenImageIO reader (values v/255 or
/// v/65535). Sets `hash`. Errors name "/continent_map".
Result<ContinentMap> decode_continent_map(std::span<const std::uint8_t> bytes);

}  // namespace planet
