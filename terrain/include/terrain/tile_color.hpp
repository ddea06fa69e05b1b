// Colour imagery tiles (docs/tile-encodings.md): the material model's colour of every sample
// (terrain/material.hpp, the same as render.png's and the viewer's) lit by a map sun from the
// north-west, as an 8-bit RGB PNG or JPEG. Pixels depend on their own sample alone (its height,
// its exact slopes, its water), so neighbouring tiles continue each other without seams, and the
// same tile always gives the same bytes.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "terrain/material.hpp"
#include "terrain/math.hpp"
#include "terrain/result.hpp"
#include "terrain/tile.hpp"
#include "terrain/tile_image.hpp"

namespace terrain {

/// What a colour tile needs besides the heights and slopes of its samples.
struct ColorTileInputs {
  /// The heights the material maps to its 0..1 relief (scenes: their elevation range; planets:
  /// sea level to their highest peak), so that a scene's snow line is the same on every tile.
  Interval relief;
  /// One value per sample in the tile's layout: the surface of the water that covers the sample
  /// (under water where it lies above the ground) or whose shore it may be on; NaN where no
  /// water is near. Empty: no water anywhere. Water is drawn flat, lit as a level surface.
  std::span<const float> water_surface;
  /// Shores: sand from the water's edge up to this many metres above its surface (0: none).
  float shore_band = 0.0f;
  /// The colours and where each cover takes over (a scene's or planet's "material").
  Material material;
  /// One value per row of samples: |sine of its latitude|, which lowers the snow line towards
  /// the poles, and whose sign says which way is poleward (negative: south). Empty: 0 (scenes).
  std::span<const float> polar;
  /// The sun: from the north-west, 45° high, as in cartographic hillshades.
  HillshadeOptions light;
};

enum class ColorCodec { png, jpeg };

/// JPEG quality of colour tiles: about 20 kB for a 256² tile of mountains, with no visible blocks.
inline constexpr int kColorJpegQuality = 90;

/// The tile's colours, encoded. Errors name the field ("/elevation/17", "/water_surface",
/// "/shore_band", "/relief",
/// "/hillshade/altitude_deg").
Result<std::vector<std::uint8_t>> encode_color(const HeightTile& tile,
                                               const ColorTileInputs& inputs, ColorCodec codec);

/// The unencoded colours behind encode_color: width·height·3 bytes, row 0 (north) first.
Result<std::vector<std::uint8_t>> color_pixels(const HeightTile& tile,
                                               const ColorTileInputs& inputs);

}  // namespace terrain
