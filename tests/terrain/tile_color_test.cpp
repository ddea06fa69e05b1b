// Colour imagery tiles: the material model's colours by height, slope and water, lit from the
// north-west; children stitched together give their parent's pixels (no seams); the same bytes
// every time, PNG and JPEG alike; formats parsed from the table; malformed inputs refused
// naming the field.
#include "terrain/tile_color.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "example_tile_sources.hpp"
#include "synthetic_tiles.hpp"
#include "terrain/image_io.hpp"
#include "terrain/material.hpp"
#include "terrain/tile_products.hpp"
#include "terrain/tile_source.hpp"

namespace terrain {
namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr float kDry = std::numeric_limits<float>::quiet_NaN();  // no water near

struct Pixel {
  int r, g, b;
};

Pixel pixel_at(const Bytes& rgb, std::size_t i) {
  return {rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]};
}

// A 2×2 tile (one cell, its corners) with the given heights and slopes, row 0 north.
HeightTile four_samples(const float (&heights)[4], const float (&east)[4],
                        const float (&north)[4]) {
  HeightTile tile = test_tiles::synthetic_tile(0, 0, 0, 1);
  tile.elevation.assign(std::begin(heights), std::end(heights));
  tile.slope_east.assign(std::begin(east), std::end(east));
  tile.slope_north.assign(std::begin(north), std::end(north));
  return tile;
}

TEST(ColorTile, GrassLowSnowOnFlatSummitsRockOnCliffsAndWaterWhereFlagged) {
  // Low and flat; summit and flat; mid-height at 63° (slope 2); low and flagged as water.
  const HeightTile tile = four_samples({0.0f, 1000.0f, 500.0f, 0.0f}, {0.0f, 0.0f, 2.0f, 0.0f},
                                       {0.0f, 0.0f, 0.0f, 0.0f});
  const std::vector<float> water = {kDry, kDry, kDry, 10.0f};
  ColorTileInputs inputs;
  inputs.relief = {0.0f, 1000.0f};
  inputs.water_surface = water;
  Result<Bytes> rgb = color_pixels(tile, inputs);
  ASSERT_TRUE(rgb.ok()) << rgb.error().message;
  const Pixel grass = pixel_at(*rgb, 0), snow = pixel_at(*rgb, 1), rock = pixel_at(*rgb, 2),
              lake = pixel_at(*rgb, 3);
  EXPECT_GT(grass.g, grass.r);
  EXPECT_GT(grass.r, grass.b);
  EXPECT_GT(std::min({snow.r, snow.g, snow.b}), 190);
  EXPECT_LE(std::abs(rock.r - rock.g), 8) << "rock is grey";
  EXPECT_LE(std::abs(rock.g - rock.b), 8);
  EXPECT_GT(lake.b, lake.g);
  EXPECT_GT(lake.g, lake.r);
}

TEST(ColorTile, SandOnShoresJustAboveTheWaterAndSnowLowerOnNorthFaces) {
  // Flat ground 1 m and 30 m above a lake's surface at 100 m (band 10 m); then the same
  // 27° slope at 77 % of the relief facing north and facing south.
  const float t = 0.5f;
  const HeightTile tile =
      four_samples({101.0f, 130.0f, 770.0f, 770.0f}, {0.0f, 0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -t, t});
  const std::vector<float> lake = {100.0f, 100.0f, kDry, kDry};
  ColorTileInputs inputs;
  inputs.relief = {0.0f, 1000.0f};
  inputs.water_surface = lake;
  inputs.shore_band = 10.0f;
  Result<Bytes> rgb = color_pixels(tile, inputs);
  ASSERT_TRUE(rgb.ok()) << rgb.error().message;
  const Pixel beach = pixel_at(*rgb, 0), field = pixel_at(*rgb, 1), north = pixel_at(*rgb, 2),
              south = pixel_at(*rgb, 3);
  EXPECT_GT(beach.r, beach.g) << "sand is yellow";
  EXPECT_GT(beach.g, beach.b);
  EXPECT_GT(field.g, field.r) << "beyond the band: vegetation";
  // The north face is snowy (whiter: its blue channel well up), the south face bare.
  EXPECT_GT(north.b - south.b, 40) << "north " << north.b << ", south " << south.b;
}

TEST(ColorTile, PlanetRowsLowerTheSnowLinePolewardAndFacePolewardSouthOfTheEquator) {
  // Four samples at 40 % of the relief: flat at the equator and flat near a pole (row 0 and
  // row 1 below); then, as a second tile, the same slope facing north in the north and in
  // the south at 45° of latitude, the snow line then 0.80 − 0.7·0.707 ≈ 0.30 ± 0.10.
  const HeightTile flat = four_samples({400.0f, 400.0f, 400.0f, 400.0f}, {0.0f, 0.0f, 0.0f, 0.0f},
                                       {0.0f, 0.0f, 0.0f, 0.0f});
  ColorTileInputs inputs;
  inputs.relief = {0.0f, 1000.0f};
  const std::vector<float> equator_then_pole = {0.0f, -0.99f};
  inputs.polar = equator_then_pole;
  Result<Bytes> rgb = color_pixels(flat, inputs);
  ASSERT_TRUE(rgb.ok()) << rgb.error().message;
  EXPECT_GT(pixel_at(*rgb, 0).g, pixel_at(*rgb, 0).b) << "no snow at the equator";
  EXPECT_GT(pixel_at(*rgb, 2).b, 190) << "snow near a pole, south as north";

  const float t = 0.5f;  // 27°, facing north (the gradient rises southward)
  const HeightTile slope =
      four_samples({330.0f, 330.0f, 330.0f, 330.0f}, {0.0f, 0.0f, 0.0f, 0.0f}, {-t, -t, -t, -t});
  const std::vector<float> north_then_south = {0.7071f, -0.7071f};
  inputs.polar = north_then_south;
  rgb = color_pixels(slope, inputs);
  ASSERT_TRUE(rgb.ok());
  // Facing north is facing the pole in the north, the equator in the south: less snow there.
  EXPECT_GT(pixel_at(*rgb, 0).b - pixel_at(*rgb, 2).b, 20);
}

TEST(ColorTile, SlopesFacingTheNorthWestSunAreBrighter) {
  // The same 27° slope rising to the south-east (facing the sun) and to the north-west.
  const float s = 0.5f / std::sqrt(2.0f);
  const HeightTile tile =
      four_samples({300.0f, 300.0f, 300.0f, 300.0f}, {s, -s, 0.0f, 0.0f}, {-s, s, 0.0f, 0.0f});
  ColorTileInputs inputs;
  inputs.relief = {0.0f, 1000.0f};
  Result<Bytes> rgb = color_pixels(tile, inputs);
  ASSERT_TRUE(rgb.ok()) << rgb.error().message;
  const Pixel facing = pixel_at(*rgb, 0), away = pixel_at(*rgb, 1), flat = pixel_at(*rgb, 2);
  EXPECT_GT(facing.g, flat.g);
  EXPECT_GT(flat.g, away.g);
}

TEST(ColorTile, ChildTilesStitchIntoTheirParentWithoutSeams) {
  // A 512² tile and its four 256² children sample the same places at the same level of detail:
  // their pixels must agree, edges included, water included (lake-dunes has a lake).
  TileGenerator generator(testing::example_source("lake-dunes"));
  const TileSource& source = generator.source();
  ColorTileInputs inputs;
  inputs.relief = source.elevation_range;
  const TileRange r = tiles_covering_area(source, TileScheme::local, 1);
  const TileAddress parent{1, r.min_x, r.min_y};
  std::vector<float> parent_water;
  Result<HeightTile> big = generator.height_tile_with_water(
      {TileScheme::local, parent, SampleLayout::cell_centres, 512, 0}, parent_water);
  ASSERT_TRUE(big.ok()) << big.error().message;
  ASSERT_FALSE(parent_water.empty());
  inputs.water_surface = parent_water;
  inputs.shore_band = shore_band_for(source.elevation_range);
  Result<Bytes> whole = color_pixels(*big, inputs);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  int differing = 0, wet = 0;
  for (int q = 0; q < 4; ++q) {
    const int dx = q % 2, dy = q / 2;
    const TileAddress child{2, 2 * parent.x + dx, 2 * parent.y + dy};
    std::vector<float> water;
    Result<HeightTile> small = generator.height_tile_with_water(
        {TileScheme::local, child, SampleLayout::cell_centres, 256, 0}, water);
    ASSERT_TRUE(small.ok()) << small.error().message;
    inputs.water_surface = water;
    Result<Bytes> part = color_pixels(*small, inputs);
    ASSERT_TRUE(part.ok()) << part.error().message;
    for (std::size_t i = 0; i < water.size(); ++i) wet += water[i] > small->elevation[i] ? 1 : 0;
    for (int row = 0; row < 256; ++row) {
      for (int column = 0; column < 256; ++column) {
        // Local tiles count y to the south, as their rows do.
        const int parent_row = dy * 256 + row, parent_column = dx * 256 + column;
        const Pixel a = pixel_at(*part, static_cast<std::size_t>(row * 256 + column));
        const Pixel b =
            pixel_at(*whole, static_cast<std::size_t>(parent_row * 512 + parent_column));
        const int d = std::max({std::abs(a.r - b.r), std::abs(a.g - b.g), std::abs(a.b - b.b)});
        ASSERT_LE(d, 1) << "child " << q << " row " << row << " column " << column;
        differing += d;
      }
    }
  }
  EXPECT_GT(wet, 0) << "the lake shows in the children";
  EXPECT_LT(differing, 256 * 256 * 4 / 1000) << "at most float rounding, rarely";
}

TEST(ColorTile, SameTileSameBytesAndJpegLooksLikeThePng) {
  ProductMaker maker(testing::example_source("mountain-range"));
  const TileRange r = tiles_covering_area(maker.source(), TileScheme::webmercator, 12);
  const TileAddress address{12, (r.min_x + r.max_x) / 2, (r.min_y + r.max_y) / 2};
  Result<Product> png = maker.make(TileScheme::webmercator, address, TileFormat::color_png);
  Result<Product> again = maker.make(TileScheme::webmercator, address, TileFormat::color_png);
  Result<Product> jpeg = maker.make(TileScheme::webmercator, address, TileFormat::color_jpeg);
  Result<Product> jpeg_again = maker.make(TileScheme::webmercator, address, TileFormat::color_jpeg);
  ASSERT_TRUE(png.ok() && again.ok() && jpeg.ok() && jpeg_again.ok());
  EXPECT_EQ(png->bytes, again->bytes);
  EXPECT_EQ(jpeg->bytes, jpeg_again->bytes);
  EXPECT_EQ(png->media_type, "image/png");
  EXPECT_EQ(jpeg->media_type, "image/jpeg");
  ASSERT_GE(jpeg->bytes.size(), 3u);
  EXPECT_EQ(jpeg->bytes[0], 0xFF);
  EXPECT_EQ(jpeg->bytes[1], 0xD8);
  // Both decode to 256² pictures that agree within JPEG's loss (on the first channel, which
  // decode_heightfield reads, normalised to 0..1).
  Result<Raster> a = decode_heightfield(png->bytes, "png");
  Result<Raster> b = decode_heightfield(jpeg->bytes, "jpg");
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok()) << b.error().message;
  ASSERT_EQ(a->width, 256);
  ASSERT_EQ(b->width, 256);
  double total = 0.0;
  for (std::size_t i = 0; i < a->samples.size(); ++i) {
    total += std::abs(a->samples[i] - b->samples[i]) * 255.0;
  }
  EXPECT_LT(total / static_cast<double>(a->samples.size()), 3.0) << "mean error in 8-bit steps";
}

TEST(ColorTileFormat, ComesFromTheFormatTable) {
  EXPECT_EQ(parse_tile_format("png", "color").value(), TileFormat::color_png);
  EXPECT_EQ(parse_tile_format("jpg", "color").value(), TileFormat::color_jpeg);
  EXPECT_EQ(parse_tile_format("jpg").value(), TileFormat::color_jpeg) << "the only JPEG";
  EXPECT_EQ(parse_tile_format("png").value(), TileFormat::terrain_rgb) << "PNG's default";
}

// ---------------------------------------------------------------------------------------------
// Malformed input

TEST(ColorTileFormat, RefusesEncodingsAndExtensionsItDoesNotHave) {
  Result<TileFormat> jpeg_heights = parse_tile_format("jpg", "terrain-rgb");
  ASSERT_FALSE(jpeg_heights.ok());
  EXPECT_EQ(jpeg_heights.error().pointer, "/encoding");
  EXPECT_NE(jpeg_heights.error().message.find("expected color"), std::string::npos)
      << jpeg_heights.error().message;
  Result<TileFormat> webp = parse_tile_format("webp");
  ASSERT_FALSE(webp.ok());
  EXPECT_EQ(webp.error().pointer, "/format");
  EXPECT_NE(webp.error().message.find("png, jpg, tif, terrain, glb, drc"), std::string::npos)
      << webp.error().message;
  Result<TileFormat> tiff_colour = parse_tile_format("tif", "color");
  ASSERT_FALSE(tiff_colour.ok());
  EXPECT_EQ(tiff_colour.error().pointer, "/encoding");
}

TEST(ColorTile, RefusesMalformedInputsNamingTheField) {
  const HeightTile tile = test_tiles::synthetic_tile(0, 0, 0, 4);
  ColorTileInputs inputs;
  inputs.relief = {0.0f, 1000.0f};
  const std::vector<float> short_water(3, 1.0f);
  inputs.water_surface = short_water;
  EXPECT_EQ(color_pixels(tile, inputs).error().pointer, "/water_surface");
  inputs.water_surface = {};
  inputs.shore_band = -1.0f;
  EXPECT_EQ(color_pixels(tile, inputs).error().pointer, "/shore_band");
  inputs.shore_band = 0.0f;
  inputs.relief = {0.0f, std::numeric_limits<float>::infinity()};
  EXPECT_EQ(color_pixels(tile, inputs).error().pointer, "/relief");
  inputs.relief = {0.0f, 1000.0f};
  inputs.light.altitude_deg = 120.0;
  EXPECT_EQ(color_pixels(tile, inputs).error().pointer, "/hillshade/altitude_deg");
  inputs.light = {};
  const std::vector<float> wrong_rows(3, 0.0f), not_a_sine(5, 1.5f);
  inputs.polar = wrong_rows;
  EXPECT_EQ(color_pixels(tile, inputs).error().pointer, "/polar");
  inputs.polar = not_a_sine;
  EXPECT_EQ(color_pixels(tile, inputs).error().pointer, "/polar/0");
  inputs.polar = {};
  HeightTile broken = tile;
  broken.elevation[7] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(color_pixels(broken, inputs).error().pointer, "/elevation/7");
  EXPECT_FALSE(encode_color(broken, inputs, ColorCodec::jpeg).ok());
}

}  // namespace
}  // namespace terrain
