// Height-tile encoders (docs/tile-encodings.md): the PNGs, through image_io (OpenImageIO). The
// GeoTIFF is geotiff.cpp's.
#include "terrain/tile_image.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "terrain/image_io.hpp"
#include "terrain/scene.hpp"
#include "tile_encoding_checks.hpp"

namespace terrain {
namespace {

using namespace tile_encoding;  // NOLINT(google-build-using-namespace): the shared checks

constexpr std::uint32_t kMax24BitCode = (1u << 24) - 1;
constexpr std::uint32_t kMax16BitCode = 65535;

// ---------------------------------------------------------------------------------------------
// Quantised PNGs

// The nearest code, saturated to [0, top]. `value` is finite (the samples were checked).
std::uint32_t quantise(double value, std::uint32_t top) {
  return static_cast<std::uint32_t>(std::clamp(std::round(value), 0.0, static_cast<double>(top)));
}

std::uint8_t to_byte(double value) {
  return static_cast<std::uint8_t>(quantise(value, 255));
}

template <class Code>
Result<Bytes> encode_24bit(const HeightTile& tile, Code code) {
  if (Status ok = check_heights(tile); !ok) return ok.error();
  Bytes rgb(sample_count(tile) * 3);
  for (std::size_t i = 0; i < tile.elevation.size(); ++i) {
    const std::uint32_t v = code(static_cast<double>(tile.elevation[i]));
    rgb[3 * i] = static_cast<std::uint8_t>(v >> 16);
    rgb[3 * i + 1] = static_cast<std::uint8_t>((v >> 8) & 0xFF);
    rgb[3 * i + 2] = static_cast<std::uint8_t>(v & 0xFF);
  }
  return encode_png_rgb8(tile.width, tile.height, rgb.data());
}

// ---------------------------------------------------------------------------------------------
}  // namespace

Result<std::vector<std::uint8_t>> encode_terrain_rgb(const HeightTile& tile) {
  return guarded("cannot encode terrain-RGB", [&] {
    return encode_24bit(
        tile, [](double h) { return quantise((h - kTerrainRgbLowest) * 10.0, kMax24BitCode); });
  });
}

Result<std::vector<std::uint8_t>> encode_terrarium(const HeightTile& tile) {
  return guarded("cannot encode Terrarium", [&] {
    return encode_24bit(
        tile, [](double h) { return quantise((h - kTerrariumLowest) * 256.0, kMax24BitCode); });
  });
}

Gray16Encoding gray16_encoding_for(Interval elevation_range) {
  double lo = elevation_range.lo;
  double hi = elevation_range.hi;
  if (elevation_range.empty() || !std::isfinite(lo) || !std::isfinite(hi)) lo = hi = 0.0;
  // 1, 2, 5 · 10^e from a millimetre up; the widest float range needs e ≈ 34, so this ends.
  for (int exponent = -3; exponent < 300; ++exponent) {
    for (const double mantissa : {1.0, 2.0, 5.0}) {
      // k·mantissa / 10^−e is the double nearest the decimal k·scale (0.001, 0.002, -12.32, ...),
      // where k·scale with scale already rounded would drift off it.
      const auto multiple = [&](double steps) {
        return exponent < 0 ? steps * mantissa / std::pow(10.0, -exponent)
                            : steps * mantissa * std::pow(10.0, exponent);
      };
      const double scale = multiple(1.0);
      // lo / scale is rounded, so its floor may be one step off either way.
      double k = std::floor(lo / scale);
      if (multiple(k + 1.0) <= lo) {
        k += 1.0;
      } else if (multiple(k) > lo) {
        k -= 1.0;
      }
      const double offset = multiple(k);
      if (offset + static_cast<double>(kMax16BitCode) * scale >= hi) return {offset, scale};
    }
  }
  return {lo, 1.0};  // unreachable for float ranges
}

Result<std::vector<std::uint8_t>> encode_gray16(const HeightTile& tile,
                                                const Gray16Encoding& encoding) {
  return guarded("cannot encode 16-bit grey", [&]() -> Result<Bytes> {
    if (!std::isfinite(encoding.offset)) {
      return Error{"the gray16 offset must be finite", "/gray16/offset"};
    }
    if (!std::isfinite(encoding.scale) || !(encoding.scale > 0.0)) {
      return Error{"the gray16 scale must be finite and positive, not " + text(encoding.scale),
                   "/gray16/scale"};
    }
    if (Status ok = check_heights(tile); !ok) return ok.error();
    std::vector<std::uint16_t> codes(sample_count(tile));
    for (std::size_t i = 0; i < codes.size(); ++i) {
      const double h = tile.elevation[i];
      codes[i] = static_cast<std::uint16_t>(
          quantise((h - encoding.offset) / encoding.scale, kMax16BitCode));
    }
    return encode_png16(tile.width, tile.height, codes.data());
  });
}

Result<std::vector<std::uint8_t>> encode_normal_map(const HeightTile& tile) {
  return guarded("cannot encode normal map", [&]() -> Result<Bytes> {
    if (Status ok = check_slopes(tile); !ok) return ok.error();
    Bytes rgb(sample_count(tile) * 3);
    for (std::size_t i = 0; i < sample_count(tile); ++i) {
      const double nx = -static_cast<double>(tile.slope_east[i]);
      const double ny = -static_cast<double>(tile.slope_north[i]);
      const double length = std::sqrt(nx * nx + ny * ny + 1.0);
      rgb[3 * i] = to_byte((nx / length + 1.0) * 0.5 * 255.0);
      rgb[3 * i + 1] = to_byte((ny / length + 1.0) * 0.5 * 255.0);
      rgb[3 * i + 2] = to_byte((1.0 / length + 1.0) * 0.5 * 255.0);
    }
    return encode_png_rgb8(tile.width, tile.height, rgb.data());
  });
}

Result<std::vector<std::uint8_t>> encode_hillshade(const HeightTile& tile,
                                                   const HillshadeOptions& options) {
  return guarded("cannot encode hillshade", [&]() -> Result<Bytes> {
    if (Status ok = check_light(options); !ok) return ok.error();
    if (Status ok = check_slopes(tile); !ok) return ok.error();
    const auto [lx, ly, lz] = towards_light(options);
    Bytes shade(sample_count(tile));
    for (std::size_t i = 0; i < shade.size(); ++i) {
      const double nx = -options.z_factor * static_cast<double>(tile.slope_east[i]);
      const double ny = -options.z_factor * static_cast<double>(tile.slope_north[i]);
      const double length = std::sqrt(nx * nx + ny * ny + 1.0);
      const double lit = (nx * lx + ny * ly + lz) / length;
      shade[i] = to_byte(255.0 * std::max(0.0, lit));
    }
    return encode_png_gray8(tile.width, tile.height, shade.data());
  });
}

}  // namespace terrain
