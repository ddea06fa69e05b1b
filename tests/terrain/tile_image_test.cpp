// Image encodings of height tiles: every format decoded back and compared with the heights within
// its quantum, saturation at the ends of the code ranges, shading against hand-computed values,
// GeoTIFF georeferencing as GDAL reads it, determinism, and refusal of malformed tiles. Tiles are
// built by hand here, independent of tile generation from scenes.
#include "terrain/tile_image.hpp"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/image_io.hpp"
#include "terrain/scene.hpp"

namespace terrain {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

// ---------------------------------------------------------------------------------------------
// Synthetic tiles

constexpr double kMercatorHalf = 20037508.342789244;
constexpr TileBounds kLocalWorld{-2048.0, -2048.0, 2048.0, 2048.0};
constexpr TileBounds kMercatorWorld{-kMercatorHalf, -kMercatorHalf, kMercatorHalf, kMercatorHalf};
constexpr TileBounds kGeographicWorld{-180.0, -90.0, 180.0, 90.0};

// Height and its slopes (∂h/∂x, ∂h/∂y) at a position in the scheme's coordinates.
using Surface = std::function<std::array<double, 3>(double x, double y)>;

// A tile of `scheme` at `address`, with bounds derived from the world as the schemes define them
// (geographic rows count from the south), sampled from `surface` at HeightTile::sample_crs_x/y.
HeightTile make_tile(TileScheme scheme, TileAddress address, SampleLayout layout, int cells,
                     int border, TileBounds world, const Surface& surface) {
  HeightTile tile;
  tile.scheme = scheme;
  tile.address = address;
  tile.layout = layout;
  tile.cells = cells;
  tile.border = border;
  tile.width = layout == SampleLayout::cell_corners ? cells + 1 : cells + 2 * border;
  tile.height = tile.width;
  tile.world = world;
  const double tile_width =
      (world.east - world.west) / static_cast<double>(columns_at(scheme, address.z));
  const double tile_height =
      (world.north - world.south) / static_cast<double>(rows_at(scheme, address.z));
  const std::int64_t rows_from_north =
      scheme == TileScheme::geographic ? rows_at(scheme, address.z) - 1 - address.y : address.y;
  tile.bounds.west = world.west + static_cast<double>(address.x) * tile_width;
  tile.bounds.east = tile.bounds.west + tile_width;
  tile.bounds.north = world.north - static_cast<double>(rows_from_north) * tile_height;
  tile.bounds.south = tile.bounds.north - tile_height;
  tile.ground_spacing = tile_width / cells;
  for (int row = 0; row < tile.height; ++row) {
    for (int column = 0; column < tile.width; ++column) {
      const double x = tile.sample_crs_x(column);
      const double y = tile.sample_crs_y(row);
      const auto [h, dx, dy] = surface(x, y);
      tile.elevation.push_back(static_cast<float>(h));
      tile.slope_east.push_back(static_cast<float>(dx));
      tile.slope_north.push_back(static_cast<float>(dy));
      tile.scene_x.push_back(x);
      tile.scene_y.push_back(y);
    }
  }
  return tile;
}

// A tilted plane with a Gaussian hill: smooth, and varied enough that the low code bytes wrap.
std::array<double, 3> slope_and_bump(double x, double y) {
  const double cx = -500.0, cy = -500.0, sigma = 150.0, amplitude = 80.0;
  const double bump =
      amplitude * std::exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (2 * sigma * sigma));
  return {500.0 + 0.05 * x - 0.02 * y + bump, 0.05 - bump * (x - cx) / (sigma * sigma),
          -0.02 - bump * (y - cy) / (sigma * sigma)};
}

// 256 cells of 4 m: the local tile (2, 1, 2) spans x in [-1024, 0], y in [-1024, 0].
HeightTile local_tile(int border) {
  return make_tile(TileScheme::local, {2, 1, 2}, SampleLayout::cell_centres, 256, border,
                   kLocalWorld, slope_and_bump);
}

// Over the Alps at zoom 12; heights vary with the position in EPSG:3857 metres.
HeightTile webmercator_tile() {
  return make_tile(TileScheme::webmercator, {12, 2124, 1459}, SampleLayout::cell_centres, 256, 0,
                   kMercatorWorld, [](double x, double y) -> std::array<double, 3> {
                     return {1800.0 + 400.0 * std::sin(x / 700.0) * std::cos(y / 900.0), 0, 0};
                   });
}

// A cell_corners tile (65×65 samples) at zoom 7 of the two-root geographic scheme.
HeightTile geographic_corner_tile() {
  return make_tile(TileScheme::geographic, {7, 134, 96}, SampleLayout::cell_corners, 64, 0,
                   kGeographicWorld, [](double lon, double lat) -> std::array<double, 3> {
                     return {300.0 + 1000.0 * std::sin(lon) * std::cos(lat * 2.0), 0, 0};
                   });
}

// A plane h = se·x + sn·y with the given slopes: the reference for normal maps and hillshades.
HeightTile plane_tile(double slope_east, double slope_north) {
  return make_tile(TileScheme::local, {0, 0, 0}, SampleLayout::cell_centres, 8, 0, kLocalWorld,
                   [=](double x, double y) -> std::array<double, 3> {
                     return {slope_east * x + slope_north * y, slope_east, slope_north};
                   });
}

// An n×n tile (tiles are square) whose first row holds `heights`, zeros elsewhere.
HeightTile tile_with_first_row(const std::vector<float>& heights) {
  const int n = static_cast<int>(heights.size());
  HeightTile tile = make_tile(TileScheme::local, {0, 0, 0}, SampleLayout::cell_centres, n, 0,
                              kLocalWorld, [](double, double) -> std::array<double, 3> {
                                return {0, 0, 0};
                              });
  std::copy(heights.begin(), heights.end(), tile.elevation.begin());
  return tile;
}

// ---------------------------------------------------------------------------------------------
// Decoding and tools

// The pixels of an 8- or 16-bit PNG as stored, channel-interleaved.
struct Pixels {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<std::uint32_t> values;

  std::uint32_t at(int column, int row, int channel = 0) const {
    return values[(static_cast<std::size_t>(row) * static_cast<std::size_t>(width) +
                   static_cast<std::size_t>(column)) *
                      static_cast<std::size_t>(channels) +
                  static_cast<std::size_t>(channel)];
  }
};

Pixels decode_png(const Bytes& bytes) {
  Pixels pixels;
  OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
  auto in = OIIO::ImageInput::create("png");
  EXPECT_TRUE(in && in->set_ioproxy(&proxy));
  if (!in) return pixels;
  OIIO::ImageSpec spec;
  EXPECT_TRUE(in->open("memory.png", spec)) << in->geterror();
  pixels.width = spec.width;
  pixels.height = spec.height;
  pixels.channels = spec.nchannels;
  const std::size_t count = static_cast<std::size_t>(spec.width) *
                            static_cast<std::size_t>(spec.height) *
                            static_cast<std::size_t>(spec.nchannels);
  if (spec.format == OIIO::TypeDesc::UINT8) {
    std::vector<std::uint8_t> raw(count);
    EXPECT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, raw.data()))
        << in->geterror();
    pixels.values.assign(raw.begin(), raw.end());
  } else {
    EXPECT_EQ(spec.format, OIIO::TypeDesc::UINT16);
    std::vector<std::uint16_t> raw(count);
    EXPECT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT16, raw.data()))
        << in->geterror();
    pixels.values.assign(raw.begin(), raw.end());
  }
  in->close();
  return pixels;
}

// A fresh directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::random_device seed;
    path_ = fs::temp_directory_path() /
            ("terrain-tile-image-" + std::string(info->name()) + "-" + std::to_string(seed()));
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

void write_file(const std::string& path, const Bytes& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

Bytes file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Runs a command and returns its standard output (empty when it cannot be started).
std::string run(const std::string& command) {
  std::string output;
  std::FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return output;
  char buffer[4096];
  while (const std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
  pclose(pipe);
  return output;
}

bool have_gdal() {
  return fs::exists("/usr/bin/gdalinfo") && fs::exists("/usr/bin/gdal_translate") &&
         fs::exists("/usr/bin/gdallocationinfo");
}

// What GDAL makes of a GeoTIFF: gdalinfo's JSON (with the PROJ.4 string).
nlohmann::json gdal_info(const TempDir& dir, const Bytes& tiff) {
  const std::string path = dir.file("tile.tif");
  write_file(path, tiff);
  const std::string text = run("/usr/bin/gdalinfo -json -proj4 '" + path + "' 2>&1");
  nlohmann::json info = nlohmann::json::parse(text, nullptr, false);
  EXPECT_FALSE(info.is_discarded()) << text;
  return info;
}

// The samples GDAL decodes, as raw float32 through gdal_translate to ENVI.
std::vector<float> gdal_samples(const TempDir& dir, const Bytes& tiff) {
  const std::string path = dir.file("values.tif");
  const std::string raw = dir.file("values.raw");
  write_file(path, tiff);
  const std::string output =
      run("/usr/bin/gdal_translate -q -of ENVI '" + path + "' '" + raw + "' 2>&1");
  EXPECT_EQ(output, "");
  const Bytes bytes = file_bytes(raw);
  std::vector<float> samples(bytes.size() / sizeof(float));
  std::memcpy(samples.data(), bytes.data(), samples.size() * sizeof(float));
  return samples;
}

// The value GDAL finds at a position given in the file's CRS (on stdin, so that negative
// coordinates are not taken for options).
double gdal_value_at(const TempDir& dir, const Bytes& tiff, double x, double y) {
  const std::string path = dir.file("located.tif");
  write_file(path, tiff);
  char position[80];
  std::snprintf(position, sizeof position, "%.17g %.17g", x, y);
  const std::string text =
      run("echo '" + std::string(position) + "' | /usr/bin/gdallocationinfo -valonly -geoloc '" +
          path + "' 2>&1");
  try {
    return std::stod(text);
  } catch (const std::exception&) {
    ADD_FAILURE() << "gdallocationinfo said: " << text;
    return std::numeric_limits<double>::quiet_NaN();
  }
}

// Longitude/latitude or metres: compared relative to the larger of the value and one unit.
void expect_geotransform(const nlohmann::json& info, const std::array<double, 6>& expected) {
  ASSERT_TRUE(info.contains("geoTransform")) << info.dump();
  const auto& actual = info["geoTransform"];
  ASSERT_EQ(actual.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    const double a = actual[i].get<double>();
    EXPECT_NEAR(a, expected[i], 1e-9 * std::max(1.0, std::abs(expected[i])))
        << "geoTransform[" << i << "]";
  }
}

std::string area_or_point(const nlohmann::json& info) {
  return info.value(nlohmann::json::json_pointer("/metadata//AREA_OR_POINT"), std::string());
}

double proj4_parameter(const nlohmann::json& info, const std::string& name) {
  const std::string proj4 = info["coordinateSystem"].value("proj4", std::string());
  const auto at = proj4.find("+" + name + "=");
  if (at == std::string::npos) return std::numeric_limits<double>::quiet_NaN();
  return std::stod(proj4.substr(at + name.size() + 2));
}

// ---------------------------------------------------------------------------------------------
// terrain-RGB and Terrarium

double terrain_rgb_height(const Pixels& p, int column, int row) {
  return -10000.0 +
         (p.at(column, row, 0) * 65536.0 + p.at(column, row, 1) * 256.0 + p.at(column, row, 2)) *
             0.1;
}

double terrarium_height(const Pixels& p, int column, int row) {
  return p.at(column, row, 0) * 256.0 + p.at(column, row, 1) + p.at(column, row, 2) / 256.0 -
         32768.0;
}

TEST(TileImageTerrainRgb, RoundTripsWithinHalfADecimetre) {
  const HeightTile tile = local_tile(1);
  const auto png = encode_terrain_rgb(tile);
  ASSERT_TRUE(png) << png.error().message;
  const Pixels p = decode_png(*png);
  ASSERT_EQ(p.width, 258);
  ASSERT_EQ(p.height, 258);
  ASSERT_EQ(p.channels, 3);
  for (int row = 0; row < tile.height; ++row) {
    for (int column = 0; column < tile.width; ++column) {
      ASSERT_NEAR(terrain_rgb_height(p, column, row), tile.elevation[tile.index(column, row)],
                  0.05 + 1e-6)
          << "column " << column << ", row " << row;
    }
  }
}

TEST(TileImageTerrainRgb, SaturatesOutsideItsRange) {
  const HeightTile tile = tile_with_first_row({-20000.0f, -10000.0f, 0.0f, 1667721.5f, 2.0e6f});
  const auto png = encode_terrain_rgb(tile);
  ASSERT_TRUE(png) << png.error().message;
  const Pixels p = decode_png(*png);
  const auto code = [&](int column) {
    return p.at(column, 0, 0) << 16 | p.at(column, 0, 1) << 8 | p.at(column, 0, 2);
  };
  EXPECT_EQ(code(0), 0u);
  EXPECT_EQ(code(1), 0u);
  EXPECT_EQ(code(2), 100000u);  // (0 + 10000) · 10
  EXPECT_EQ(code(3), 0xFFFFFFu);
  EXPECT_EQ(code(4), 0xFFFFFFu);
  EXPECT_EQ(terrain_rgb_height(p, 3, 0), kTerrainRgbHighest);
}

TEST(TileImageTerrarium, RoundTripsWithinHalfAStep) {
  const HeightTile tile = local_tile(0);
  const auto png = encode_terrarium(tile);
  ASSERT_TRUE(png) << png.error().message;
  const Pixels p = decode_png(*png);
  ASSERT_EQ(p.width, 256);
  ASSERT_EQ(p.channels, 3);
  for (int row = 0; row < tile.height; ++row) {
    for (int column = 0; column < tile.width; ++column) {
      ASSERT_LE(
          std::abs(terrarium_height(p, column, row) - tile.elevation[tile.index(column, row)]),
          0.5 / 256.0)
          << "column " << column << ", row " << row;
    }
  }
}

TEST(TileImageTerrarium, SaturatesOutsideItsRange) {
  const HeightTile tile = tile_with_first_row({-40000.0f, 0.0f, 1.5f, 32767.99609375f, 40000.0f});
  const auto png = encode_terrarium(tile);
  ASSERT_TRUE(png) << png.error().message;
  const Pixels p = decode_png(*png);
  EXPECT_EQ(terrarium_height(p, 0, 0), kTerrariumLowest);
  EXPECT_EQ(p.at(1, 0, 0), 128u);
  EXPECT_EQ(p.at(1, 0, 1), 0u);
  EXPECT_EQ(p.at(1, 0, 2), 0u);
  EXPECT_EQ(terrarium_height(p, 2, 0), 1.5);
  EXPECT_EQ(terrarium_height(p, 3, 0), kTerrariumHighest);
  EXPECT_EQ(terrarium_height(p, 4, 0), kTerrariumHighest);
}

// ---------------------------------------------------------------------------------------------
// 16-bit grey

TEST(TileImageGray16, EncodingUsesTheSmallestRoundScaleThatCoversTheRange) {
  EXPECT_EQ(gray16_encoding_for({0.0f, 60.0f}).scale, 0.001);
  EXPECT_EQ(gray16_encoding_for({0.0f, 100.0f}).scale, 0.002);
  EXPECT_EQ(gray16_encoding_for({0.0f, 200.0f}).scale, 0.005);
  EXPECT_EQ(gray16_encoding_for({0.0f, 400.0f}).scale, 0.01);
  EXPECT_EQ(gray16_encoding_for({-12.34f, 1234.5f}).scale, 0.02);
  EXPECT_EQ(gray16_encoding_for({-11000.0f, 8849.0f}).scale, 0.5);
  EXPECT_EQ(gray16_encoding_for({0.0f, 3.0e7f}).scale, 500.0);
  // A flat or empty range still gets the finest step.
  EXPECT_EQ(gray16_encoding_for({100.0f, 100.0f}).scale, 0.001);
  EXPECT_EQ(gray16_encoding_for(Interval{}).scale, 0.001);
  EXPECT_EQ(gray16_encoding_for(Interval{}).offset, 0.0);
}

TEST(TileImageGray16, OffsetIsAMultipleOfTheScaleAtOrBelowTheMinimum) {
  for (const Interval range :
       {Interval{-12.34f, 1234.5f}, Interval{100.0f, 100.0f}, Interval{0.3f, 70.0f},
        Interval{-11000.0f, 8849.0f}, Interval{1234.567f, 1290.0f}, Interval{-0.001f, 0.0f}}) {
    const Gray16Encoding e = gray16_encoding_for(range);
    EXPECT_LE(e.offset, range.lo);
    EXPECT_GT(e.offset, range.lo - e.scale);
    EXPECT_NEAR(e.offset / e.scale, std::round(e.offset / e.scale), 1e-6);
    EXPECT_GE(e.offset + 65535.0 * e.scale, range.hi);
  }
  EXPECT_EQ(gray16_encoding_for({-12.34f, 1234.5f}).offset, -12.36);
  EXPECT_EQ(gray16_encoding_for({-11000.0f, 8849.0f}).offset, -11000.0);
}

TEST(TileImageGray16, RoundTripsWithinHalfAStep) {
  const HeightTile tile = local_tile(1);
  const Gray16Encoding encoding = gray16_encoding_for({400.0f, 700.0f});
  ASSERT_EQ(encoding.scale, 0.005);
  const auto png = encode_gray16(tile, encoding);
  ASSERT_TRUE(png) << png.error().message;
  const Pixels p = decode_png(*png);
  ASSERT_EQ(p.width, 258);
  ASSERT_EQ(p.channels, 1);
  for (int row = 0; row < tile.height; ++row) {
    for (int column = 0; column < tile.width; ++column) {
      const double decoded = encoding.offset + encoding.scale * p.at(column, row);
      ASSERT_NEAR(decoded, tile.elevation[tile.index(column, row)], encoding.scale / 2 + 1e-6)
          << "column " << column << ", row " << row;
    }
  }
  // The image_io reader sees the same codes, normalised.
  const auto raster = decode_heightfield(*png, "png");
  ASSERT_TRUE(raster) << raster.error().message;
  EXPECT_EQ(std::lround(raster->at(7, 9) * 65535.0), static_cast<long>(p.at(7, 9)));
}

TEST(TileImageGray16, SaturatesOutsideTheEncoding) {
  const HeightTile tile = tile_with_first_row({-1.0f, 10.0f, 10.0004f, 10.0006f, 80.0f, 1e9f});
  const auto png = encode_gray16(tile, {10.0, 0.001});
  ASSERT_TRUE(png) << png.error().message;
  const Pixels p = decode_png(*png);
  EXPECT_EQ(p.at(0, 0), 0u);
  EXPECT_EQ(p.at(1, 0), 0u);
  EXPECT_EQ(p.at(2, 0), 0u);
  EXPECT_EQ(p.at(3, 0), 1u);
  EXPECT_EQ(p.at(4, 0), 65535u);
  EXPECT_EQ(p.at(5, 0), 65535u);
}

// ---------------------------------------------------------------------------------------------
// GeoTIFF

const Georeference kChamonix{45.83, 6.86, 0.0};

TEST(TileImageGeoTiff, KeepsTheHeightsExactly) {
  const HeightTile tile = local_tile(1);
  const auto tiff = encode_geotiff(tile, kChamonix);
  ASSERT_TRUE(tiff) << tiff.error().message;
  const auto raster = decode_heightfield(*tiff, "tif");
  ASSERT_TRUE(raster) << raster.error().message;
  ASSERT_EQ(raster->width, 258);
  ASSERT_EQ(raster->height, 258);
  EXPECT_EQ(raster->samples, tile.elevation);
}

TEST(TileImageGeoTiff, GdalReadsTheSameFloats) {
  ASSERT_TRUE(have_gdal()) << "gdal-bin is missing; run scripts/install-deps.sh";
  const TempDir dir;
  for (const HeightTile& tile : {local_tile(1), geographic_corner_tile()}) {
    const auto tiff = encode_geotiff(tile, kChamonix);
    ASSERT_TRUE(tiff) << tiff.error().message;
    EXPECT_EQ(gdal_samples(dir, *tiff), tile.elevation) << scheme_name(tile.scheme);
  }
}

TEST(TileImageGeoTiff, LocalTileIsOrthographicAroundTheGeoreference) {
  ASSERT_TRUE(have_gdal()) << "gdal-bin is missing; run scripts/install-deps.sh";
  const TempDir dir;
  const HeightTile tile = local_tile(1);
  const auto tiff = encode_geotiff(tile, kChamonix);
  ASSERT_TRUE(tiff) << tiff.error().message;
  const nlohmann::json info = gdal_info(dir, *tiff);
  const std::string wkt = info["coordinateSystem"].value("wkt", std::string());
  EXPECT_NE(wkt.find("Orthographic"), std::string::npos) << wkt;
  EXPECT_NE(wkt.find("WGS 84"), std::string::npos) << wkt;
  EXPECT_NE(info["coordinateSystem"].value("proj4", std::string()).find("+proj=ortho"),
            std::string::npos);
  EXPECT_DOUBLE_EQ(proj4_parameter(info, "lat_0"), 45.83);
  EXPECT_DOUBLE_EQ(proj4_parameter(info, "lon_0"), 6.86);
  EXPECT_EQ(area_or_point(info), "Area");
  // Pixel-is-area: the border moves the outer corner one 4 m pixel out of the tile bounds.
  const double step = 4.0;
  expect_geotransform(info,
                      {tile.bounds.west - step, step, 0.0, tile.bounds.north + step, 0.0, -step});
  EXPECT_EQ(info["size"], nlohmann::json::array({258, 258}));
}

TEST(TileImageGeoTiff, LocalTileHeadingRotatesTheGrid) {
  ASSERT_TRUE(have_gdal()) << "gdal-bin is missing; run scripts/install-deps.sh";
  const TempDir dir;
  const HeightTile tile = local_tile(0);
  const double heading = 30.0;
  const auto tiff = encode_geotiff(tile, Georeference{45.83, 6.86, heading});
  ASSERT_TRUE(tiff) << tiff.error().message;
  const nlohmann::json info = gdal_info(dir, *tiff);
  EXPECT_DOUBLE_EQ(proj4_parameter(info, "lat_0"), 45.83);
  // Scene +y points 30° east of north: the scene point (x, y) is at
  // east = x·cos 30° + y·sin 30°, north = −x·sin 30° + y·cos 30°.
  const double c = std::cos(heading * std::numbers::pi / 180.0);
  const double s = std::sin(heading * std::numbers::pi / 180.0);
  const double x0 = tile.bounds.west, y0 = tile.bounds.north, step = 4.0;
  expect_geotransform(
      info, {c * x0 + s * y0, c * step, -s * step, -s * x0 + c * y0, -s * step, -c * step});
  // GDAL finds each sample where the heading puts its scene position.
  for (const auto& [column, row] : {std::pair{0, 0}, std::pair{100, 60}, std::pair{255, 17}}) {
    const double x = tile.sample_crs_x(column), y = tile.sample_crs_y(row);
    EXPECT_NEAR(gdal_value_at(dir, *tiff, c * x + s * y, -s * x + c * y),
                tile.elevation[tile.index(column, row)], 1e-3)
        << "column " << column << ", row " << row;
  }
  // Heading 90°: scene +y points east and scene +x south, so (x, y) is at east y, north −x.
  const auto east = encode_geotiff(tile, Georeference{45.83, 6.86, 90.0});
  ASSERT_TRUE(east) << east.error().message;
  const double x = tile.sample_crs_x(100), y = tile.sample_crs_y(60);
  EXPECT_NEAR(gdal_value_at(dir, *east, y, -x), tile.elevation[tile.index(100, 60)], 1e-3);
}

TEST(TileImageGeoTiff, WebMercatorTileIsEpsg3857) {
  ASSERT_TRUE(have_gdal()) << "gdal-bin is missing; run scripts/install-deps.sh";
  const TempDir dir;
  const HeightTile tile = webmercator_tile();
  const auto tiff = encode_geotiff(tile, kChamonix);
  ASSERT_TRUE(tiff) << tiff.error().message;
  const nlohmann::json info = gdal_info(dir, *tiff);
  const std::string wkt = info["coordinateSystem"].value("wkt", std::string());
  EXPECT_NE(wkt.find("ID[\"EPSG\",3857]"), std::string::npos) << wkt;
  EXPECT_EQ(area_or_point(info), "Area");
  const double step = (tile.bounds.east - tile.bounds.west) / 256.0;
  expect_geotransform(info, {tile.bounds.west, step, 0.0, tile.bounds.north, 0.0, -step});
  // The centre of pixel (0, 0) is the first sample.
  const auto& gt = info["geoTransform"];
  EXPECT_NEAR(gt[0].get<double>() + 0.5 * gt[1].get<double>(), tile.sample_crs_x(0), 1e-6);
  EXPECT_NEAR(gt[3].get<double>() + 0.5 * gt[5].get<double>(), tile.sample_crs_y(0), 1e-6);
}

TEST(TileImageGeoTiff, GeographicCornerTileIsEpsg4326PixelIsPoint) {
  ASSERT_TRUE(have_gdal()) << "gdal-bin is missing; run scripts/install-deps.sh";
  const TempDir dir;
  const HeightTile tile = geographic_corner_tile();
  const auto tiff = encode_geotiff(tile, kChamonix);
  ASSERT_TRUE(tiff) << tiff.error().message;
  const nlohmann::json info = gdal_info(dir, *tiff);
  const std::string wkt = info["coordinateSystem"].value("wkt", std::string());
  EXPECT_NE(wkt.find("ID[\"EPSG\",4326]"), std::string::npos) << wkt;
  EXPECT_EQ(area_or_point(info), "Point");
  EXPECT_EQ(info["size"], nlohmann::json::array({65, 65}));
  // Tile (7, 134, 96): 1.40625° square at 8.4375°E..9.84375°E, 45°N..46.40625°N. GDAL reports
  // pixel corners, half a pixel out from the first sample on the tile's north-west corner.
  ASSERT_DOUBLE_EQ(tile.bounds.west, 8.4375);
  ASSERT_DOUBLE_EQ(tile.bounds.north, 46.40625);
  const double step = 1.40625 / 64.0;
  expect_geotransform(info, {8.4375 - step / 2, step, 0.0, 46.40625 + step / 2, 0.0, -step});
  for (const auto& [column, row] : {std::pair{0, 0}, std::pair{10, 20}, std::pair{64, 64}}) {
    EXPECT_NEAR(gdal_value_at(dir, *tiff, tile.sample_crs_x(column), tile.sample_crs_y(row)),
                tile.elevation[tile.index(column, row)], 1e-3)
        << "column " << column << ", row " << row;
  }
}

TEST(TileImageGeoTiff, BorderlessCellCentresStartAtTheTileCorner) {
  ASSERT_TRUE(have_gdal()) << "gdal-bin is missing; run scripts/install-deps.sh";
  const TempDir dir;
  const HeightTile tile =
      make_tile(TileScheme::geographic, {3, 9, 3}, SampleLayout::cell_centres, 16, 0,
                kGeographicWorld, [](double, double) -> std::array<double, 3> {
                  return {7, 0, 0};
                });
  const auto tiff = encode_geotiff(tile, kChamonix);
  ASSERT_TRUE(tiff) << tiff.error().message;
  const nlohmann::json info = gdal_info(dir, *tiff);
  EXPECT_EQ(area_or_point(info), "Area");
  // 22.5° tiles: column 9 spans 22.5°E..45°E, row 3 (counted from the south) 22.5°S..0°.
  expect_geotransform(info, {22.5, 22.5 / 16, 0.0, 0.0, 0.0, -22.5 / 16});
}

// ---------------------------------------------------------------------------------------------
// Normal map and hillshade

TEST(TileImageNormalMap, PlaneGivesItsHandComputedNormal) {
  // n = normalize(−0.5, 0.25, 1) = (−0.43644, 0.21822, 0.87287) → (n + 1)/2·255 =
  // (71.85, 155.32, 238.79).
  const auto png = encode_normal_map(plane_tile(0.5, -0.25));
  ASSERT_TRUE(png) << png.error().message;
  const Pixels p = decode_png(*png);
  ASSERT_EQ(p.channels, 3);
  for (int row = 0; row < p.height; ++row) {
    for (int column = 0; column < p.width; ++column) {
      EXPECT_EQ(p.at(column, row, 0), 72u);
      EXPECT_EQ(p.at(column, row, 1), 155u);
      EXPECT_EQ(p.at(column, row, 2), 239u);
    }
  }
  const auto flat_png = encode_normal_map(plane_tile(0.0, 0.0));
  ASSERT_TRUE(flat_png) << flat_png.error().message;
  const Pixels flat = decode_png(*flat_png);
  EXPECT_EQ(flat.at(3, 3, 0), 128u);  // 127.5 rounds up
  EXPECT_EQ(flat.at(3, 3, 1), 128u);
  EXPECT_EQ(flat.at(3, 3, 2), 255u);
}

TEST(TileImageNormalMap, UsesTheSlopesTheTileCarries) {
  // Flat heights but slopes of a plane rising east: the image shows the slopes, so it is not
  // computed by differencing the heights.
  HeightTile tile = plane_tile(1.0, 0.0);
  std::fill(tile.elevation.begin(), tile.elevation.end(), 0.0f);
  const auto png = encode_normal_map(tile);
  ASSERT_TRUE(png) << png.error().message;
  const Pixels p = decode_png(*png);
  EXPECT_EQ(p.at(4, 4, 0), 37u);  // (1 − 1/√2)/2·255 = 37.34
  EXPECT_EQ(p.at(4, 4, 1), 128u);
  EXPECT_EQ(p.at(4, 4, 2), 218u);  // (1 + 1/√2)/2·255 = 217.66
}

std::uint32_t hillshade_at_centre(double slope_east, double slope_north,
                                  const HillshadeOptions& options = {}) {
  const auto png = encode_hillshade(plane_tile(slope_east, slope_north), options);
  if (!png) {
    ADD_FAILURE() << png.error().message;
    return 0;
  }
  const Pixels p = decode_png(*png);
  EXPECT_EQ(p.channels, 1);
  EXPECT_EQ(p.width, 8);
  return p.at(4, 4);
}

TEST(TileImageHillshade, PlanesGiveTheirHandComputedShade) {
  // Default light from the north-west, 45° up: l = (−½, ½, √½).
  EXPECT_EQ(hillshade_at_centre(0.0, 0.0), 180u);  // 255·sin 45° = 180.31
  // Facing the light: n = l.
  EXPECT_EQ(hillshade_at_centre(std::sqrt(0.5), -std::sqrt(0.5)), 255u);
  // Facing away: n·l < 0 is black.
  EXPECT_EQ(hillshade_at_centre(-1.5, 1.5), 0u);
  // z_factor 2 on a 0.5 slope is a 1.0 slope: n = (−1, 0, 1)/√2, n·l = 0.8536 → 217.66.
  EXPECT_EQ(hillshade_at_centre(0.5, 0.0, {315.0, 45.0, 2.0}), 218u);
  // Light from the east, 30° up, on a slope rising east: n·l = (−0.433 + 0.5)/1.118 → 15.28.
  EXPECT_EQ(hillshade_at_centre(0.5, 0.0, {90.0, 30.0, 1.0}), 15u);
  // Overhead light on a flat plane is full white whatever the azimuth.
  EXPECT_EQ(hillshade_at_centre(0.0, 0.0, {0.0, 90.0, 1.0}), 255u);
}

// ---------------------------------------------------------------------------------------------
// Determinism

TEST(TileImageDeterminism, EncodingTwiceGivesTheSameBytes) {
  const HeightTile tile = local_tile(1);
  const Georeference rotated{45.83, 6.86, 17.0};
  const std::vector<std::function<Result<Bytes>()>> encoders = {
      [&] { return encode_terrain_rgb(tile); },
      [&] { return encode_terrarium(tile); },
      [&] {
        return encode_gray16(tile, gray16_encoding_for({0.0f, 1000.0f}));
      },
      [&] { return encode_geotiff(tile, kChamonix); },
      [&] { return encode_geotiff(tile, rotated); },
      [&] { return encode_geotiff(webmercator_tile(), kChamonix); },
      [&] { return encode_normal_map(tile); },
      [&] { return encode_hillshade(tile); },
  };
  for (std::size_t i = 0; i < encoders.size(); ++i) {
    const auto first = encoders[i]();
    const auto second = encoders[i]();
    ASSERT_TRUE(first && second) << "encoder " << i;
    EXPECT_FALSE(first->empty());
    EXPECT_EQ(*first, *second) << "encoder " << i;
  }
}

// ---------------------------------------------------------------------------------------------
// Malformed input

// Every encoder of heights, for checks that apply to all of them.
std::vector<Result<Bytes>> encode_all(const HeightTile& tile) {
  return {encode_terrain_rgb(tile),         encode_terrarium(tile),
          encode_gray16(tile, {0.0, 0.01}), encode_geotiff(tile, kChamonix),
          encode_normal_map(tile),          encode_hillshade(tile)};
}

void expect_all_refused(const HeightTile& tile, const std::string& pointer) {
  const auto results = encode_all(tile);
  for (std::size_t i = 0; i < results.size(); ++i) {
    ASSERT_FALSE(results[i]) << "encoder " << i << " accepted a tile with a bad " << pointer;
    EXPECT_EQ(results[i].error().pointer, pointer)
        << "encoder " << i << ": " << results[i].error().message;
    EXPECT_FALSE(results[i].error().message.empty());
  }
}

TEST(TileImageMalformed, InconsistentGridsAreRefusedNamingTheField) {
  expect_all_refused(HeightTile{}, "/width");  // empty: no samples for 256 cells

  HeightTile no_cells = plane_tile(0, 0);
  no_cells.cells = 0;
  expect_all_refused(no_cells, "/cells");

  HeightTile huge = plane_tile(0, 0);
  huge.cells = 1 << 20;
  expect_all_refused(huge, "/cells");

  HeightTile wide_border = plane_tile(0, 0);
  wide_border.border = 2;
  expect_all_refused(wide_border, "/border");

  HeightTile corners_with_border = geographic_corner_tile();
  corners_with_border.border = 1;
  expect_all_refused(corners_with_border, "/border");

  HeightTile wrong_width = plane_tile(0, 0);
  wrong_width.width = 9;
  expect_all_refused(wrong_width, "/width");

  HeightTile not_square = plane_tile(0, 0);
  not_square.height = 7;
  expect_all_refused(not_square, "/height");

  HeightTile short_elevation = plane_tile(0, 0);
  short_elevation.elevation.pop_back();
  for (const auto& result :
       {encode_terrain_rgb(short_elevation), encode_terrarium(short_elevation),
        encode_gray16(short_elevation, {0.0, 0.01}), encode_geotiff(short_elevation, kChamonix)}) {
    ASSERT_FALSE(result);
    EXPECT_EQ(result.error().pointer, "/elevation");
  }
}

TEST(TileImageMalformed, NonFiniteSamplesAreRefusedNamingTheSample) {
  HeightTile nan_height = plane_tile(0, 0);
  nan_height.elevation[13] = std::numeric_limits<float>::quiet_NaN();
  for (const auto& result :
       {encode_terrain_rgb(nan_height), encode_terrarium(nan_height),
        encode_gray16(nan_height, {0.0, 0.01}), encode_geotiff(nan_height, kChamonix)}) {
    ASSERT_FALSE(result);
    EXPECT_EQ(result.error().pointer, "/elevation/13");
    EXPECT_NE(result.error().message.find("column 5, row 1"), std::string::npos)
        << result.error().message;
  }

  HeightTile infinite_slope = plane_tile(0, 0);
  infinite_slope.slope_north[2] = std::numeric_limits<float>::infinity();
  for (const auto& result : {encode_normal_map(infinite_slope), encode_hillshade(infinite_slope)}) {
    ASSERT_FALSE(result);
    EXPECT_EQ(result.error().pointer, "/slope_north/2");
  }

  HeightTile no_slopes = plane_tile(0, 0);
  no_slopes.slope_east.clear();
  for (const auto& result : {encode_normal_map(no_slopes), encode_hillshade(no_slopes)}) {
    ASSERT_FALSE(result);
    EXPECT_EQ(result.error().pointer, "/slope_east");
  }
  // Height encoders do not need slopes.
  EXPECT_TRUE(encode_terrain_rgb(no_slopes));
}

TEST(TileImageMalformed, BadOptionsAreRefusedNamingTheOption) {
  const HeightTile tile = plane_tile(0.1, 0.1);
  const auto pointer = [](const Result<Bytes>& result) {
    return result ? std::string("accepted") : result.error().pointer;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(pointer(encode_gray16(tile, {0.0, 0.0})), "/gray16/scale");
  EXPECT_EQ(pointer(encode_gray16(tile, {0.0, -1.0})), "/gray16/scale");
  EXPECT_EQ(pointer(encode_gray16(tile, {nan, 1.0})), "/gray16/offset");
  EXPECT_EQ(pointer(encode_hillshade(tile, {inf, 45.0, 1.0})), "/hillshade/azimuth_deg");
  EXPECT_EQ(pointer(encode_hillshade(tile, {315.0, 95.0, 1.0})), "/hillshade/altitude_deg");
  EXPECT_EQ(pointer(encode_hillshade(tile, {315.0, -1.0, 1.0})), "/hillshade/altitude_deg");
  EXPECT_EQ(pointer(encode_hillshade(tile, {315.0, 45.0, 0.0})), "/hillshade/z_factor");
  EXPECT_EQ(pointer(encode_geotiff(tile, {91.0, 0.0, 0.0})), "/georeference/latitude");
  EXPECT_EQ(pointer(encode_geotiff(tile, {0.0, -181.0, 0.0})), "/georeference/longitude");
  EXPECT_EQ(pointer(encode_geotiff(tile, {0.0, 0.0, nan})), "/georeference/heading");
  // Only local tiles use the georeference.
  EXPECT_EQ(pointer(encode_geotiff(webmercator_tile(), {91.0, 0.0, 0.0})), "accepted");
}

TEST(TileImageMalformed, GeoTiffRefusesATileThatCannotBePlaced) {
  const auto pointer = [](const HeightTile& tile) {
    const auto result = encode_geotiff(tile, kChamonix);
    return result ? std::string("accepted") : result.error().pointer;
  };
  HeightTile bad_zoom = webmercator_tile();
  bad_zoom.address.z = 30;
  EXPECT_EQ(pointer(bad_zoom), "/address/z");

  HeightTile bad_column = webmercator_tile();
  bad_column.address.x = 1 << 12;
  EXPECT_EQ(pointer(bad_column), "/address/x");

  HeightTile no_world = local_tile(0);
  no_world.world = {};
  EXPECT_EQ(pointer(no_world), "/world");

  HeightTile moved = local_tile(0);
  moved.bounds.west += 1.0;
  EXPECT_EQ(pointer(moved), "/bounds");
}

}  // namespace
}  // namespace terrain
