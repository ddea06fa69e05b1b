// GeoTIFF 1.0 writer (docs/tile-encodings.md#geotiff), with libtiff directly: OpenImageIO 2.4's
// TIFF writer sets only a fixed list of baseline and Exif tags from ImageSpec attributes and
// silently drops everything else, so the GeoTIFF tags (ModelPixelScale, ModelTiepoint,
// ModelTransformation, GeoKeyDirectory, ...) cannot reach the file through it.
#include "terrain/geotiff.hpp"

#include <tiffio.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>

#include "terrain/scene.hpp"
#include "terrain/tile_image.hpp"
#include "tile_encoding_checks.hpp"

namespace terrain {
namespace {

using namespace tile_encoding;  // NOLINT(google-build-using-namespace): the shared checks

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

// How raster space maps to model space: tiepoint and pixel scale when the axes are aligned, the
// full affine ModelTransformation when a local scene is rotated against north.
struct Placement {
  std::uint16_t raster_type = geokey::kRasterPixelIsArea;
  bool rotated = false;
  std::array<double, 6> tiepoint{};
  std::array<double, 3> pixel_scale{};
  std::array<double, 16> transformation{};
};

// Raster (0, 0) at scene point (origin_x, origin_y), columns growing by step_x along scene +x and
// rows by step_y along scene −y, on a plane whose +y points `heading` clockwise from north.
Placement placed(std::uint16_t raster_type, double origin_x, double origin_y, double step_x,
                 double step_y, double heading) {
  Placement p;
  p.raster_type = raster_type;
  const auto [c, s] = cos_sin_degrees(heading);
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
  std::uint16_t raster_type = geokey::kRasterPixelIsPoint;
  double origin_x = west;
  double origin_y = north;
  if (tile.layout == SampleLayout::cell_centres) {
    raster_type = geokey::kRasterPixelIsArea;
    origin_x = w.west + static_cast<double>(first_column - tile.border) * step_x;
    origin_y = w.north - static_cast<double>(first_row - tile.border) * step_y;
  }
  const double heading = tile.scheme == TileScheme::local ? georeference.heading : 0.0;
  return placed(raster_type, origin_x, origin_y, step_x, step_y, heading);
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

Result<Bytes> write_geotiff(std::uint32_t width, std::uint32_t height, const float* samples,
                            const Placement& placement, const GeoKeyDirectory& keys) {
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

  // About 64 KiB per strip: small enough for readers that decode strip by strip.
  const std::uint32_t rows_per_strip = std::clamp<std::uint32_t>(16384 / width, 1, height);
  const std::vector<std::uint16_t> directory = keys.directory();
  // No DateTime or Software tag, so the bytes depend on the samples alone. No GDAL_NODATA either:
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
    std::copy_n(samples + static_cast<std::ptrdiff_t>(row) * width, count, strip.begin());
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

void GeoKeyDirectory::add(std::uint16_t key, std::uint16_t value) {
  entries_.push_back({key, 0, 1, value});
}

void GeoKeyDirectory::add_double(std::uint16_t key, double value) {
  entries_.push_back(
      {key, geokey::kGeoDoubleParamsTag, 1, static_cast<std::uint16_t>(doubles_.size())});
  doubles_.push_back(value);
}

void GeoKeyDirectory::add_text(std::uint16_t key, std::string_view value) {
  entries_.push_back({key, geokey::kGeoAsciiParamsTag, static_cast<std::uint16_t>(value.size() + 1),
                      static_cast<std::uint16_t>(ascii_.size())});
  ascii_ += value;
  ascii_ += '|';
}

std::vector<std::uint16_t> GeoKeyDirectory::directory() const {
  std::vector<std::array<std::uint16_t, 4>> sorted = entries_;
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::uint16_t> out{1, 1, 0, static_cast<std::uint16_t>(sorted.size())};
  for (const auto& entry : sorted) out.insert(out.end(), entry.begin(), entry.end());
  return out;
}

GeoKeyDirectory geotiff_crs_keys(TileScheme scheme, const Georeference& georeference,
                                 std::uint16_t raster_type) {
  GeoKeyDirectory keys;
  keys.add(geokey::kRasterType, raster_type);
  switch (scheme) {
    case TileScheme::webmercator:
      keys.add(geokey::kModelType, geokey::kModelTypeProjected);
      keys.add_text(geokey::kCitation, "WGS 84 / Pseudo-Mercator");
      keys.add(geokey::kProjectedCSType, geokey::kEpsgWebMercator);
      keys.add(geokey::kProjLinearUnits, geokey::kLinearMeter);
      break;
    case TileScheme::geographic:
      // GeoTIFF model space is always (longitude, latitude), whatever EPSG's axis order.
      keys.add(geokey::kModelType, geokey::kModelTypeGeographic);
      keys.add(geokey::kGeographicType, geokey::kEpsgWgs84);
      keys.add(geokey::kGeogAngularUnits, geokey::kAngularDegree);
      break;
    case TileScheme::local:
      // Scene metres are the tangent plane at the georeference: orthographic on WGS 84.
      keys.add(geokey::kModelType, geokey::kModelTypeProjected);
      keys.add_text(geokey::kCitation, "Terrain scene plane (orthographic on WGS 84)");
      keys.add(geokey::kGeographicType, geokey::kEpsgWgs84);
      keys.add(geokey::kGeogAngularUnits, geokey::kAngularDegree);
      keys.add(geokey::kProjectedCSType, geokey::kUserDefined);
      keys.add(geokey::kProjection, geokey::kUserDefined);
      keys.add(geokey::kProjCoordTrans, geokey::kCtOrthographic);
      keys.add(geokey::kProjLinearUnits, geokey::kLinearMeter);
      keys.add_double(geokey::kProjFalseEasting, 0.0);
      keys.add_double(geokey::kProjFalseNorthing, 0.0);
      keys.add_double(geokey::kProjCenterLong, georeference.longitude);
      keys.add_double(geokey::kProjCenterLat, georeference.latitude);
      break;
  }
  return keys;
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
    return write_geotiff(static_cast<std::uint32_t>(tile.width),
                         static_cast<std::uint32_t>(tile.height), tile.elevation.data(), *placement,
                         geotiff_crs_keys(tile.scheme, georeference, placement->raster_type));
  });
}

Result<std::vector<std::uint8_t>> encode_scene_plane_geotiff(const float* north_up, int columns,
                                                             int rows, double first_x,
                                                             double first_y, double step,
                                                             const Georeference& georeference) {
  return guarded("cannot encode GeoTIFF", [&]() -> Result<Bytes> {
    if (north_up == nullptr || columns < 1 || rows < 1 || columns > kMaxCells || rows > kMaxCells) {
      return Error{
          "a scene-plane GeoTIFF has 1.." + std::to_string(kMaxCells) + " samples per side",
          "/size"};
    }
    if (!std::isfinite(first_x) || !std::isfinite(first_y) || !(step > 0.0) ||
        !std::isfinite(step)) {
      return Error{"the first sample and the step must be finite, the step positive", "/step"};
    }
    const std::size_t count = static_cast<std::size_t>(columns) * static_cast<std::size_t>(rows);
    for (std::size_t i = 0; i < count; ++i) {
      if (!std::isfinite(north_up[i])) {
        return Error{"sample " + std::to_string(i) + " is not finite",
                     "/elevation/" + std::to_string(i)};
      }
    }
    if (Status ok = check_georeference(georeference); !ok) return ok.error();
    const Placement placement =
        placed(geokey::kRasterPixelIsPoint, first_x, first_y, step, step, georeference.heading);
    return write_geotiff(
        static_cast<std::uint32_t>(columns), static_cast<std::uint32_t>(rows), north_up, placement,
        geotiff_crs_keys(TileScheme::local, georeference, geokey::kRasterPixelIsPoint));
  });
}

}  // namespace terrain
