// Image input/output through OpenImageIO (shaded PNGs through libpng: png_huffman.hpp). Everything
// OIIO reports (return codes, pending error text, exceptions) is turned into an Error here so that
// callers see one uniform failure path.
#include "terrain/image_io.hpp"

#include "png_huffman.hpp"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <initializer_list>
#include <memory>
#include <string>
#include <utility>

namespace terrain {
namespace {

// OIIO keeps a per-thread error string for failures that happen before an ImageInput exists. If
// nobody fetches it, it grows and leaks into the next unrelated message, so every public entry
// point drains it on the way out.
struct DrainGlobalOiioError {
  DrainGlobalOiioError() = default;
  DrainGlobalOiioError(const DrainGlobalOiioError&) = delete;
  DrainGlobalOiioError& operator=(const DrainGlobalOiioError&) = delete;
  ~DrainGlobalOiioError() {
    try {
      (void)OIIO::geterror();
    } catch (...) {  // NOLINT(bugprone-empty-catch): nothing useful to do in a destructor
    }
  }
};

// OIIO messages are multi-line and end with a newline; fold them into one line.
std::string tidy(std::string text) {
  std::string out;
  out.reserve(text.size());
  bool pending_break = false;
  for (const char ch : text) {
    if (ch == '\n' || ch == '\r') {
      pending_break = !out.empty();
      continue;
    }
    if (pending_break) {
      out += "; ";
      pending_break = false;
    }
    out += ch;
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == '\t')) out.pop_back();
  return out.empty() ? std::string("OpenImageIO gave no further detail") : out;
}

// The reader's own message when there is one, else the per-thread global one.
std::string input_message(OIIO::ImageInput* in) {
  std::string text = in != nullptr ? in->geterror() : std::string();
  std::string global = OIIO::geterror();
  if (text.empty()) text = std::move(global);
  return tidy(std::move(text));
}

std::string output_message(OIIO::ImageOutput* out) {
  std::string text = out != nullptr ? out->geterror() : std::string();
  std::string global = OIIO::geterror();
  if (text.empty()) text = std::move(global);
  return tidy(std::move(text));
}

Error fail(std::string message) {
  return Error{std::move(message), ""};
}

// Config hints for every reader: keep alpha as stored. Weights are an independent channel, so
// OIIO's default premultiplication of colour by alpha would corrupt the heights.
OIIO::ImageSpec reader_config() {
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  return config;
}

const char* non_finite_name(float x) {
  return std::isnan(x) ? "NaN" : "infinite";
}

// Decodes the pixels of an opened reader (subimage 0, MIP level 0) into a Raster. Reads in bands
// of rows so that memory stays near the size of the result even for RGBA images.
Result<Raster> read_pixels(OIIO::ImageInput& in, const std::string& what,
                           const ReadLimits& limits) {
  const OIIO::ImageSpec spec = in.spec();
  if (spec.deep) return fail(what + ": deep images are not supported");
  if (spec.depth > 1) return fail(what + ": volume images are not supported");
  if (spec.nchannels < 1) return fail(what + ": image has no channels");
  if (spec.width <= 0 || spec.height <= 0) return fail(what + ": image has no pixels");
  if (spec.width > limits.max_width || spec.height > limits.max_height) {
    return fail(what + ": image is " + std::to_string(spec.width) + "x" +
                std::to_string(spec.height) + " pixels; the limit is " +
                std::to_string(limits.max_width) + "x" + std::to_string(limits.max_height));
  }
  const std::int64_t pixels = std::int64_t{spec.width} * std::int64_t{spec.height};
  if (pixels > limits.max_pixels) {
    return fail(what + ": image has " + std::to_string(pixels) + " pixels; the limit is " +
                std::to_string(limits.max_pixels));
  }

  const int alpha = spec.alpha_channel;
  const bool has_weight = alpha > 0 && alpha < spec.nchannels;
  // Channel ranges must start at 0: some readers (PNG) refuse a range like [1, 2).
  const int channels = has_weight ? alpha + 1 : 1;
  const auto width = static_cast<std::size_t>(spec.width);
  const auto height = static_cast<std::size_t>(spec.height);

  Raster raster;
  raster.width = spec.width;
  raster.height = spec.height;
  raster.samples.resize(width * height);
  if (has_weight) raster.weights.resize(width * height);

  const bool tiled = spec.tile_width > 0 && spec.tile_height > 0;
  // About 4 Mi floats per band; tiled reads need whole tile rows except at the bottom edge.
  const std::size_t per_row = width * static_cast<std::size_t>(channels);
  int band = static_cast<int>(std::clamp<std::size_t>((std::size_t{1} << 22) / per_row, 1, height));
  if (tiled) band = std::max(1, band / spec.tile_height) * spec.tile_height;
  std::vector<float> buffer(per_row * static_cast<std::size_t>(std::min(band, spec.height)));

  for (int y0 = 0; y0 < spec.height; y0 += band) {
    const int y1 = std::min(spec.height, y0 + band);
    // read_scanlines on a tiled file crashes OIIO 2.4 (division by zero), hence two paths.
    const bool ok =
        tiled ? in.read_tiles(0, 0, spec.x, spec.x + spec.width, spec.y + y0, spec.y + y1, spec.z,
                              spec.z + 1, 0, channels, OIIO::TypeDesc::FLOAT, buffer.data())
              : in.read_scanlines(0, 0, spec.y + y0, spec.y + y1, spec.z, 0, channels,
                                  OIIO::TypeDesc::FLOAT, buffer.data());
    // Some readers (TIFF) report a short strip as an error message but still return true.
    if (!ok || in.has_error()) {
      return fail(what + ": cannot decode pixels: " + input_message(&in));
    }
    for (int y = y0; y < y1; ++y) {
      for (int x = 0; x < spec.width; ++x) {
        const std::size_t src = static_cast<std::size_t>(y - y0) * per_row +
                                static_cast<std::size_t>(x) * static_cast<std::size_t>(channels);
        const std::size_t dst = static_cast<std::size_t>(y) * width + static_cast<std::size_t>(x);
        const float h = buffer[src];
        if (!std::isfinite(h)) {
          return fail(what + ": height sample at pixel (x=" + std::to_string(x) +
                      ", y=" + std::to_string(y) + ") is " + non_finite_name(h));
        }
        raster.samples[dst] = h;
        if (has_weight) {
          const float w = buffer[src + static_cast<std::size_t>(alpha)];
          if (!std::isfinite(w)) {
            return fail(what + ": weight (alpha) sample at pixel (x=" + std::to_string(x) +
                        ", y=" + std::to_string(y) + ") is " + non_finite_name(w));
          }
          raster.weights[dst] = w;
        }
      }
    }
  }
  return raster;
}

// Recognises the three tested formats from their signatures, so that a wrong or missing hint
// does not matter for them. Returns an OIIO format name, or "" when unknown.
std::string sniff_format(std::span<const std::uint8_t> bytes) {
  auto starts_with = [&](std::initializer_list<std::uint8_t> magic) {
    return bytes.size() >= magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin());
  };
  if (starts_with({0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A})) return "png";
  // Classic TIFF (42) and BigTIFF (43), either byte order.
  if (starts_with({'I', 'I', 42, 0}) || starts_with({'M', 'M', 0, 42}) ||
      starts_with({'I', 'I', 43, 0}) || starts_with({'M', 'M', 0, 43})) {
    return "tiff";
  }
  if (starts_with({0x76, 0x2F, 0x31, 0x01})) return "openexr";
  return "";
}

// "PNG", ".png", "image/png", "image/x-exr" -> "png", "png", "png", "exr".
std::string normalise_hint(std::string_view hint) {
  std::string text(hint);
  std::transform(text.begin(), text.end(), text.begin(), [](char ch) {
    return (ch >= 'A' && ch <= 'Z') ? static_cast<char>(ch - 'A' + 'a') : ch;
  });
  if (const auto slash = text.rfind('/'); slash != std::string::npos) text.erase(0, slash + 1);
  if (text.rfind("x-", 0) == 0) text.erase(0, 2);
  if (const auto dot = text.rfind('.'); dot != std::string::npos) text.erase(0, dot + 1);
  return text;
}

// Refuses PNG bytes whose chunks do not run whole from the signature to IEND, before OIIO reads
// them: OIIO 2.4's PNG reader leaks its error message (PNGInput::PngReadCallback builds a
// std::string that libpng's longjmp then skips) each time libpng reads past the end of the data,
// so a cut-short upload must not get that far.
Status check_png_chunks(std::span<const std::uint8_t> bytes, const std::string& what) {
  static constexpr std::uint8_t kSignature[] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (bytes.size() < std::size(kSignature) ||
      !std::equal(std::begin(kSignature), std::end(kSignature), bytes.begin())) {
    return fail(what + ": not a PNG (no PNG signature)");
  }
  std::size_t at = std::size(kSignature);
  while (true) {
    // Each chunk: a 4-byte length, a 4-byte type, the data, a 4-byte CRC.
    if (bytes.size() - at < 12) {
      return fail(what + ": the PNG is cut short at byte " + std::to_string(at) +
                  " (no IEND chunk)");
    }
    const std::uint32_t length = std::uint32_t{bytes[at]} << 24 |
                                 std::uint32_t{bytes[at + 1]} << 16 |
                                 std::uint32_t{bytes[at + 2]} << 8 | std::uint32_t{bytes[at + 3]};
    const std::string type(reinterpret_cast<const char*>(bytes.data() + at + 4), 4);
    const bool named = std::all_of(type.begin(), type.end(), [](char c) {
      return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
    });
    if (bytes.size() - at - 12 < length) {
      return fail(what + ": the PNG is cut short: its " + (named ? type + " chunk" : "chunk") +
                  " at byte " + std::to_string(at) + " runs past the end of the data");
    }
    if (type == "IEND") return Ok{};
    at += 12 + std::size_t{length};
  }
}

Result<Raster> decode_impl(std::span<const std::uint8_t> bytes, std::string_view format_hint,
                           const ReadLimits& limits) {
  const std::string what = "image data";
  if (bytes.empty()) return fail(what + ": no bytes");
  std::string format = sniff_format(bytes);
  if (format.empty()) format = normalise_hint(format_hint);
  if (format.empty()) {
    return fail(what + ": not recognised as PNG, TIFF or OpenEXR, and no format hint given");
  }
  if (format == "png") {
    if (Status whole = check_png_chunks(bytes, what); !whole) return whole.error();
  }
  // create() with a bare format name or extension makes a reader without opening anything.
  auto in = OIIO::ImageInput::create(format);
  if (!in) {
    return fail(what + ": unsupported image format '" + std::string(format_hint) +
                "': " + input_message(nullptr));
  }
  if (!in->supports("ioproxy")) {
    return fail(what + ": the " + std::string(in->format_name()) +
                " reader cannot read from memory");
  }
  OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
  if (!in->set_ioproxy(&proxy)) {
    return fail(what + ": cannot attach memory reader: " + input_message(in.get()));
  }
  OIIO::ImageSpec spec;
  if (!in->open("memory." + format, spec, reader_config())) {
    return fail(what + " (" + std::string(in->format_name()) + "): " + input_message(in.get()));
  }
  Result<Raster> raster = read_pixels(*in, what, limits);
  in->close();
  return raster;
}

Result<Raster> read_impl(const std::string& path, const ReadLimits& limits) {
  const std::string what = "image '" + path + "'";
  const OIIO::ImageSpec config = reader_config();
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) return fail("cannot read " + what + ": " + input_message(nullptr));
  Result<Raster> raster = read_pixels(*in, what, limits);
  in->close();
  return raster;
}

Status check_dimensions(int width, int height, const void* data) {
  if (width <= 0 || height <= 0) {
    return fail("cannot encode an image of " + std::to_string(width) + "x" +
                std::to_string(height) + " pixels");
  }
  if (data == nullptr) return fail("cannot encode an image without pixels (null pointer)");
  return Ok{};
}

// Encodes one image with the named OIIO writer into memory. Only the pixel-describing fields are
// set; DateTime is pinned empty because the TIFF and OpenEXR writers otherwise stamp the current
// time, which would make the bytes differ from one second to the next.
struct EncodeOptions {
  int jpeg_quality = 0;  ///< 0: not a JPEG
};

// libpng's PNG_FILTER_PAETH, which OIIO passes on: numeric PNGs (PngKind::numeric).
constexpr int kPaethFilter = 0x80;

Result<std::vector<std::uint8_t>> encode_impl(const char* format, int width, int height,
                                              int channels, OIIO::TypeDesc type, const void* pixels,
                                              const EncodeOptions& options = {}) {
  if (Status ok = check_dimensions(width, height, pixels); !ok) return ok.error();
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  auto out = OIIO::ImageOutput::create(format);
  if (!out) return fail(std::string("no ") + format + " writer: " + output_message(nullptr));
  if (!out->supports("ioproxy") || !out->set_ioproxy(&proxy)) {
    return fail(std::string("the ") + format + " writer cannot write to memory");
  }
  OIIO::ImageSpec spec(width, height, channels, type);
  spec.attribute("DateTime", "");
  // Deflate at its fastest level (each writer reads its own attribute): a 256² terrain tile then
  // encodes 2–4× faster than at the default level 6 for 2–3 % more bytes (float TIFF 181 kB
  // instead of 178 kB, 16-bit PNG 73 kB instead of 71 kB), which keeps generating and encoding a
  // tile within its 10 ms budget (docs/performance.md).
  spec.attribute("compression", "zip:1");
  spec.attribute("png:compressionLevel", 1);
  spec.attribute("png:filter", kPaethFilter);
  if (options.jpeg_quality > 0) {
    spec.attribute("compression", "jpeg:" + std::to_string(options.jpeg_quality));
  }
  if (!out->open(std::string("memory.") + format, spec)) {
    return fail(std::string("cannot encode ") + format + ": " + output_message(out.get()));
  }
  const bool wrote = out->write_image(type, pixels);
  const bool closed = out->close();
  if (!wrote || !closed) {
    return fail(std::string("cannot encode ") + format + ": " + output_message(out.get()));
  }
  return std::vector<std::uint8_t>(bytes.begin(), bytes.end());
}

Status write_bytes(const std::string& path, const Result<std::vector<std::uint8_t>>& encoded) {
  if (!encoded) return encoded.error();
  const std::vector<std::uint8_t>& bytes = encoded.value();
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) {
    return fail("cannot open '" + path + "' for writing: " + std::strerror(errno));
  }
  const std::size_t written = std::fwrite(bytes.data(), 1, bytes.size(), file);
  const int write_errno = errno;
  const int closed = std::fclose(file);
  if (written != bytes.size() || closed != 0) {
    return fail("cannot write '" + path + "': " + std::strerror(write_errno));
  }
  return Ok{};
}

// The single place where exceptions from OIIO (or std::bad_alloc) are turned into errors.
template <class F>
auto guarded(const std::string& context, F&& body) -> decltype(body()) {
  DrainGlobalOiioError drain;
  try {
    return body();
  } catch (const std::exception& e) {
    return fail(context + ": " + e.what());
  } catch (...) {
    return fail(context + ": unknown exception from OpenImageIO");
  }
}

}  // namespace

Result<Raster> read_heightfield(const std::string& path, const ReadLimits& limits) {
  return guarded("cannot read image '" + path + "'", [&] { return read_impl(path, limits); });
}

Result<Raster> decode_heightfield(std::span<const std::uint8_t> bytes, std::string_view format_hint,
                                  const ReadLimits& limits) {
  return guarded("cannot decode image data",
                 [&] { return decode_impl(bytes, format_hint, limits); });
}

Result<std::vector<std::uint8_t>> encode_float_tiff(int width, int height, const float* samples) {
  return guarded("cannot encode TIFF", [&] {
    return encode_impl("tiff", width, height, 1, OIIO::TypeDesc::FLOAT, samples);
  });
}

Result<std::vector<std::uint8_t>> encode_png16(int width, int height,
                                               const std::uint16_t* samples) {
  return guarded("cannot encode PNG", [&] {
    return encode_impl("png", width, height, 1, OIIO::TypeDesc::UINT16, samples);
  });
}

Result<std::vector<std::uint8_t>> encode_png_gray8(int width, int height,
                                                   const std::uint8_t* samples) {
  return guarded("cannot encode PNG", [&] {
    return encode_impl("png", width, height, 1, OIIO::TypeDesc::UINT8, samples);
  });
}

Result<std::vector<std::uint8_t>> encode_png_rgb8(int width, int height, const std::uint8_t* rgb,
                                                  PngKind kind) {
  if (kind == PngKind::shaded) {
    if (Status ok = check_dimensions(width, height, rgb); !ok) return ok.error();
    return encode_png_up_huffman(width, height, rgb);
  }
  return guarded("cannot encode PNG",
                 [&] { return encode_impl("png", width, height, 3, OIIO::TypeDesc::UINT8, rgb); });
}

Result<std::vector<std::uint8_t>> encode_jpeg_rgb8(int width, int height, const std::uint8_t* rgb,
                                                   int quality) {
  if (quality < 1 || quality > 100) return fail("JPEG quality must be 1..100");
  return guarded("cannot encode JPEG", [&] {
    return encode_impl("jpeg", width, height, 3, OIIO::TypeDesc::UINT8, rgb,
                       {.jpeg_quality = quality});
  });
}

Status write_float_tiff(const std::string& path, int width, int height, const float* samples) {
  return guarded("cannot write '" + path + "'",
                 [&] { return write_bytes(path, encode_float_tiff(width, height, samples)); });
}

Status write_png16(const std::string& path, int width, int height, const std::uint16_t* samples) {
  return guarded("cannot write '" + path + "'",
                 [&] { return write_bytes(path, encode_png16(width, height, samples)); });
}

Status write_png_rgb8(const std::string& path, int width, int height, const std::uint8_t* rgb,
                      PngKind kind) {
  return guarded("cannot write '" + path + "'",
                 [&] { return write_bytes(path, encode_png_rgb8(width, height, rgb, kind)); });
}

}  // namespace terrain
