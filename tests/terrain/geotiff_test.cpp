// The GeoTIFF writer's GeoKey directory (GeoTIFF 1.0 §2.4) and the CRS keys of each tiling
// scheme; the files themselves are checked by GDAL in cli_geotiff.sh.
#include "terrain/geotiff.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "terrain/scene.hpp"

namespace terrain {
namespace {

// The value of `key` in a directory: the SHORT itself, or the double it points to.
struct KeyValue {
  std::uint16_t location = 0;
  std::uint16_t count = 0;
  std::uint16_t value = 0;
};
std::optional<KeyValue> find_key(const std::vector<std::uint16_t>& directory, std::uint16_t key) {
  for (std::size_t i = 4; i + 3 < directory.size(); i += 4) {
    if (directory[i] == key) return KeyValue{directory[i + 1], directory[i + 2], directory[i + 3]};
  }
  return std::nullopt;
}

TEST(GeoKeyDirectory, ListsKeysAscendingAfterTheHeaderWithParametersInTheirStores) {
  GeoKeyDirectory keys;
  keys.add_double(geokey::kProjCenterLat, 45.5);
  keys.add(geokey::kRasterType, geokey::kRasterPixelIsPoint);
  keys.add_text(geokey::kCitation, "scene");
  keys.add(geokey::kModelType, geokey::kModelTypeProjected);
  keys.add_double(geokey::kProjCenterLong, 6.25);
  const std::vector<std::uint16_t> expected = {1,    1,
                                               0,    5,  // version 1, revision 1.0, 5 keys
                                               1024, 0,
                                               1,    1,  // model type: projected
                                               1025, 0,
                                               1,    2,  // raster type: pixel is point
                                               1026, geokey::kGeoAsciiParamsTag,
                                               6,    0,  // "scene|" at 0
                                               3088, geokey::kGeoDoubleParamsTag,
                                               1,    1,  // centre longitude: doubles[1]
                                               3089, geokey::kGeoDoubleParamsTag,
                                               1,    0};  // centre latitude: doubles[0]
  EXPECT_EQ(keys.directory(), expected);
  EXPECT_EQ(keys.doubles(), (std::vector<double>{45.5, 6.25}));
  EXPECT_EQ(keys.ascii(), "scene|");
}

TEST(GeoKeyDirectory, LocalTilesAreAUserDefinedOrthographicCrsInMetresAtTheGeoreference) {
  const Georeference here{45.9237, 6.8694, 30.0};
  const GeoKeyDirectory keys =
      geotiff_crs_keys(TileScheme::local, here, geokey::kRasterPixelIsArea);
  const std::vector<std::uint16_t> d = keys.directory();
  EXPECT_EQ(find_key(d, geokey::kModelType)->value, geokey::kModelTypeProjected);
  EXPECT_EQ(find_key(d, geokey::kRasterType)->value, geokey::kRasterPixelIsArea);
  EXPECT_EQ(find_key(d, geokey::kProjectedCSType)->value, geokey::kUserDefined);
  EXPECT_EQ(find_key(d, geokey::kProjection)->value, geokey::kUserDefined);
  EXPECT_EQ(find_key(d, geokey::kProjCoordTrans)->value, geokey::kCtOrthographic);
  EXPECT_EQ(find_key(d, geokey::kProjLinearUnits)->value, geokey::kLinearMeter);
  EXPECT_EQ(find_key(d, geokey::kGeographicType)->value, geokey::kEpsgWgs84);
  const auto lat = find_key(d, geokey::kProjCenterLat), lon = find_key(d, geokey::kProjCenterLong);
  ASSERT_TRUE(lat && lon);
  EXPECT_EQ(lat->location, geokey::kGeoDoubleParamsTag);
  EXPECT_EQ(keys.doubles().at(lat->value), 45.9237);
  EXPECT_EQ(keys.doubles().at(lon->value), 6.8694);
  for (std::uint16_t key : {geokey::kProjFalseEasting, geokey::kProjFalseNorthing}) {
    const auto offset = find_key(d, key);
    ASSERT_TRUE(offset) << key;
    EXPECT_EQ(keys.doubles().at(offset->value), 0.0) << key;  // projected x, y = scene metres
  }
}

TEST(GeoKeyDirectory, WebMercatorAndGeographicTilesNameTheirEpsgCrs) {
  const std::vector<std::uint16_t> web =
      geotiff_crs_keys(TileScheme::webmercator, {}, geokey::kRasterPixelIsArea).directory();
  EXPECT_EQ(find_key(web, geokey::kModelType)->value, geokey::kModelTypeProjected);
  EXPECT_EQ(find_key(web, geokey::kProjectedCSType)->value, geokey::kEpsgWebMercator);
  EXPECT_EQ(find_key(web, geokey::kProjLinearUnits)->value, geokey::kLinearMeter);
  EXPECT_FALSE(find_key(web, geokey::kGeographicType));

  const std::vector<std::uint16_t> geo =
      geotiff_crs_keys(TileScheme::geographic, {}, geokey::kRasterPixelIsPoint).directory();
  EXPECT_EQ(find_key(geo, geokey::kModelType)->value, geokey::kModelTypeGeographic);
  EXPECT_EQ(find_key(geo, geokey::kGeographicType)->value, geokey::kEpsgWgs84);
  EXPECT_EQ(find_key(geo, geokey::kGeogAngularUnits)->value, geokey::kAngularDegree);
  EXPECT_EQ(find_key(geo, geokey::kRasterType)->value, geokey::kRasterPixelIsPoint);
  EXPECT_FALSE(find_key(geo, geokey::kProjectedCSType));
}

TEST(GeoKeyDirectory, ScenePlaneRastersRefuseBadInputNamingTheField) {
  const std::vector<float> ok(9, 100.0f);
  EXPECT_TRUE(encode_scene_plane_geotiff(ok.data(), 3, 3, -10.0, 10.0, 1.0, {}).ok());
  std::vector<float> nan = ok;
  nan[4] = std::numeric_limits<float>::quiet_NaN();
  auto r = encode_scene_plane_geotiff(nan.data(), 3, 3, -10.0, 10.0, 1.0, {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().pointer, "/elevation/4");
  r = encode_scene_plane_geotiff(ok.data(), 3, 3, -10.0, 10.0, 0.0, {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().pointer, "/step");
  r = encode_scene_plane_geotiff(ok.data(), 0, 3, -10.0, 10.0, 1.0, {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().pointer, "/size");
  r = encode_scene_plane_geotiff(ok.data(), 3, 3, -10.0, 10.0, 1.0, {91.0, 0.0, 0.0});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().pointer, "/georeference/latitude");
}

}  // namespace
}  // namespace terrain
