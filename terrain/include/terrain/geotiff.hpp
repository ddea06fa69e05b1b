// GeoTIFF 1.0 writing (docs/tile-encodings.md#geotiff): the GeoKey directory, the CRS keys of
// each tiling scheme, and float32 rasters of a scene's plane such as `terrain grid` writes.
// encode_geotiff, for height tiles, is declared in tile_image.hpp beside the other encoders.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "terrain/result.hpp"
#include "terrain/tile.hpp"

namespace terrain {

struct Georeference;  // terrain/scene.hpp

/// GeoKey ids and values we write (GeoTIFF 1.0 §6).
namespace geokey {
inline constexpr std::uint16_t kModelType = 1024;   ///< GTModelTypeGeoKey
inline constexpr std::uint16_t kRasterType = 1025;  ///< GTRasterTypeGeoKey
inline constexpr std::uint16_t kCitation = 1026;    ///< GTCitationGeoKey
inline constexpr std::uint16_t kGeographicType = 2048;
inline constexpr std::uint16_t kGeogAngularUnits = 2054;
inline constexpr std::uint16_t kProjectedCSType = 3072;
inline constexpr std::uint16_t kProjection = 3074;
inline constexpr std::uint16_t kProjCoordTrans = 3075;
inline constexpr std::uint16_t kProjLinearUnits = 3076;
inline constexpr std::uint16_t kProjFalseEasting = 3082;
inline constexpr std::uint16_t kProjFalseNorthing = 3083;
inline constexpr std::uint16_t kProjCenterLong = 3088;
inline constexpr std::uint16_t kProjCenterLat = 3089;

inline constexpr std::uint16_t kModelTypeProjected = 1;
inline constexpr std::uint16_t kModelTypeGeographic = 2;
inline constexpr std::uint16_t kRasterPixelIsArea = 1;
inline constexpr std::uint16_t kRasterPixelIsPoint = 2;
inline constexpr std::uint16_t kUserDefined = 32767;
inline constexpr std::uint16_t kCtOrthographic = 21;
inline constexpr std::uint16_t kLinearMeter = 9001;
inline constexpr std::uint16_t kAngularDegree = 9102;
inline constexpr std::uint16_t kEpsgWgs84 = 4326;
inline constexpr std::uint16_t kEpsgWebMercator = 3857;

inline constexpr std::uint16_t kGeoDoubleParamsTag = 34736;  ///< where double values live
inline constexpr std::uint16_t kGeoAsciiParamsTag = 34737;   ///< where text values live
}  // namespace geokey

/// A GeoKeyDirectoryTag with its GeoDoubleParamsTag and GeoAsciiParamsTag stores.
class GeoKeyDirectory {
 public:
  /// A SHORT value stored in the directory itself.
  void add(std::uint16_t key, std::uint16_t value);
  /// A DOUBLE value, stored in doubles().
  void add_double(std::uint16_t key, double value);
  /// An ASCII value, stored '|'-terminated in ascii(); the entry's count includes the '|'.
  void add_text(std::uint16_t key, std::string_view value);

  /// Header {1, 1, 0, key count} (directory version 1, revision 1.0), then one
  /// {key, location tag (0, double or ASCII), count, value or offset} per key, keys ascending.
  std::vector<std::uint16_t> directory() const;
  const std::vector<double>& doubles() const { return doubles_; }
  const std::string& ascii() const { return ascii_; }

 private:
  std::vector<std::array<std::uint16_t, 4>> entries_;
  std::vector<double> doubles_;
  std::string ascii_;
};

/// The keys of the CRS tiles of `scheme` are written in, with GTRasterTypeGeoKey `raster_type`:
/// webmercator EPSG:3857; geographic EPSG:4326; local (and `terrain grid`) the scene's plane, a
/// user-defined projected CRS in metres: orthographic on WGS 84 centred on the georeference's
/// latitude and longitude, false easting and northing 0, so projected coordinates are the scene's
/// own metres (the plane is the tangent plane at the scene origin). The georeference is read
/// for local only.
GeoKeyDirectory geotiff_crs_keys(TileScheme scheme, const Georeference& georeference,
                                 std::uint16_t raster_type);

/// A north-up float32 GeoTIFF of samples on a scene's plane (what `terrain grid` writes):
/// `columns`×`rows` values, row 0 north, sample (i, j) at scene metres
/// (first_x + i·step, first_y − j·step), pixel-is-point, in the local scheme's CRS
/// (geotiff_crs_keys) rotated by the georeference's heading as local tiles are. Refuses (never
/// throws) sizes outside 1..8192, a step or position that is not finite and positive, non-finite
/// samples and a georeference outside the globe.
Result<std::vector<std::uint8_t>> encode_scene_plane_geotiff(const float* north_up, int columns,
                                                             int rows, double first_x,
                                                             double first_y, double step,
                                                             const Georeference& georeference);

}  // namespace terrain
