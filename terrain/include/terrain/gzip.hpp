// gzip (RFC 1952) compression for what the server sends: quantized-mesh tiles and JSON. The
// output is a function of the input bytes and the level only (no timestamp, no file name, fixed
// OS byte), so identical tiles compress to identical bytes and cache and hash well.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "terrain/result.hpp"

namespace terrain {

/// The OS byte every member we write carries (255, "unknown"), whatever the build platform.
inline constexpr std::uint8_t gzip_os_byte = 255;

/// One gzip member holding `data`: mtime 0, no name or comment, OS byte gzip_os_byte.
/// level: 0 (store) .. 9 (best); anything else is refused, as is a zlib failure.
Result<std::vector<std::uint8_t>> gzip_compress(std::span<const std::uint8_t> data, int level = 6);
Result<std::vector<std::uint8_t>> gzip_compress(std::string_view text, int level = 6);

/// The content of one gzip member. Refuses (never throws, never writes past the limit) input
/// that is not gzip, is truncated or corrupt (CRC or length mismatch), has bytes after the
/// member, or would inflate to more than max_output bytes (a guard against zip bombs).
Result<std::vector<std::uint8_t>> gzip_decompress(std::span<const std::uint8_t> data,
                                                  std::size_t max_output);

}  // namespace terrain
