// PNG encoding for shaded images (colour tiles, pictures) straight through libpng: every row
// filtered Up and the filtered rows deflated by Huffman coding alone (zlib's Z_HUFFMAN_ONLY).
// OpenImageIO, which writes every other PNG here, does not expose zlib's strategy.
#pragma once

#include <cstdint>
#include <vector>

#include "terrain/result.hpp"

namespace terrain {

/// 8-bit RGB PNG of interleaved samples, row 0 first. The caller has checked the dimensions and
/// the pointer.
Result<std::vector<std::uint8_t>> encode_png_up_huffman(int width, int height,
                                                        const std::uint8_t* rgb);

}  // namespace terrain
