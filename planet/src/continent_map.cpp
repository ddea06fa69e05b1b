#include "planet/continent_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string_view>

#include "terrain/image_io.hpp"
#include "terrain/scene.hpp"

namespace planet {
namespace {

constexpr const char* kPointer = "/continent_map";

Error map_error(const std::string& message) {
  return Error{"continent map: " + message, kPointer};
}

std::string dimensions(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

terrain::Status check_dimensions(std::int64_t width, std::int64_t height) {
  if (width < ContinentMap::kMinWidth || height < ContinentMap::kMinHeight) {
    return map_error("image is " + std::to_string(width) + "x" + std::to_string(height) +
                     " pixels; at least " +
                     dimensions(ContinentMap::kMinWidth, ContinentMap::kMinHeight) + " needed");
  }
  if (width > ContinentMap::kMaxWidth || height > ContinentMap::kMaxHeight) {
    return map_error("image is " + std::to_string(width) + "x" + std::to_string(height) +
                     " pixels; the limit is " +
                     dimensions(ContinentMap::kMaxWidth, ContinentMap::kMaxHeight));
  }
  const double aspect = static_cast<double>(width) / static_cast<double>(height);
  if (std::abs(aspect - 2.0) > 2.0 * ContinentMap::kAspectTolerance) {
    return map_error("image is " + std::to_string(width) + "x" + std::to_string(height) +
                     " pixels; an equirectangular map is twice as wide as high (within 1 %)");
  }
  return terrain::Ok{};
}

std::uint32_t big_endian32(std::span<const std::uint8_t> bytes, std::size_t at) {
  return (static_cast<std::uint32_t>(bytes[at]) << 24) |
         (static_cast<std::uint32_t>(bytes[at + 1]) << 16) |
         (static_cast<std::uint32_t>(bytes[at + 2]) << 8) |
         static_cast<std::uint32_t>(bytes[at + 3]);
}

// The PNG header (signature, then IHDR, which the format requires to be the first chunk): what
// is refused here costs no decoding at all, whatever the pixels would have cost.
terrain::Status check_png_header(std::span<const std::uint8_t> bytes) {
  static constexpr std::array<std::uint8_t, 8> signature = {0x89, 0x50, 0x4E, 0x47,
                                                            0x0D, 0x0A, 0x1A, 0x0A};  // \x89PNG…
  static constexpr std::array<std::uint8_t, 8> ihdr = {0, 0, 0, 13, 'I', 'H', 'D', 'R'};
  if (bytes.size() < 33 || !std::equal(signature.begin(), signature.end(), bytes.begin())) {
    return map_error("not a PNG image (a continent map is a greyscale PNG)");
  }
  if (!std::equal(ihdr.begin(), ihdr.end(), bytes.begin() + 8)) {
    return map_error("malformed PNG: the first chunk is not IHDR");
  }
  const std::uint32_t width = big_endian32(bytes, 16);
  const std::uint32_t height = big_endian32(bytes, 20);
  if (terrain::Status ok = check_dimensions(width, height); !ok) return ok;
  const int depth = bytes[24];
  const int colour = bytes[25];
  // Greyscale (0) or greyscale with alpha (4): the value is the grey sample. Colour images are
  // refused rather than guessed at (which channel, or which colour, would be land?).
  if (colour != 0 && colour != 4) {
    return map_error("image is a colour PNG (colour type " + std::to_string(colour) +
                     "); a continent map is greyscale");
  }
  if (depth != 8 && depth != 16) {
    return map_error("image has " + std::to_string(depth) +
                     " bits per sample; a continent map has 8 or 16");
  }
  return terrain::Ok{};
}

}  // namespace

double ContinentMap::sample(double latitude, double longitude) const {
  // Continuous pixel coordinates of the point, pixel centres at integers.
  const double u = (longitude + 180.0) / 360.0 * width - 0.5;
  const double v =
      std::clamp((90.0 - latitude) / 180.0 * height - 0.5, 0.0, static_cast<double>(height - 1));
  const double fu = std::floor(u);
  const double fv = std::floor(v);
  const double tu = u - fu, tv = v - fv;
  // Longitude wraps: the columns left of the first and right of the last are each other.
  const auto columns = static_cast<std::int64_t>(width);
  const auto column = [&](double c) {
    return static_cast<std::size_t>(((static_cast<std::int64_t>(c) % columns) + columns) % columns);
  };
  const std::size_t x0 = column(fu), x1 = column(fu + 1.0);
  const auto y0 = static_cast<std::size_t>(fv);
  const std::size_t y1 = std::min(y0 + 1, static_cast<std::size_t>(height - 1));
  const auto w = static_cast<std::size_t>(width);
  const auto at = [&](std::size_t x, std::size_t y) {
    return static_cast<double>(values[y * w + x]);
  };
  const double top = at(x0, y0) + (at(x1, y0) - at(x0, y0)) * tu;
  const double bottom = at(x0, y1) + (at(x1, y1) - at(x0, y1)) * tu;
  return top + (bottom - top) * tv;
}

double ContinentMap::land_fraction() const {
  constexpr double degree = std::numbers::pi / 180.0;
  double land = 0.0;
  for (int y = 0; y < height; ++y) {
    // A latitude band's share of the sphere: (sin φ_top − sin φ_bottom) / 2.
    const double top = 90.0 - 180.0 * y / height;
    const double bottom = 90.0 - 180.0 * (y + 1) / height;
    const double band = (std::sin(top * degree) - std::sin(bottom * degree)) / 2.0;
    int count = 0;
    for (int x = 0; x < width; ++x) {
      count += values[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                      static_cast<std::size_t>(x)] >= kLandThreshold
                   ? 1
                   : 0;
    }
    land += band * count / width;
  }
  return land;
}

terrain::Status ContinentMap::validate() const {
  if (terrain::Status ok = check_dimensions(width, height); !ok) return ok;
  if (values.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    return map_error("holds " + std::to_string(values.size()) + " values for " +
                     dimensions(width, height) + " pixels");
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!(values[i] >= 0.0f && values[i] <= 1.0f)) {
      return map_error("value at pixel (x=" + std::to_string(i % static_cast<std::size_t>(width)) +
                       ", y=" + std::to_string(i / static_cast<std::size_t>(width)) +
                       ") is not in [0, 1]");
    }
  }
  return terrain::Ok{};
}

std::string continent_map_reference(std::span<const std::uint8_t> bytes) {
  return "sha256:" + terrain::sha256_hex(std::string_view(
                         reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

Result<ContinentMap> decode_continent_map(std::span<const std::uint8_t> bytes) {
  if (terrain::Status ok = check_png_header(bytes); !ok) return ok.error();
  // The reader's own limits as a second line, should the header above be misread.
  terrain::ReadLimits limits;
  limits.max_width = ContinentMap::kMaxWidth;
  limits.max_height = ContinentMap::kMaxHeight;
  limits.max_pixels = std::int64_t{ContinentMap::kMaxWidth} * ContinentMap::kMaxHeight;
  Result<terrain::Raster> raster = terrain::decode_heightfield(bytes, "png", limits);
  if (!raster) return map_error(raster.error().message);
  ContinentMap map;
  map.width = raster->width;
  map.height = raster->height;
  map.values = std::move(raster->samples);
  map.hash = continent_map_reference(bytes);
  if (terrain::Status ok = map.validate(); !ok) return ok.error();
  return map;
}

}  // namespace planet
