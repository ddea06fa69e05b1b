// A picture of the whole planet for people to look at: equirectangular (longitude → x, latitude
// → y), coloured by surface type and altitude and shaded by a hillshade of the ground.
#pragma once

#include <cstdint>
#include <vector>

#include "planet/planet.hpp"

namespace planet {

struct PictureOptions {
  int width = 2048;            ///< pixels; the height is width / 2
  int threads = 1;             ///< rows are shared out; the picture does not depend on it
  double z_factor = 8.0;       ///< vertical exaggeration of the shading
  double azimuth_deg = 315.0;  ///< light from the north-west
  double altitude_deg = 35.0;
};

/// RGB bytes, width × width/2 × 3, row 0 north; pixel centres sampled at the LoD of their size.
std::vector<std::uint8_t> planet_picture_rgb(const std::shared_ptr<const Planet>& planet,
                                             const PictureOptions& options);
/// The same as a PNG.
Result<std::vector<std::uint8_t>> planet_picture_png(const std::shared_ptr<const Planet>& planet,
                                                     const PictureOptions& options);

}  // namespace planet
