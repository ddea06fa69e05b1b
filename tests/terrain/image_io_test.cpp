// Reading heightfield images (files and memory), deterministic writers, and refusal of malformed
// input. Test images are generated with OIIO in a temporary directory.
#include "terrain/image_io.hpp"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "terrain/heightfield.hpp"

namespace terrain {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::random_device seed;
    path_ =
        fs::temp_directory_path() / ("terrain-image-io-" + std::string(info->test_suite_name()) +
                                     "-" + info->name() + "-" + std::to_string(seed()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

std::vector<std::uint8_t> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_file(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

// Writes an image with OIIO directly (formats and layouts our writers do not produce).
void oiio_write(const std::string& path, OIIO::ImageSpec spec, const float* pixels) {
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out) << OIIO::geterror();
  // Keep alpha as given instead of letting the writer un-premultiply colour.
  spec.attribute("oiio:UnassociatedAlpha", 1);
  ASSERT_TRUE(out->open(path, spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels)) << out->geterror();
  ASSERT_TRUE(out->close()) << out->geterror();
}

std::vector<float> ramp_pixels(int width, int height, int channels) {
  std::vector<float> px;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < channels; ++c) {
        px.push_back(c == 0 ? 0.25f * static_cast<float>(x) - 3.0f * static_cast<float>(y)
                            : static_cast<float>((x + 2 * y + c) % 5) / 4.0f);
      }
    }
  }
  return px;
}

void expect_same(const Raster& a, const Raster& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.weights, b.weights);
}

TEST(ImageIoRoundTrip, FloatTiffGivesTheSamplesBack) {
  TempDir dir;
  const int w = 37, h = 23;
  std::vector<float> samples(static_cast<std::size_t>(w * h));
  std::mt19937 rng(1);
  std::normal_distribution<float> normal(0.0f, 1000.0f);
  for (float& s : samples) s = normal(rng);
  const std::string path = dir.file("height.tif");
  ASSERT_TRUE(write_float_tiff(path, w, h, samples.data()).ok());
  const Result<Raster> r = read_heightfield(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->width, w);
  EXPECT_EQ(r->height, h);
  EXPECT_EQ(r->samples, samples);  // bit exact
  EXPECT_FALSE(r->has_weight());
}

TEST(ImageIoRoundTrip, Png16IsNormalisedWithinOneStep) {
  TempDir dir;
  const int w = 300, h = 7;
  std::vector<std::uint16_t> samples;
  for (int k = 0; k < w * h; ++k) samples.push_back(static_cast<std::uint16_t>(k * 31 % 65536));
  samples[5] = 65535;
  const std::string path = dir.file("height.png");
  ASSERT_TRUE(write_png16(path, w, h, samples.data()).ok());
  const Result<Raster> r = read_heightfield(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->samples.size(), samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k) {
    EXPECT_NEAR(r->samples[k], samples[k] / 65535.0, 1.0 / 65535.0) << k;
  }
  EXPECT_EQ(r->samples[5], 1.0f);
}

TEST(ImageIoRoundTrip, Png8AndRgbTakeTheFirstChannelNormalised) {
  TempDir dir;
  const int w = 5, h = 4;
  std::vector<std::uint8_t> rgb;
  for (int k = 0; k < w * h; ++k) {
    rgb.push_back(static_cast<std::uint8_t>(k * 13));
    rgb.push_back(200);
    rgb.push_back(7);
  }
  const std::string path = dir.file("colour.png");
  ASSERT_TRUE(write_png_rgb8(path, w, h, rgb.data()).ok());
  const Result<Raster> r = read_heightfield(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->has_weight());
  for (int k = 0; k < w * h; ++k) {
    EXPECT_NEAR(r->samples[static_cast<std::size_t>(k)], (k * 13) / 255.0, 1e-6);
  }
}

TEST(ImageIoRoundTrip, ExrGivesTheSamplesBack) {
  TempDir dir;
  const int w = 9, h = 6;
  const std::vector<float> px = ramp_pixels(w, h, 1);
  const std::string path = dir.file("height.exr");
  oiio_write(path, OIIO::ImageSpec(w, h, 1, OIIO::TypeDesc::FLOAT), px.data());
  const Result<Raster> r = read_heightfield(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->samples, px);
  EXPECT_EQ(r->at(4, 2), 0.25f * 4 - 3.0f * 2);  // row 0 is the top row
}

TEST(ImageIoRoundTrip, AlphaBecomesAnUnpremultipliedWeight) {
  TempDir dir;
  const int w = 6, h = 5;
  std::vector<float> px = ramp_pixels(w, h, 2);
  for (std::size_t k = 0; k < px.size(); k += 2) px[k] = std::abs(px[k]) / 16.0f;  // PNG range
  OIIO::ImageSpec spec(w, h, 2, OIIO::TypeDesc::UINT16);
  spec.channelnames = {"Y", "A"};
  spec.alpha_channel = 1;
  const std::string png = dir.file("grey-alpha.png");
  oiio_write(png, spec, px.data());
  spec.set_format(OIIO::TypeDesc::FLOAT);
  const std::string exr = dir.file("grey-alpha.exr");
  oiio_write(exr, spec, px.data());

  for (const std::string& path : {png, exr}) {
    const Result<Raster> r = read_heightfield(path);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(r->has_weight()) << path;
    for (std::size_t k = 0; k < r->samples.size(); ++k) {
      // Heights are not multiplied by alpha (some alphas are 0).
      EXPECT_NEAR(r->samples[k], px[2 * k], 1.0 / 65535.0) << path << " " << k;
      EXPECT_NEAR(r->weights[k], px[2 * k + 1], 1.0 / 65535.0) << path << " " << k;
    }
  }
}

TEST(ImageIoRoundTrip, TiledImagesAreReadInBands) {
  TempDir dir;
  const int w = 70, h = 53;  // not multiples of the tile size
  const std::vector<float> px = ramp_pixels(w, h, 2);
  OIIO::ImageSpec spec(w, h, 2, OIIO::TypeDesc::FLOAT);
  spec.tile_width = 16;
  spec.tile_height = 16;
  spec.tile_depth = 1;
  spec.channelnames = {"Y", "A"};
  spec.alpha_channel = 1;
  for (const char* name : {"tiled.tif", "tiled.exr"}) {
    const std::string path = dir.file(name);
    oiio_write(path, spec, px.data());
    const Result<Raster> r = read_heightfield(path);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(r->has_weight());
    for (std::size_t k = 0; k < r->samples.size(); ++k) {
      ASSERT_EQ(r->samples[k], px[2 * k]) << name << " " << k;
      ASSERT_EQ(r->weights[k], px[2 * k + 1]) << name << " " << k;
    }
  }
}

TEST(ImageIoRoundTrip, RgbPngsOfEitherKindGiveEveryChannelBack) {
  // Shaded PNGs (colour tiles, pictures) go through libpng with Huffman coding alone, numeric ones
  // through OpenImageIO: a standard reader gets every byte back from both.
  TempDir dir;
  const int w = 37, h = 29;  // odd sizes: no row happens to align
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(w * h * 3));
  for (std::size_t k = 0; k < rgb.size(); ++k) {
    rgb[k] = k < rgb.size() / 3 ? 200 : static_cast<std::uint8_t>((k * 2654435761u) >> 13);
  }
  for (const PngKind kind : {PngKind::shaded, PngKind::numeric}) {
    const std::string path = dir.file(kind == PngKind::shaded ? "shaded.png" : "numeric.png");
    ASSERT_TRUE(write_png_rgb8(path, w, h, rgb.data(), kind).ok());
    auto in = OIIO::ImageInput::open(path);
    ASSERT_TRUE(in);
    ASSERT_EQ(in->spec().width, w);
    ASSERT_EQ(in->spec().height, h);
    ASSERT_EQ(in->spec().nchannels, 3);
    std::vector<std::uint8_t> back(rgb.size());
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, back.data()));
    EXPECT_EQ(back, rgb);
  }
  const auto shaded = encode_png_rgb8(w, h, rgb.data(), PngKind::shaded);
  ASSERT_TRUE(shaded.ok());
  EXPECT_EQ(shaded.value(), encode_png_rgb8(w, h, rgb.data(), PngKind::shaded).value());
  EXPECT_FALSE(encode_png_rgb8(0, h, rgb.data(), PngKind::shaded).ok());
  EXPECT_FALSE(encode_png_rgb8(w, h, nullptr, PngKind::shaded).ok());
}

TEST(ImageIoDecode, MemoryEqualsFileWhateverTheHint) {
  TempDir dir;
  const int w = 11, h = 8;
  const std::vector<float> heights = ramp_pixels(w, h, 1);
  std::vector<std::uint16_t> words;
  for (int k = 0; k < w * h; ++k) words.push_back(static_cast<std::uint16_t>(k * 700));
  const std::string tif = dir.file("a.tif"), png = dir.file("b.png"), exr = dir.file("c.exr");
  ASSERT_TRUE(write_float_tiff(tif, w, h, heights.data()).ok());
  ASSERT_TRUE(write_png16(png, w, h, words.data()).ok());
  oiio_write(exr, OIIO::ImageSpec(w, h, 1, OIIO::TypeDesc::HALF), heights.data());

  for (const auto& [path, hint] :
       {std::pair{tif, "tif"}, std::pair{png, "image/png"}, std::pair{exr, ".EXR"}}) {
    const Result<Raster> from_file = read_heightfield(path);
    ASSERT_TRUE(from_file.ok()) << from_file.error().message;
    const std::vector<std::uint8_t> bytes = file_bytes(path);
    for (const char* h_ : {hint, "", "png", "nonsense"}) {
      const Result<Raster> from_memory = decode_heightfield(bytes, h_);
      ASSERT_TRUE(from_memory.ok())
          << path << " hint '" << h_ << "': " << from_memory.error().message;
      expect_same(from_file.value(), from_memory.value());
    }
  }
}

TEST(ImageIoEncode, WritersAreDeterministicAndFilesMatchMemory) {
  TempDir dir;
  const int w = 64, h = 48;
  std::vector<float> heights(static_cast<std::size_t>(w * h));
  std::vector<std::uint16_t> words(heights.size());
  std::vector<std::uint8_t> rgb(heights.size() * 3);
  for (std::size_t k = 0; k < heights.size(); ++k) {
    heights[k] = std::sin(static_cast<float>(k) * 0.01f) * 100.0f;
    words[k] = static_cast<std::uint16_t>(k * 977);
  }
  for (std::size_t k = 0; k < rgb.size(); ++k) rgb[k] = static_cast<std::uint8_t>(k * 7);

  const auto tiff1 = encode_float_tiff(w, h, heights.data());
  const auto tiff2 = encode_float_tiff(w, h, heights.data());
  const auto png1 = encode_png16(w, h, words.data());
  const auto png2 = encode_png16(w, h, words.data());
  const auto rgb1 = encode_png_rgb8(w, h, rgb.data());
  const auto rgb2 = encode_png_rgb8(w, h, rgb.data());
  ASSERT_TRUE(tiff1.ok() && tiff2.ok() && png1.ok() && png2.ok() && rgb1.ok() && rgb2.ok());
  EXPECT_EQ(tiff1.value(), tiff2.value());
  EXPECT_EQ(png1.value(), png2.value());
  EXPECT_EQ(rgb1.value(), rgb2.value());

  ASSERT_TRUE(write_float_tiff(dir.file("x.tif"), w, h, heights.data()).ok());
  ASSERT_TRUE(write_png16(dir.file("x.png"), w, h, words.data()).ok());
  // The writer picks the format, not the extension.
  ASSERT_TRUE(write_png_rgb8(dir.file("x.rgb.tif"), w, h, rgb.data()).ok());
  EXPECT_EQ(file_bytes(dir.file("x.tif")), tiff1.value());
  EXPECT_EQ(file_bytes(dir.file("x.png")), png1.value());
  EXPECT_EQ(file_bytes(dir.file("x.rgb.tif")), rgb1.value());

  // Nothing time-dependent: OIIO's writers stamp DateTime unless told not to.
  for (const auto* bytes : {&tiff1.value(), &png1.value(), &rgb1.value()}) {
    const Result<Raster> back = decode_heightfield(*bytes, "");
    ASSERT_TRUE(back.ok()) << back.error().message;
  }
  const std::string stamped = dir.file("x.tif");
  auto in = OIIO::ImageInput::open(stamped);
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().find_attribute("DateTime"), nullptr);
}

TEST(ImageIoMalformed, RefusedWithClearErrors) {
  TempDir dir;
  // Missing file: the message names it.
  const std::string missing = dir.file("does-not-exist.png");
  const Result<Raster> none = read_heightfield(missing);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("does-not-exist.png"), std::string::npos)
      << none.error().message;

  // Truncated PNG bytes: cut in the header, and cut in the pixel data. They are refused before
  // OpenImageIO reads them (its PNG reader leaks memory when it reads past the end).
  std::vector<std::uint16_t> words(200 * 200);
  for (std::size_t k = 0; k < words.size(); ++k)
    words[k] = static_cast<std::uint16_t>(k * 2654435761u >> 16);
  const std::vector<std::uint8_t> png = encode_png16(200, 200, words.data()).value();
  for (const std::size_t keep : {std::size_t{20}, png.size() / 2, png.size() - 20}) {
    const std::vector<std::uint8_t> cut(png.begin(), png.begin() + static_cast<long>(keep));
    const Result<Raster> r = decode_heightfield(cut, "png");
    ASSERT_FALSE(r.ok()) << "kept " << keep << " of " << png.size();
    EXPECT_NE(r.error().message.find("the PNG is cut short"), std::string::npos)
        << r.error().message;
  }
  const std::string_view text_of_png(reinterpret_cast<const char*>(png.data()), png.size());
  const std::size_t idat = text_of_png.find("IDAT") - 4;  // the chunk starts with its length
  const std::vector<std::uint8_t> in_idat(png.begin(), png.begin() + static_cast<long>(idat + 40));
  EXPECT_NE(
      decode_heightfield(in_idat, "png")
          .error()
          .message.find("its IDAT chunk at byte " + std::to_string(idat) + " runs past the end"),
      std::string::npos)
      << decode_heightfield(in_idat, "png").error().message;
  // Whole chunks with the IEND chunk missing, and a PNG hint on bytes that are no PNG.
  const std::size_t iend = png.size() - 12;
  EXPECT_NE(decode_heightfield(std::vector<std::uint8_t>(png.begin(), png.begin() + iend), "png")
                .error()
                .message.find("no IEND chunk"),
            std::string::npos);
  EXPECT_NE(decode_heightfield(std::vector<std::uint8_t>{1, 2, 3}, "image/png")
                .error()
                .message.find("not a PNG"),
            std::string::npos);
  // A truncated file too.
  write_file(dir.file("cut.png"), std::vector<std::uint8_t>(png.begin(), png.begin() + 100));
  EXPECT_FALSE(read_heightfield(dir.file("cut.png")).ok());

  // Not an image at all, empty, and an unknown hint.
  const std::vector<std::uint8_t> text = {'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd'};
  EXPECT_FALSE(decode_heightfield(text, "").ok());
  EXPECT_FALSE(decode_heightfield(text, "png").ok());
  EXPECT_FALSE(decode_heightfield(text, "no-such-format").ok());
  EXPECT_FALSE(decode_heightfield({}, "png").ok());
  write_file(dir.file("text.tif"), text);
  EXPECT_FALSE(read_heightfield(dir.file("text.tif")).ok());

  // Too large: per-axis and total limits, checked before decoding.
  const ReadLimits narrow{.max_width = 100, .max_height = 8192, .max_pixels = 1 << 24};
  const Result<Raster> wide = decode_heightfield(png, "png", narrow);
  ASSERT_FALSE(wide.ok());
  EXPECT_NE(wide.error().message.find("limit is 100x8192"), std::string::npos)
      << wide.error().message;
  const ReadLimits few{.max_width = 8192, .max_height = 8192, .max_pixels = 1000};
  const Result<Raster> many = decode_heightfield(png, "png", few);
  ASSERT_FALSE(many.ok());
  EXPECT_NE(many.error().message.find("40000 pixels"), std::string::npos) << many.error().message;

  // NaN and infinity in a float TIFF: the first bad pixel is named.
  std::vector<float> heights(6 * 4, 1.0f);
  heights[2 * 6 + 3] = std::numeric_limits<float>::quiet_NaN();
  heights[3 * 6 + 1] = std::numeric_limits<float>::infinity();
  ASSERT_TRUE(write_float_tiff(dir.file("nan.tif"), 6, 4, heights.data()).ok());
  const Result<Raster> nan = read_heightfield(dir.file("nan.tif"));
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().message.find("(x=3, y=2)"), std::string::npos) << nan.error().message;
  EXPECT_NE(nan.error().message.find("NaN"), std::string::npos) << nan.error().message;

  // Writers refuse empty images and null pixels.
  EXPECT_FALSE(encode_float_tiff(0, 5, heights.data()).ok());
  EXPECT_FALSE(encode_png16(3, 3, nullptr).ok());
  EXPECT_FALSE(write_float_tiff(dir.file("no-such-dir/x.tif"), 6, 4, heights.data()).ok());

  // Quads: non-convex (a dart), self-intersecting (bow tie), degenerate (coincident corners,
  // collinear corners), non-finite.
  const Result<QuadMap> dart = QuadMap::create({0, 0}, {10, 0}, {2, 2}, {0, 10});
  ASSERT_FALSE(dart.ok());
  EXPECT_NE(dart.error().message.find("not convex"), std::string::npos) << dart.error().message;
  const Result<QuadMap> bow = QuadMap::create({0, 0}, {10, 0}, {0, 10}, {10, 10});
  ASSERT_FALSE(bow.ok());
  EXPECT_NE(bow.error().message.find("not convex"), std::string::npos) << bow.error().message;
  const Result<QuadMap> coincident = QuadMap::create({0, 0}, {10, 0}, {10, 0}, {0, 10});
  ASSERT_FALSE(coincident.ok());
  EXPECT_NE(coincident.error().message.find("degenerate"), std::string::npos)
      << coincident.error().message;
  const Result<QuadMap> collinear = QuadMap::create({0, 0}, {5, 0}, {10, 0}, {0, 10});
  ASSERT_FALSE(collinear.ok());
  EXPECT_NE(collinear.error().message.find("collinear"), std::string::npos)
      << collinear.error().message;
  const Result<QuadMap> flat = QuadMap::create({0, 0}, {1, 0}, {2, 0}, {3, 0});
  EXPECT_FALSE(flat.ok());
  const Result<QuadMap> point = QuadMap::create({1, 1}, {1, 1}, {1, 1}, {1, 1});
  EXPECT_FALSE(point.ok());
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_FALSE(QuadMap::create({0, 0}, {inf, 0}, {1, 1}, {0, 1}).ok());
}

}  // namespace
}  // namespace terrain
