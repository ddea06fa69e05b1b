// Height-tile encoders (docs/tile-encodings.md). The PNGs go through image_io (OpenImageIO). The
// GeoTIFF is written with libtiff directly: OpenImageIO 2.4's TIFF writer sets only a fixed list
// of baseline and Exif tags from ImageSpec attributes and silently drops everything else, so
// the GeoTIFF tags (ModelPixelScale, ModelTiepoint, ModelTransformation, GeoKeyDirectory, ...)
// cannot reach the file through it.
#include "terrain/tile_image.hpp"

#include <tiffio.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <numbers>
#include <string>
#include <string_view>
#include <utility>

#include "terrain/image_io.hpp"
#include "terrain/scene.hpp"

namespace terrain {
namespace {

using Bytes = std::vector<std::uint8_t>;

// Larger tiles are refused before anything is allocated; image_io reads no more than this either.
constexpr int kMaxCells = 8192;
constexpr std::uint32_t kMax24BitCode = (1u << 24) - 1;
constexpr std::uint32_t kMax16BitCode = 65535;

std::string text(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

// ---------------------------------------------------------------------------------------------
// Validation

Status check_grid(const HeightTile& tile) {
  if (tile.cells < 1 || tile.cells > kMaxCells) {
    return Error{"the tile must have 1.." + std::to_string(kMaxCells) + " cells per side, not " +
                     std::to_string(tile.cells),
                 "/cells"};
  }
  if (tile.border != 0 && tile.border != 1) {
    return Error{"border must be 0 or 1, not " + std::to_string(tile.border), "/border"};
  }
  if (tile.layout == SampleLayout::cell_corners && tile.border != 0) {
    return Error{"a cell_corners tile has no border", "/border"};
  }
  const int expected =
      tile.layout == SampleLayout::cell_corners ? tile.cells + 1 : tile.cells + 2 * tile.border;
  if (tile.width != expected) {
    return Error{"width is " + std::to_string(tile.width) + " but " + std::to_string(tile.cells) +
                     " cells with this layout and border make " + std::to_string(expected) +
                     " samples per row",
                 "/width"};
  }
  if (tile.height != tile.width) {
    return Error{"height is " + std::to_string(tile.height) + " but tiles are square (width " +
                     std::to_string(tile.width) + ")",
                 "/height"};
  }
  return Ok{};
}

std::size_t sample_count(const HeightTile& tile) {
  return static_cast<std::size_t>(tile.width) * static_cast<std::size_t>(tile.height);
}

// One value per sample, all finite: quantisation and shading are undefined for NaN, and a
// non-finite height is a bug upstream that an image must not hide.
Status check_samples(const HeightTile& tile, const std::vector<float>& values,
                     const std::string& name) {
  if (values.size() != sample_count(tile)) {
    return Error{name + " holds " + std::to_string(values.size()) + " samples but the " +
                     std::to_string(tile.width) + "x" + std::to_string(tile.height) +
                     " grid needs " + std::to_string(sample_count(tile)),
                 "/" + name};
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      const auto width = static_cast<std::size_t>(tile.width);
      return Error{name + " at column " + std::to_string(i % width) + ", row " +
                       std::to_string(i / width) + " is " +
                       (std::isnan(values[i]) ? "NaN" : "infinite"),
                   "/" + name + "/" + std::to_string(i)};
    }
  }
  return Ok{};
}

Status check_heights(const HeightTile& tile) {
  if (Status ok = check_grid(tile); !ok) return ok;
  return check_samples(tile, tile.elevation, "elevation");
}

Status check_slopes(const HeightTile& tile) {
  if (Status ok = check_grid(tile); !ok) return ok;
  if (Status ok = check_samples(tile, tile.slope_east, "slope_east"); !ok) return ok;
  return check_samples(tile, tile.slope_north, "slope_north");
}

// Everything a tile needs beyond its grid to say where it is.
Status check_placement(const HeightTile& tile) {
  if (Status ok = validate_address(tile.scheme, tile.address); !ok) {
    return Error{ok.error().message, "/address" + ok.error().pointer};
  }
  const TileBounds& w = tile.world;
  if (!std::isfinite(w.west) || !std::isfinite(w.east) || !std::isfinite(w.south) ||
      !std::isfinite(w.north) || !(w.east > w.west) || !(w.north > w.south)) {
    return Error{"the world bounds must be finite with east > west and north > south", "/world"};
  }
  return Ok{};
}

Status check_georeference(const Georeference& g) {
  if (!std::isfinite(g.latitude) || g.latitude < -90.0 || g.latitude > 90.0) {
    return Error{"latitude must be in [-90, 90], not " + text(g.latitude),
                 "/georeference/latitude"};
  }
  if (!std::isfinite(g.longitude) || g.longitude < -180.0 || g.longitude > 180.0) {
    return Error{"longitude must be in [-180, 180], not " + text(g.longitude),
                 "/georeference/longitude"};
  }
  if (!std::isfinite(g.heading)) {
    return Error{"heading must be finite", "/georeference/heading"};
  }
  return Ok{};
}

// The encoders' own allocations are the only thing left that can throw.
template <class F>
Result<Bytes> guarded(const char* what, F&& body) {
  try {
    return body();
  } catch (const std::exception& e) {
    return Error{std::string(what) + ": " + e.what(), ""};
  }
}

// Cosine and sine of an angle in degrees, exact at multiples of 90° so that axis-aligned
// headings and overhead light give exact zeros and ones.
std::pair<double, double> cos_sin_degrees(double degrees) {
  double reduced = std::fmod(degrees, 360.0);
  if (reduced < 0.0) reduced += 360.0;
  if (reduced == 0.0) return {1.0, 0.0};
  if (reduced == 90.0) return {0.0, 1.0};
  if (reduced == 180.0) return {-1.0, 0.0};
  if (reduced == 270.0) return {0.0, -1.0};
  const double radians = reduced * (std::numbers::pi / 180.0);
  return {std::cos(radians), std::sin(radians)};
}

// ---------------------------------------------------------------------------------------------
// Quantised PNGs

// The nearest code, saturated to [0, top]. `value` is finite (the samples were checked).
std::uint32_t quantise(double value, std::uint32_t top) {
  return static_cast<std::uint32_t>(std::clamp(std::round(value), 0.0, static_cast<double>(top)));
}

std::uint8_t to_byte(double value) {
  return static_cast<std::uint8_t>(quantise(value, 255));
}

template <class Code>
Result<Bytes> encode_24bit(const HeightTile& tile, Code code) {
  if (Status ok = check_heights(tile); !ok) return ok.error();
  Bytes rgb(sample_count(tile) * 3);
  for (std::size_t i = 0; i < tile.elevation.size(); ++i) {
    const std::uint32_t v = code(static_cast<double>(tile.elevation[i]));
    rgb[3 * i] = static_cast<std::uint8_t>(v >> 16);
    rgb[3 * i + 1] = static_cast<std::uint8_t>((v >> 8) & 0xFF);
    rgb[3 * i + 2] = static_cast<std::uint8_t>(v & 0xFF);
  }
  return encode_png_rgb8(tile.width, tile.height, rgb.data());
}

// ---------------------------------------------------------------------------------------------
// GeoTIFF

// The GeoTIFF tags (GeoTIFF 1.0 §2.4). libtiff does not know them, so each handle learns them
// the way libgeotiff teaches them: TIFFMergeFieldInfo, libtiff's obsolete but only public
// interface for new tags. Its struct predates const, hence the casts on the names.
constexpr ttag_t kModelPixelScaleTag = 33550;
constexpr ttag_t kModelTiepointTag = 33922;
constexpr ttag_t kModelTransformationTag = 34264;
constexpr ttag_t kGeoKeyDirectoryTag = 34735;
constexpr ttag_t kGeoDoubleParamsTag = 34736;
constexpr ttag_t kGeoAsciiParamsTag = 34737;

const TIFFFieldInfo kGeoTiffFields[] = {
    {kModelPixelScaleTag, TIFF_VARIABLE, TIFF_VARIABLE, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1,
     const_cast<char*>("ModelPixelScaleTag")},
    {kModelTiepointTag, TIFF_VARIABLE, TIFF_VARIABLE, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1,
     const_cast<char*>("ModelTiepointTag")},
    {kModelTransformationTag, TIFF_VARIABLE, TIFF_VARIABLE, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1,
     const_cast<char*>("ModelTransformationTag")},
    {kGeoKeyDirectoryTag, TIFF_VARIABLE, TIFF_VARIABLE, TIFF_SHORT, FIELD_CUSTOM, 1, 1,
     const_cast<char*>("GeoKeyDirectoryTag")},
    {kGeoDoubleParamsTag, TIFF_VARIABLE, TIFF_VARIABLE, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1,
     const_cast<char*>("GeoDoubleParamsTag")},
    {kGeoAsciiParamsTag, TIFF_VARIABLE, TIFF_VARIABLE, TIFF_ASCII, FIELD_CUSTOM, 1, 0,
     const_cast<char*>("GeoAsciiParamsTag")},
};

// GeoKey ids and values (GeoTIFF 1.0 §6).
constexpr std::uint16_t kGTModelTypeGeoKey = 1024;
constexpr std::uint16_t kGTRasterTypeGeoKey = 1025;
constexpr std::uint16_t kGTCitationGeoKey = 1026;
constexpr std::uint16_t kGeographicTypeGeoKey = 2048;
constexpr std::uint16_t kGeogAngularUnitsGeoKey = 2054;
constexpr std::uint16_t kProjectedCSTypeGeoKey = 3072;
constexpr std::uint16_t kProjectionGeoKey = 3074;
constexpr std::uint16_t kProjCoordTransGeoKey = 3075;
constexpr std::uint16_t kProjLinearUnitsGeoKey = 3076;
constexpr std::uint16_t kProjFalseEastingGeoKey = 3082;
constexpr std::uint16_t kProjFalseNorthingGeoKey = 3083;
constexpr std::uint16_t kProjCenterLongGeoKey = 3088;
constexpr std::uint16_t kProjCenterLatGeoKey = 3089;

constexpr std::uint16_t kModelTypeProjected = 1;
constexpr std::uint16_t kModelTypeGeographic = 2;
constexpr std::uint16_t kRasterPixelIsArea = 1;
constexpr std::uint16_t kRasterPixelIsPoint = 2;
constexpr std::uint16_t kUserDefined = 32767;
constexpr std::uint16_t kCtOrthographic = 21;
constexpr std::uint16_t kLinearMeter = 9001;
constexpr std::uint16_t kAngularDegree = 9102;
constexpr std::uint16_t kEpsgWgs84 = 4326;
constexpr std::uint16_t kEpsgWebMercator = 3857;

// The GeoKeyDirectory with its double and ASCII parameter stores.
class GeoKeys {
 public:
  void add(std::uint16_t key, std::uint16_t value) { entries_.push_back({key, 0, 1, value}); }
  void add_double(std::uint16_t key, double value) {
    entries_.push_back({key, static_cast<std::uint16_t>(kGeoDoubleParamsTag), 1,
                        static_cast<std::uint16_t>(doubles_.size())});
    doubles_.push_back(value);
  }
  // ASCII parameters are '|'-terminated inside one string; the count includes the '|'.
  void add_text(std::uint16_t key, std::string_view value) {
    entries_.push_back({key, static_cast<std::uint16_t>(kGeoAsciiParamsTag),
                        static_cast<std::uint16_t>(value.size() + 1),
                        static_cast<std::uint16_t>(ascii_.size())});
    ascii_ += value;
    ascii_ += '|';
  }

  // Header (directory version 1, revision 1.0, key count), then the keys in ascending order.
  std::vector<std::uint16_t> directory() const {
    std::vector<std::array<std::uint16_t, 4>> sorted = entries_;
    std::sort(sorted.begin(), sorted.end());
    std::vector<std::uint16_t> out{1, 1, 0, static_cast<std::uint16_t>(sorted.size())};
    for (const auto& entry : sorted) out.insert(out.end(), entry.begin(), entry.end());
    return out;
  }
  const std::vector<double>& doubles() const { return doubles_; }
  const std::string& ascii() const { return ascii_; }

 private:
  std::vector<std::array<std::uint16_t, 4>> entries_;
  std::vector<double> doubles_;
  std::string ascii_;
};

// How raster space maps to model space: tiepoint and pixel scale when the axes are aligned, the
// full affine ModelTransformation when a local scene is rotated against north.
struct Placement {
  std::uint16_t raster_type = kRasterPixelIsArea;
  bool rotated = false;
  std::array<double, 6> tiepoint{};
  std::array<double, 3> pixel_scale{};
  std::array<double, 16> transformation{};
};

Result<Placement> place(const HeightTile& tile, const Georeference& georeference) {
  const TileBounds& w = tile.world;
  const std::int64_t columns = columns_at(tile.scheme, tile.address.z);
  const std::int64_t rows = rows_at(tile.scheme, tile.address.z);
  const double step_x = (w.east - w.west) / static_cast<double>(columns * tile.cells);
  const double step_y = (w.north - w.south) / static_cast<double>(rows * tile.cells);
  const std::int64_t rows_from_north =
      tile.scheme == TileScheme::geographic ? rows - 1 - tile.address.y : tile.address.y;
  const std::int64_t first_column = tile.address.x * tile.cells;
  const std::int64_t first_row = rows_from_north * tile.cells;

  // The tile's own bounds must be where its address puts it in the world.
  const double tolerance_x = 1e-9 * (w.east - w.west);
  const double tolerance_y = 1e-9 * (w.north - w.south);
  const double west = w.west + static_cast<double>(first_column) * step_x;
  const double north = w.north - static_cast<double>(first_row) * step_y;
  if (!(std::abs(tile.bounds.west - west) <= tolerance_x) ||
      !(std::abs(tile.bounds.north - north) <= tolerance_y) ||
      !(std::abs(tile.bounds.east - (west + tile.cells * step_x)) <= tolerance_x) ||
      !(std::abs(tile.bounds.south - (north - tile.cells * step_y)) <= tolerance_y)) {
    return Error{"the tile bounds do not match its address in the world bounds", "/bounds"};
  }

  // Raster (0, 0) is the outer corner of the first pixel for pixel-is-area (the border moves it
  // out by one pixel) and the first sample itself for pixel-is-point; both come from global
  // sample indices as in HeightTile::sample_crs_x/y.
  Placement p;
  double origin_x = west;
  double origin_y = north;
  if (tile.layout == SampleLayout::cell_centres) {
    p.raster_type = kRasterPixelIsArea;
    origin_x = w.west + static_cast<double>(first_column - tile.border) * step_x;
    origin_y = w.north - static_cast<double>(first_row - tile.border) * step_y;
  } else {
    p.raster_type = kRasterPixelIsPoint;
  }

  const auto [c, s] = tile.scheme == TileScheme::local ? cos_sin_degrees(georeference.heading)
                                                       : std::pair{1.0, 0.0};
  p.rotated = s != 0.0 || c != 1.0;
  if (!p.rotated) {
    p.tiepoint = {0.0, 0.0, 0.0, origin_x, origin_y, 0.0};
    p.pixel_scale = {step_x, step_y, 0.0};
    return p;
  }
  // Scene +y points `heading` clockwise from north, scene +x a right angle further, so the scene
  // point (x, y) lies at east = x·cos + y·sin, north = −x·sin + y·cos on the tangent plane; the
  // pixel (i, j) is the scene point (origin_x + i·step_x, origin_y − j·step_y).
  p.transformation = {c * step_x,  -s * step_y, 0.0, c * origin_x + s * origin_y,
                      -s * step_x, -c * step_y, 0.0, -s * origin_x + c * origin_y,
                      0.0,         0.0,         1.0, 0.0,
                      0.0,         0.0,         0.0, 1.0};
  return p;
}

GeoKeys geokeys(const HeightTile& tile, const Georeference& georeference,
                const Placement& placement) {
  GeoKeys keys;
  keys.add(kGTRasterTypeGeoKey, placement.raster_type);
  switch (tile.scheme) {
    case TileScheme::webmercator:
      keys.add(kGTModelTypeGeoKey, kModelTypeProjected);
      keys.add_text(kGTCitationGeoKey, "WGS 84 / Pseudo-Mercator");
      keys.add(kProjectedCSTypeGeoKey, kEpsgWebMercator);
      keys.add(kProjLinearUnitsGeoKey, kLinearMeter);
      break;
    case TileScheme::geographic:
      // GeoTIFF model space is always (longitude, latitude), whatever EPSG's axis order.
      keys.add(kGTModelTypeGeoKey, kModelTypeGeographic);
      keys.add(kGeographicTypeGeoKey, kEpsgWgs84);
      keys.add(kGeogAngularUnitsGeoKey, kAngularDegree);
      break;
    case TileScheme::local:
      // Scene metres are the tangent plane at the georeference: orthographic on WGS 84.
      keys.add(kGTModelTypeGeoKey, kModelTypeProjected);
      keys.add_text(kGTCitationGeoKey, "Terrain scene plane (orthographic on WGS 84)");
      keys.add(kGeographicTypeGeoKey, kEpsgWgs84);
      keys.add(kGeogAngularUnitsGeoKey, kAngularDegree);
      keys.add(kProjectedCSTypeGeoKey, kUserDefined);
      keys.add(kProjectionGeoKey, kUserDefined);
      keys.add(kProjCoordTransGeoKey, kCtOrthographic);
      keys.add(kProjLinearUnitsGeoKey, kLinearMeter);
      keys.add_double(kProjFalseEastingGeoKey, 0.0);
      keys.add_double(kProjFalseNorthingGeoKey, 0.0);
      keys.add_double(kProjCenterLongGeoKey, georeference.longitude);
      keys.add_double(kProjCenterLatGeoKey, georeference.latitude);
      break;
  }
  return keys;
}

// A growable in-memory file behind libtiff's client procedures. libtiff is C: nothing may unwind
// through it, so allocation failures become short writes.
struct MemoryFile {
  Bytes bytes;
  std::uint64_t position = 0;
  std::string error;
};

MemoryFile& memory(thandle_t handle) {
  return *static_cast<MemoryFile*>(handle);
}

tmsize_t memory_read(thandle_t handle, void* buffer, tmsize_t size) {
  MemoryFile& file = memory(handle);
  if (size <= 0 || file.position >= file.bytes.size()) return 0;
  const std::uint64_t n =
      std::min<std::uint64_t>(static_cast<std::uint64_t>(size), file.bytes.size() - file.position);
  std::memcpy(buffer, file.bytes.data() + file.position, n);
  file.position += n;
  return static_cast<tmsize_t>(n);
}

tmsize_t memory_write(thandle_t handle, void* buffer, tmsize_t size) {
  MemoryFile& file = memory(handle);
  if (size < 0) return -1;
  try {
    const std::uint64_t end = file.position + static_cast<std::uint64_t>(size);
    if (end > file.bytes.size()) file.bytes.resize(end);
    if (size > 0) std::memcpy(file.bytes.data() + file.position, buffer, static_cast<size_t>(size));
    file.position = end;
    return size;
  } catch (...) {
    return -1;
  }
}

toff_t memory_seek(thandle_t handle, toff_t offset, int whence) {
  MemoryFile& file = memory(handle);
  const std::uint64_t base = whence == SEEK_CUR   ? file.position
                             : whence == SEEK_END ? file.bytes.size()
                                                  : 0;
  file.position = base + offset;  // unsigned wrap-around is how libtiff passes negative offsets
  return file.position;
}

int memory_close(thandle_t) {
  return 0;
}
toff_t memory_size(thandle_t handle) {
  return memory(handle).bytes.size();
}
int memory_map(thandle_t, void**, toff_t*) {
  return 0;
}
void memory_unmap(thandle_t, void*, toff_t) {}

// libtiff reports through these instead of stderr; the first error is the one worth showing.
int remember_error(TIFF*, void* user_data, const char* module, const char* format, va_list args) {
  MemoryFile& file = memory(user_data);
  try {
    if (file.error.empty()) {
      char message[512];
      std::vsnprintf(message, sizeof message, format, args);
      file.error = (module != nullptr ? std::string(module) + ": " : std::string()) + message;
    }
  } catch (...) {  // NOLINT(bugprone-empty-catch): the write fails anyway, only the text is lost
  }
  return 1;
}

int ignore_warning(TIFF*, void*, const char*, const char*, va_list) {
  return 1;
}

struct TiffCloser {
  void operator()(TIFF* tiff) const { TIFFClose(tiff); }
};
struct OpenOptionsFree {
  void operator()(TIFFOpenOptions* options) const { TIFFOpenOptionsFree(options); }
};

Result<Bytes> write_geotiff(const HeightTile& tile, const Placement& placement,
                            const GeoKeys& keys) {
  MemoryFile file;
  const auto fail = [&file](std::string what) {
    return Error{"cannot encode GeoTIFF: " + what + (file.error.empty() ? "" : ": " + file.error),
                 ""};
  };
  std::unique_ptr<TIFFOpenOptions, OpenOptionsFree> options(TIFFOpenOptionsAlloc());
  if (!options) return fail("out of memory");
  TIFFOpenOptionsSetErrorHandlerExtR(options.get(), remember_error, &file);
  TIFFOpenOptionsSetWarningHandlerExtR(options.get(), ignore_warning, nullptr);
  // "l": little-endian whatever the host, so that every machine writes the same bytes.
  std::unique_ptr<TIFF, TiffCloser> tiff(
      TIFFClientOpenExt("tile.tif", "wl", &file, memory_read, memory_write, memory_seek,
                        memory_close, memory_size, memory_map, memory_unmap, options.get()));
  if (!tiff) return fail("cannot open a TIFF writer");
  TIFF* t = tiff.get();
  if (TIFFMergeFieldInfo(t, kGeoTiffFields,
                         static_cast<std::uint32_t>(std::size(kGeoTiffFields))) != 0) {
    return fail("cannot register the GeoTIFF tags");
  }

  const auto width = static_cast<std::uint32_t>(tile.width);
  const auto height = static_cast<std::uint32_t>(tile.height);
  // About 64 KiB per strip: small enough for readers that decode strip by strip.
  const std::uint32_t rows_per_strip = std::clamp<std::uint32_t>(16384 / width, 1, height);
  const std::vector<std::uint16_t> directory = keys.directory();
  // No DateTime or Software tag, so the bytes depend on the tile alone. No GDAL_NODATA either:
  // every sample is a finite height (others are refused), so no value means "no data".
  bool ok = TIFFSetField(t, TIFFTAG_IMAGEWIDTH, width) == 1 &&
            TIFFSetField(t, TIFFTAG_IMAGELENGTH, height) == 1 &&
            TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 1) == 1 &&
            TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 32) == 1 &&
            TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_IEEEFP) == 1 &&
            TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK) == 1 &&
            TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG) == 1 &&
            TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE) == 1 &&
            // The floating-point predictor makes smooth heights compress about twice as well.
            TIFFSetField(t, TIFFTAG_PREDICTOR, PREDICTOR_FLOATINGPOINT) == 1 &&
            TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, rows_per_strip) == 1 &&
            TIFFSetField(t, kGeoKeyDirectoryTag, static_cast<int>(directory.size()),
                         directory.data()) == 1;
  if (ok && placement.rotated) {
    ok = TIFFSetField(t, kModelTransformationTag, 16, placement.transformation.data()) == 1;
  } else if (ok) {
    ok = TIFFSetField(t, kModelPixelScaleTag, 3, placement.pixel_scale.data()) == 1 &&
         TIFFSetField(t, kModelTiepointTag, 6, placement.tiepoint.data()) == 1;
  }
  if (ok && !keys.doubles().empty()) {
    ok = TIFFSetField(t, kGeoDoubleParamsTag, static_cast<int>(keys.doubles().size()),
                      keys.doubles().data()) == 1;
  }
  if (ok && !keys.ascii().empty()) {
    ok = TIFFSetField(t, kGeoAsciiParamsTag, keys.ascii().c_str()) == 1;
  }
  if (!ok) return fail("cannot set the TIFF tags");

  // libtiff's predictor works in place, so each strip is handed over as a copy.
  std::vector<float> strip(static_cast<std::size_t>(rows_per_strip) * width);
  for (std::uint32_t row = 0, index = 0; row < height; row += rows_per_strip, ++index) {
    const std::uint32_t rows = std::min(rows_per_strip, height - row);
    const std::size_t count = static_cast<std::size_t>(rows) * width;
    std::copy_n(tile.elevation.begin() + static_cast<std::ptrdiff_t>(row * width), count,
                strip.begin());
    if (TIFFWriteEncodedStrip(t, index, strip.data(),
                              static_cast<tmsize_t>(count * sizeof(float))) < 0) {
      return fail("cannot write strip " + std::to_string(index));
    }
  }
  if (TIFFFlush(t) != 1) return fail("cannot write the TIFF directory");
  tiff.reset();
  if (!file.error.empty()) return fail("libtiff reported an error");
  return std::move(file.bytes);
}

}  // namespace

Result<std::vector<std::uint8_t>> encode_terrain_rgb(const HeightTile& tile) {
  return guarded("cannot encode terrain-RGB", [&] {
    return encode_24bit(
        tile, [](double h) { return quantise((h - kTerrainRgbLowest) * 10.0, kMax24BitCode); });
  });
}

Result<std::vector<std::uint8_t>> encode_terrarium(const HeightTile& tile) {
  return guarded("cannot encode Terrarium", [&] {
    return encode_24bit(
        tile, [](double h) { return quantise((h - kTerrariumLowest) * 256.0, kMax24BitCode); });
  });
}

Gray16Encoding gray16_encoding_for(Interval elevation_range) {
  double lo = elevation_range.lo;
  double hi = elevation_range.hi;
  if (elevation_range.empty() || !std::isfinite(lo) || !std::isfinite(hi)) lo = hi = 0.0;
  // 1, 2, 5 · 10^e from a millimetre up; the widest float range needs e ≈ 34, so this ends.
  for (int exponent = -3; exponent < 300; ++exponent) {
    for (const double mantissa : {1.0, 2.0, 5.0}) {
      // k·mantissa / 10^−e is the double nearest the decimal k·scale (0.001, 0.002, -12.32, ...),
      // where k·scale with scale already rounded would drift off it.
      const auto multiple = [&](double steps) {
        return exponent < 0 ? steps * mantissa / std::pow(10.0, -exponent)
                            : steps * mantissa * std::pow(10.0, exponent);
      };
      const double scale = multiple(1.0);
      // lo / scale is rounded, so its floor may be one step off either way.
      double k = std::floor(lo / scale);
      if (multiple(k + 1.0) <= lo) {
        k += 1.0;
      } else if (multiple(k) > lo) {
        k -= 1.0;
      }
      const double offset = multiple(k);
      if (offset + static_cast<double>(kMax16BitCode) * scale >= hi) return {offset, scale};
    }
  }
  return {lo, 1.0};  // unreachable for float ranges
}

Result<std::vector<std::uint8_t>> encode_gray16(const HeightTile& tile,
                                                const Gray16Encoding& encoding) {
  return guarded("cannot encode 16-bit grey", [&]() -> Result<Bytes> {
    if (!std::isfinite(encoding.offset)) {
      return Error{"the gray16 offset must be finite", "/gray16/offset"};
    }
    if (!std::isfinite(encoding.scale) || !(encoding.scale > 0.0)) {
      return Error{"the gray16 scale must be finite and positive, not " + text(encoding.scale),
                   "/gray16/scale"};
    }
    if (Status ok = check_heights(tile); !ok) return ok.error();
    std::vector<std::uint16_t> codes(sample_count(tile));
    for (std::size_t i = 0; i < codes.size(); ++i) {
      const double h = tile.elevation[i];
      codes[i] = static_cast<std::uint16_t>(
          quantise((h - encoding.offset) / encoding.scale, kMax16BitCode));
    }
    return encode_png16(tile.width, tile.height, codes.data());
  });
}

Result<std::vector<std::uint8_t>> encode_geotiff(const HeightTile& tile,
                                                 const Georeference& georeference) {
  return guarded("cannot encode GeoTIFF", [&]() -> Result<Bytes> {
    if (Status ok = check_heights(tile); !ok) return ok.error();
    if (Status ok = check_placement(tile); !ok) return ok.error();
    if (tile.scheme == TileScheme::local) {
      if (Status ok = check_georeference(georeference); !ok) return ok.error();
    }
    Result<Placement> placement = place(tile, georeference);
    if (!placement) return placement.error();
    return write_geotiff(tile, *placement, geokeys(tile, georeference, *placement));
  });
}

Result<std::vector<std::uint8_t>> encode_normal_map(const HeightTile& tile) {
  return guarded("cannot encode normal map", [&]() -> Result<Bytes> {
    if (Status ok = check_slopes(tile); !ok) return ok.error();
    Bytes rgb(sample_count(tile) * 3);
    for (std::size_t i = 0; i < sample_count(tile); ++i) {
      const double nx = -static_cast<double>(tile.slope_east[i]);
      const double ny = -static_cast<double>(tile.slope_north[i]);
      const double length = std::sqrt(nx * nx + ny * ny + 1.0);
      rgb[3 * i] = to_byte((nx / length + 1.0) * 0.5 * 255.0);
      rgb[3 * i + 1] = to_byte((ny / length + 1.0) * 0.5 * 255.0);
      rgb[3 * i + 2] = to_byte((1.0 / length + 1.0) * 0.5 * 255.0);
    }
    return encode_png_rgb8(tile.width, tile.height, rgb.data());
  });
}

Result<std::vector<std::uint8_t>> encode_hillshade(const HeightTile& tile,
                                                   const HillshadeOptions& options) {
  return guarded("cannot encode hillshade", [&]() -> Result<Bytes> {
    if (!std::isfinite(options.azimuth_deg)) {
      return Error{"the light azimuth must be finite", "/hillshade/azimuth_deg"};
    }
    if (!(options.altitude_deg >= 0.0 && options.altitude_deg <= 90.0)) {
      return Error{
          "the light altitude must be in [0, 90] degrees, not " + text(options.altitude_deg),
          "/hillshade/altitude_deg"};
    }
    if (!std::isfinite(options.z_factor) || !(options.z_factor > 0.0)) {
      return Error{"z_factor must be finite and positive, not " + text(options.z_factor),
                   "/hillshade/z_factor"};
    }
    if (Status ok = check_slopes(tile); !ok) return ok.error();
    // Towards the light: azimuth clockwise from north in the east-north plane, raised by the
    // altitude.
    const auto [cos_azimuth, sin_azimuth] = cos_sin_degrees(options.azimuth_deg);
    const auto [cos_altitude, sin_altitude] = cos_sin_degrees(options.altitude_deg);
    const double lx = sin_azimuth * cos_altitude;
    const double ly = cos_azimuth * cos_altitude;
    const double lz = sin_altitude;
    Bytes shade(sample_count(tile));
    for (std::size_t i = 0; i < shade.size(); ++i) {
      const double nx = -options.z_factor * static_cast<double>(tile.slope_east[i]);
      const double ny = -options.z_factor * static_cast<double>(tile.slope_north[i]);
      const double length = std::sqrt(nx * nx + ny * ny + 1.0);
      const double lit = (nx * lx + ny * ly + lz) / length;
      shade[i] = to_byte(255.0 * std::max(0.0, lit));
    }
    return encode_png_gray8(tile.width, tile.height, shade.data());
  });
}

}  // namespace terrain
