#include "png_huffman.hpp"

#include <png.h>
#include <zlib.h>

#include <new>

namespace terrain {
namespace {

struct Sink {
  std::vector<std::uint8_t>* bytes;
};

void append(png_structp png, png_bytep data, png_size_t size) {
  auto* sink = static_cast<Sink*>(png_get_io_ptr(png));
  bool stored = true;
  try {
    sink->bytes->insert(sink->bytes->end(), data, data + size);
  } catch (const std::bad_alloc&) {
    stored = false;
  }
  // No exception may cross libpng's C frames, and png_error longjmps: outside the handler.
  if (!stored) png_error(png, "out of memory");
}

void flush(png_structp) {}

}  // namespace

Result<std::vector<std::uint8_t>> encode_png_up_huffman(int width, int height,
                                                        const std::uint8_t* rgb) {
  constexpr std::size_t kChannels = 3;
  // Everything with a destructor lives outside the setjmp region, which a longjmp leaves.
  std::vector<std::uint8_t> bytes;
  bytes.reserve(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * kChannels +
                1024);
  Sink sink{&bytes};
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (png == nullptr) return Error{"cannot encode PNG: libpng could not start", ""};
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return Error{"cannot encode PNG: libpng failed (out of memory?)", ""};
  }
  png_set_write_fn(png, &sink, append, flush);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  // Up leaves small residuals in a shaded image (rows resemble the row above), which deflate's
  // string matching hardly shortens: Huffman coding alone writes about 4 % more bytes than
  // level 1 in about half the time (docs/performance.md).
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
  png_set_compression_strategy(png, Z_HUFFMAN_ONLY);
  png_set_compression_level(png, 1);
  png_write_info(png, info);
  const std::size_t stride = static_cast<std::size_t>(width) * kChannels;
  for (int row = 0; row < height; ++row) {
    png_write_row(png, rgb + static_cast<std::size_t>(row) * stride);
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return bytes;
}

}  // namespace terrain
