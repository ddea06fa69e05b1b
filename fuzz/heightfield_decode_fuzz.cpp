// libFuzzer target: decoding an uploaded heightfield (PNG, TIFF, OpenEXR through OpenImageIO)
// must refuse any bytes with an Error (never crash, never throw), and a raster it accepts must
// be whole: width × height finite samples, and as many weights or none.
//
// Input: one byte choosing the media type the blob is stored with (used only when the bytes are
// not recognised), then the image bytes.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string_view>

#include "terrain/image_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static constexpr std::string_view kMediaTypes[] = {"image/png", "image/tiff", "png", "tif"};
  const std::string_view media_type = kMediaTypes[data[0] % std::size(kMediaTypes)];
  // Smaller than the server's limits, so a header announcing a large image is refused quickly.
  terrain::ReadLimits limits;
  limits.max_width = 1024;
  limits.max_height = 1024;
  limits.max_pixels = 1 << 18;
  const terrain::Result<terrain::Raster> raster = terrain::decode_heightfield(
      std::span<const std::uint8_t>(data + 1, size - 1), media_type, limits);
  if (!raster) return 0;
  const std::size_t pixels =
      static_cast<std::size_t>(raster->width) * static_cast<std::size_t>(raster->height);
  if (raster->width <= 0 || raster->height <= 0 || raster->width > limits.max_width ||
      raster->height > limits.max_height || raster->samples.size() != pixels ||
      (raster->has_weight() && raster->weights.size() != pixels)) {
    std::abort();
  }
  for (const float sample : raster->samples) {
    if (!std::isfinite(sample)) std::abort();
  }
  return 0;
}
