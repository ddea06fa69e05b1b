// gzip through zlib's deflate/inflate with a gzip wrapper (windowBits 15 + 16).
#include "terrain/gzip.hpp"

#include <zlib.h>

#include <algorithm>
#include <climits>
#include <string>

namespace terrain {

namespace {

// zlib counts in uInt; feed and drain in pieces no larger than that.
constexpr std::size_t kChunk = std::size_t{1} << 20;

uInt piece(std::size_t remaining) {
  return static_cast<uInt>(std::min(remaining, kChunk));
}

}  // namespace

Result<std::vector<std::uint8_t>> gzip_compress(std::span<const std::uint8_t> data, int level) {
  if (level < 0 || level > 9) {
    return Error{"gzip level must be 0..9, got " + std::to_string(level), "/level"};
  }
  z_stream z{};
  if (deflateInit2(&z, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    return Error{"zlib could not start a gzip stream", ""};
  }
  // An explicit header: without one zlib writes the build platform's OS code.
  gz_header header{};
  header.time = 0;
  header.os = gzip_os_byte;
  if (deflateSetHeader(&z, &header) != Z_OK) {
    deflateEnd(&z);
    return Error{"zlib refused the gzip header", ""};
  }
  std::vector<std::uint8_t> out;
  out.reserve(deflateBound(&z, static_cast<uLong>(std::min<std::size_t>(data.size(), ULONG_MAX))));
  std::size_t consumed = 0;
  int status = Z_OK;
  std::uint8_t buffer[1 << 15];
  while (status != Z_STREAM_END) {
    if (z.avail_in == 0 && consumed < data.size()) {
      z.next_in = const_cast<Bytef*>(data.data() + consumed);  // zlib's API is not const
      z.avail_in = piece(data.size() - consumed);
      consumed += z.avail_in;
    }
    const int flush = consumed == data.size() ? Z_FINISH : Z_NO_FLUSH;
    z.next_out = buffer;
    z.avail_out = sizeof buffer;
    status = deflate(&z, flush);
    if (status != Z_OK && status != Z_STREAM_END && status != Z_BUF_ERROR) {
      deflateEnd(&z);
      return Error{"zlib failed to compress", ""};
    }
    out.insert(out.end(), buffer, buffer + (sizeof buffer - z.avail_out));
  }
  deflateEnd(&z);
  return out;
}

Result<std::vector<std::uint8_t>> gzip_compress(std::string_view text, int level) {
  return gzip_compress(std::span<const std::uint8_t>(
                           reinterpret_cast<const std::uint8_t*>(text.data()), text.size()),
                       level);
}

Result<std::vector<std::uint8_t>> gzip_decompress(std::span<const std::uint8_t> data,
                                                  std::size_t max_output) {
  z_stream z{};
  if (inflateInit2(&z, 15 + 16) != Z_OK) return Error{"zlib could not start inflating", ""};
  std::vector<std::uint8_t> out;
  std::size_t consumed = 0;
  std::uint8_t buffer[1 << 15];
  for (;;) {
    if (z.avail_in == 0 && consumed < data.size()) {
      z.next_in = const_cast<Bytef*>(data.data() + consumed);  // zlib's API is not const
      z.avail_in = piece(data.size() - consumed);
      consumed += z.avail_in;
    }
    z.next_out = buffer;
    z.avail_out = sizeof buffer;
    const int status = inflate(&z, Z_NO_FLUSH);
    const std::size_t produced = sizeof buffer - z.avail_out;
    if (produced > max_output - out.size()) {
      inflateEnd(&z);
      return Error{"gzip content exceeds the limit of " + std::to_string(max_output) + " bytes",
                   ""};
    }
    out.insert(out.end(), buffer, buffer + produced);
    if (status == Z_STREAM_END) break;
    if (status == Z_NEED_DICT || status == Z_DATA_ERROR || status == Z_MEM_ERROR) {
      inflateEnd(&z);
      return Error{std::string("corrupt gzip data") + (z.msg != nullptr ? ": " : "") +
                       (z.msg != nullptr ? z.msg : ""),
                   ""};
    }
    // No progress possible: the input ran out before the member ended.
    if (status == Z_BUF_ERROR || (z.avail_in == 0 && consumed == data.size() && produced == 0)) {
      inflateEnd(&z);
      return Error{"truncated gzip data", ""};
    }
  }
  const bool trailing = z.avail_in != 0 || consumed != data.size();
  inflateEnd(&z);
  if (trailing) return Error{"unexpected bytes after the gzip member", ""};
  return out;
}

}  // namespace terrain
