// Heightfield image input and deterministic image output through OpenImageIO. Reading accepts
// whatever OIIO can open (8/16-bit PNG, float TIFF and OpenEXR are the tested formats), from a
// file or from bytes in memory, and never throws: every failure comes back as an Error carrying
// OIIO's own message. Writers produce the same bytes for the same pixels (no time stamps).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "terrain/result.hpp"

namespace terrain {

/// A single-channel raster of heights, row-major with row 0 at the top (north), plus an optional
/// weight channel taken from the image's alpha. Integer samples are normalised to [0, 1] the way
/// OIIO converts them (v / 255, v / 65535); float samples are kept as stored.
struct Raster {
  int width = 0;
  int height = 0;
  std::vector<float> samples;  ///< width * height heights, index y * width + x
  std::vector<float> weights;  ///< empty, or width * height alpha values (not premultiplied)

  bool has_weight() const { return !weights.empty(); }
  float at(int x, int y) const {
    return samples[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                   static_cast<std::size_t>(x)];
  }
};

/// Refuse images larger than this before any pixel is decoded.
struct ReadLimits {
  int max_width = 8192;
  int max_height = 8192;
  std::int64_t max_pixels = std::int64_t{1} << 24;  ///< 16 Mi pixels
};

/// Reads the first channel of the first subimage as heights and, when the image declares an alpha
/// channel (OIIO's alpha_channel, e.g. the second channel of a grey+alpha PNG), that channel as
/// weights, unassociated. Non-finite samples are refused, naming the first bad pixel.
Result<Raster> read_heightfield(const std::string& path, const ReadLimits& limits = {});

/// Same as read_heightfield, from an image held in memory. The format is recognised from the
/// leading bytes (PNG, TIFF, OpenEXR); `format_hint` ("png", ".tif", "image/x-exr", ...) is used
/// only when the bytes are not one of those, and must name a reader that can read from memory.
Result<Raster> decode_heightfield(std::span<const std::uint8_t> bytes, std::string_view format_hint,
                                  const ReadLimits& limits = {});

/// Single-channel 32-bit float TIFF (deflate at level 1, the fastest), row 0 first.
Result<std::vector<std::uint8_t>> encode_float_tiff(int width, int height, const float* samples);
/// What a PNG holds, which decides how it is written (docs/performance.md). libpng's default tries
/// all five row filters on every row and keeps the smallest guess, which costs about a millisecond
/// per 256² tile; one fixed filter per kind of image gives the same size within a few percent.
enum class PngKind {
  /// Heights and other numeric images: Paeth on every row (what the trial picked on nearly every
  /// row anyway), deflated at level 1.
  numeric,
  /// Shaded pictures and colour tiles: Up on every row (rows resemble the row above), and Huffman
  /// coding alone, since string matching hardly shortens their residuals: about 4 % more bytes
  /// than level 1 in half the time.
  shaded,
};

/// Single-channel 16-bit greyscale PNG.
Result<std::vector<std::uint8_t>> encode_png16(int width, int height, const std::uint16_t* samples);
/// Single-channel 8-bit greyscale PNG (numeric: hillshades, masks, continent maps).
Result<std::vector<std::uint8_t>> encode_png_gray8(int width, int height,
                                                   const std::uint8_t* samples);
/// 8-bit RGB PNG; `rgb` holds width * height * 3 bytes, pixel-interleaved.
Result<std::vector<std::uint8_t>> encode_png_rgb8(int width, int height, const std::uint8_t* rgb,
                                                  PngKind kind = PngKind::numeric);

/// 8-bit RGB baseline JPEG at `quality` (1..100), 4:2:0 chroma, no metadata.
Result<std::vector<std::uint8_t>> encode_jpeg_rgb8(int width, int height, const std::uint8_t* rgb,
                                                   int quality);

/// The encoders above, written to `path` (the format is fixed by the function, not by the file
/// extension). The file holds exactly the bytes the matching encoder returns.
Status write_float_tiff(const std::string& path, int width, int height, const float* samples);
Status write_png16(const std::string& path, int width, int height, const std::uint16_t* samples);
Status write_png_rgb8(const std::string& path, int width, int height, const std::uint8_t* rgb,
                      PngKind kind = PngKind::numeric);

}  // namespace terrain
