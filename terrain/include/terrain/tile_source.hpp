// Height tiles from a scene: where each sample of a tile address lies in the scene's plane, and
// the evaluation of the compiled program there at the level of detail the tile's spacing asks for.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "terrain/evaluate.hpp"
#include "terrain/material.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"
#include "terrain/sphere_trace.hpp"
#include "terrain/tile.hpp"

namespace terrain {

/// Maps points of the WGS84 ellipsoid to the scene plane: the plane is tangent to the ellipsoid
/// at the georeference point (latitude, longitude, height 0), a point's scene position is its
/// east/north offset in that plane (GeographicLib's local-cartesian frame with the "up" component
/// dropped, i.e. an orthographic projection), rotated so that scene +y points `heading` degrees
/// clockwise from north. Distances within 100 km of the origin are kept to better than 0.1 %.
class GeoFrame {
 public:
  explicit GeoFrame(const Georeference& georeference);

  /// Angular distance from the origin beyond which points are not mapped: the orthographic
  /// projection folds the far side of the globe onto the near side, so positions there would
  /// repeat the scene. Such points lie at the scene's base level.
  static constexpr double kMaxAngleDegrees = 60.0;

  /// Scene position of (latitude, longitude) in degrees; false beyond kMaxAngleDegrees.
  bool to_scene(double latitude, double longitude, double& x, double& y) const;
  /// Latitude and longitude (degrees) of a scene position: the ellipsoid point that projects to
  /// it, on the near side.
  void to_geographic(double x, double y, double& latitude, double& longitude) const;

  /// Rotates a scene-plane gradient (∂/∂x, ∂/∂y) into (∂/∂east, ∂/∂north).
  void scene_to_east_north(float gx, float gy, float& east, float& north) const;

  const Georeference& georeference() const { return georeference_; }

 private:
  friend class TileGenerator;
  struct Row {         // the per-latitude part of a geodetic → ECEF conversion (height 0)
    double cos_lat_n;  // N(φ) cos φ
    double z;          // N(φ)(1 − e²) sin φ
  };
  Row row(double latitude) const;
  bool project(const Row& r, double cos_lon, double sin_lon, double& x, double& y) const;

  Georeference georeference_;
  double origin_[3];  // ECEF of the origin
  double east_[3], north_[3], up_[3];
  double cos_heading_ = 1.0, sin_heading_ = 0.0;
  double min_up_ = 0.0;  // "up" offset at kMaxAngleDegrees
};

/// What a scene's tiles are made of.
struct TileSource {
  std::shared_ptr<const Program> terrain;
  std::shared_ptr<const Program> water;  ///< the scene's water layer, or null
  TileBounds local_square;  ///< the local scheme's zoom-0 tile: the scene's area made square
  Georeference georeference;
  Material material;  ///< the scene's, for colour tiles
  float base_elevation = 0.0f;
  Interval elevation_range;  ///< a bound of every tile's heights (with the base level)

  /// Compiles the scene's terrain and water trees.
  static Result<TileSource> from_scene(const Scene& scene);
};

/// What to sample.
struct TileRequest {
  TileScheme scheme = TileScheme::local;
  TileAddress address;
  SampleLayout layout = SampleLayout::cell_centres;
  int cells = 256;  ///< cell_centres: 256 or 512 (also 64, 128); cell_corners: 2..512, 2^k
  int border = 0;   ///< cell_centres only
};

/// A tile with the request's scheme, address, sample layout and size set, and nothing else
/// (bounds, spacing and samples are the producer's).
HeightTile tile_layout_for(const TileRequest& request);

/// Checks the address and the sizes; the error's pointer names the field ("/z", "/cells", ...).
Status validate_request(const TileRequest& request);

/// The zoom-0 footprint of a scheme in its own coordinates (local: the source's square).
TileBounds world_bounds(const TileSource& source, TileScheme scheme);

/// Metres between neighbouring samples of a tile at zoom z with `cells` cells per side: the
/// level of detail. It depends on (scheme, z, cells) only, never on the tile's position, so that
/// neighbours evaluate shared samples at the same level of detail (webmercator and geographic
/// use the ground spacing at the georeference latitude).
double ground_spacing(const TileSource& source, TileScheme scheme, int z, int cells);

/// A tile range at one zoom level, inclusive.
struct TileRange {
  std::int64_t min_x = 0, min_y = 0, max_x = -1, max_y = -1;
};
/// The tiles at zoom z whose footprint meets the scene's area (its extent, or its support), in
/// the scheme's own numbering; empty when the area lies outside the scheme's world.
TileRange tiles_covering_area(const TileSource& source, TileScheme scheme, int z);

/// Another evaluator of compiled programs (the GPU backend in gpu/ implements it): terrain only
/// knows this interface. The CPU interpreter stays the reference and the fallback.
class PointsBackend {
 public:
  virtual ~PointsBackend() = default;
  /// Names the backend in tiles' provenance and metrics ("gpu: NVIDIA H200 …").
  virtual std::string name() const = 0;
  /// f and ∇f of `program` at (x[i], y[i]) at level of detail `spacing`. An error (unsupported
  /// node type, lost context, ...) makes the caller evaluate on the CPU instead.
  virtual Status evaluate(const Program& program, std::span<const float> x,
                          std::span<const float> y, float spacing, float* f, float* fx,
                          float* fy) = 0;
  /// The picture terrain::render draws for the same arguments (within float rounding of the
  /// shading). An error (no tracer, unsupported node type, lost context, ...) makes the caller
  /// render on the CPU instead; backends without a tracer keep this default.
  virtual Result<Picture> render(const Program& program, const Box2& area, const Camera& camera,
                                 const RenderOptions& options) {
    static_cast<void>(program);
    static_cast<void>(area);
    static_cast<void>(camera);
    static_cast<void>(options);
    return Error{name() + " does not render pictures", ""};
  }
};

/// Generates tiles. Holds evaluators, so it is not thread-safe: use one per thread.
class TileGenerator {
 public:
  explicit TileGenerator(TileSource source);

  /// Evaluates tile heights with `backend` when it can, else on the CPU (null: CPU only). The
  /// backend is shared and must be thread-safe.
  void set_backend(std::shared_ptr<PointsBackend> backend) { backend_ = std::move(backend); }
  /// What produced the last tile: "cpu", the backend's name, or "cpu (fallback: why)".
  const std::string& last_backend() const { return last_backend_; }

  const TileSource& source() const { return source_; }

  /// Heights and slopes of a tile. Slopes are with respect to east and north; in the local
  /// scheme "east" and "north" are the scene's +x and +y.
  Result<HeightTile> height_tile(const TileRequest& request);

  /// The water mask of a tile for quantized-mesh: 256×256 bytes, row 0 north, 255 where the
  /// water layer has weight ≥ 0.5 and lies above the terrain, else 0; collapsed to one byte when
  /// the whole tile is land (0) or water (255). A scene without a water layer gives {0}.
  Result<std::vector<std::uint8_t>> water_mask(TileScheme scheme, const TileAddress& address);

  /// height_tile, also giving `water_surface`: per sample, the water layer's surface where its
  /// weight is at least 0.5 (the sample is under water where that lies above the ground, as in
  /// water_mask), else NaN; empty when the scene has no water layer. Where the water tree's
  /// bounds over a block of samples say its surface lies more than `depth_of_interest` below
  /// all their ground (or its weight stays under 0.5), the block is not evaluated and gets NaN:
  /// what only compares the surface with the ground, or a shore band above it, is the same.
  Result<HeightTile> height_tile_with_water(const TileRequest& request,
                                            std::vector<float>& water_surface,
                                            float depth_of_interest = INFINITY);

 private:
  // height_tile, also giving which samples the frame maps (0 where it does not reach).
  Result<HeightTile> height_tile(const TileRequest& request, std::vector<std::uint8_t>& mapped);
  // Scene positions of every sample; `mapped` is 0 where the frame does not reach.
  void place_samples(HeightTile& tile, std::vector<std::uint8_t>& mapped) const;
  // Evaluates a tree at the mapped samples, 8×8 blocks at a time. With `skip`, blocks it
  // returns true for are left as they are.
  using BlockFilter = std::function<bool(const PointBlock& block, const int* index)>;
  void evaluate(Evaluator& evaluator, const HeightTile& tile,
                const std::vector<std::uint8_t>& mapped, float spacing,
                std::vector<float>& elevation, std::vector<float>* gx, std::vector<float>* gy,
                std::vector<float>* weight, const BlockFilter& skip = nullptr);

  bool evaluate_on_backend(const HeightTile& tile, const std::vector<std::uint8_t>& mapped,
                           std::vector<float>& elevation, std::vector<float>& gx,
                           std::vector<float>& gy);

  TileSource source_;
  GeoFrame frame_;
  Evaluator terrain_;
  std::shared_ptr<PointsBackend> backend_;
  std::string last_backend_ = "cpu";
  std::unique_ptr<Evaluator> water_;
};

}  // namespace terrain
