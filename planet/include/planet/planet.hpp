// A planet: its definition, base mesh and geodesy, and the height function every product
// samples. The height at a point for a given level of detail is computed locally (the mesh
// hierarchy descended to the point, then Schneider's fractal detail below the mesh's finest
// edge), so it never depends on
// what else was evaluated, in what order or on which thread.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "planet/base_mesh.hpp"
#include "planet/continent_map.hpp"
#include "planet/definition.hpp"
#include "planet/geodesy.hpp"
#include "planet/smooth_surface.hpp"
#include "terrain/math.hpp"

namespace planet {

namespace detail {
struct DetailOctaves;
struct WarpOctaves;
}  // namespace detail

/// What lies at a point (the `type` of sample?lat=&lon=). `lake`: under a lake's water.
enum class SurfaceType { sea, coast, land, river, lake };
std::string_view surface_name(SurfaceType type);

struct PointSample {
  double ground = 0.0;  ///< metres above the reference surface (sea level is the definition's)
  double water = 0.0;   ///< the water surface where submerged, else equal to ground
  SurfaceType type = SurfaceType::land;
  int level = 0;  ///< mesh level the point was evaluated at
  /// Metres to the nearest river edge of the triangle holding the point (infinity if none): lets
  /// pictures draw rivers narrower than a pixel.
  double river_distance = 0.0;
  /// The area (m²) that river drains (Vertex::drainage_area; 0 if none): lets pictures draw
  /// trunks wider than headwaters.
  double river_drainage_area = 0.0;
};

class Planet {
 public:
  /// Builds the base mesh (the expensive part, tens of milliseconds) of a definition without a
  /// continent map. A definition that names one needs its pixels (build): null is returned.
  static std::shared_ptr<const Planet> create(const PlanetDefinition& definition,
                                              const BuildOptions& options = {});
  /// Builds the planet with its continent map, or without one (null): refused, naming
  /// "/continent_map", when the definition names a map and none is given, a map is given for a
  /// definition that names none, the map's hash is not the one named (a map made in memory,
  /// with an empty hash, is taken as the caller vouches), or the map is invalid.
  static Result<std::shared_ptr<const Planet>> build(const PlanetDefinition& definition,
                                                     const ContinentMap* map,
                                                     const BuildOptions& options = {});
  /// Parses, validates and builds; errors name the field (see parse_planet). A definition that
  /// names a continent map is refused (its pixels are not in the JSON: parse, decode, build).
  static Result<std::shared_ptr<const Planet>> from_json(const nlohmann::json& document);

  const PlanetDefinition& definition() const { return base_->rules.def; }
  const std::string& id() const { return id_; }
  const BaseMesh& base_mesh() const { return *base_; }
  const Rules& rules() const { return base_->rules; }
  const Geodesy& geodesy() const { return geodesy_; }

  /// The mesh level for samples `spacing` metres apart: leaf edges about two samples long,
  /// between the base mesh's level and the finest (finest_edge).
  int level_for_spacing(double spacing) const;
  /// Schneider's visible octave count for that spacing (fractional; wavelengths ≥ 2 samples).
  double octaves_for_spacing(double spacing) const;
  /// Metres between the rows of a geographic tile at zoom z with `cells` cells: the LoD of every
  /// tile at (z, cells), wherever it lies, so that neighbours sample alike.
  double ground_spacing(int z, int cells) const;
  /// How far the surface at the level of detail of `spacing` may rise between samples that far
  /// apart above their interpolation: the refinement's displacement and drain rise at the
  /// level's edge length (an estimate, not a bound: the mesh tiles' error allowance).
  double relief_between_samples(double spacing) const;
  /// A bound of every height the planet produces (samples are clamped into it).
  terrain::Interval elevation_range() const;

  /// The fractal detail at direction p before its weight: Σ_k a_k (1 + S(p r^k / λ))/2 ≥ 0
  /// over the octaves shorter than finest_edge (the mesh carries the longer ones), so it only
  /// ever raises the ground (water stays in its bed, coasts stay coasts).
  double detail(const Vec3d& direction, double octaves) const;
  /// Whether `octaves` reach below finest_edge, where the noise has octaves to sum (else detail
  /// is 0 everywhere).
  bool has_detail_octaves(double octaves) const;
  /// The same at many directions, into out[0, directions.size()): the same bits, several at
  /// once where the CPU has vectors for it.
  void detail(std::span<const Vec3d> directions, double octaves, std::span<double> out) const;
  /// The direction every sample at `direction` and `level` is evaluated at: moved by the
  /// definition's domain warp (planet.md "Winding valleys"), whose octaves reach down to four
  /// edges of the level; `direction` itself without a warp.
  Vec3d warp(const Vec3d& direction, int level) const;
  /// Whether warp() moves any direction at `level`.
  bool warps(int level) const;
  /// The warp's octaves at `level` (warp.hpp), for moving many directions at once.
  const detail::WarpOctaves& warp_octaves(int level) const;

  ~Planet();

 private:
  Planet(const PlanetDefinition& definition, const BuildOptions& options, const ContinentMap* map);
  detail::DetailOctaves detail_octaves(double octaves) const;
  std::unique_ptr<BaseMesh> base_;
  Geodesy geodesy_;
  std::string id_;
  // Constants of every sample, computed once (the same expressions the samples used to
  // evaluate each time, so the same values).
  terrain::Interval elevation_range_;
  double detail_gain_ = 0.0;
  std::uint32_t detail_seed_ = 0;
  int first_detail_octave_ = 0;  ///< octaves before it are left to the mesh
  double first_detail_amplitude_ = 0.0, first_detail_frequency_ = 0.0;  ///< of that octave
  std::vector<detail::WarpOctaves> warp_by_level_;  ///< the warp's octaves at each level
};

/// Where a group of nearby samples may start their descent instead of the octahedron: a
/// triangle of the sampler's hierarchy and its edges' planes. Levels are triangulations whose
/// children are the sectors of their diamond, so the descent of a point at level k ends in the
/// level-k triangle that holds it; a point inside this triangle by a margin therefore descends
/// through it, and starting there gives the same leaf, bit for bit. The edges' planes are the
/// descent's own determinants: every edge of a triangle was a ray m→X of the split that made it,
/// which the descent tested as det(m, X, p) = dot(cross(m, X), p), and cross(X, m) is its exact
/// negation (no FMA contraction), so any positive margin agrees with the descent's signs; the
/// margin only leaves out points on an edge, where the descent's half-open tests decide.
/// (It was 1e-12 until 2026-12-05: a determinant shrinks with the edge's length, e·d/R², so
/// that margin left out a band 0.3 m wide along 150 m edges and 4 m along the finest, 10 m
/// edges, which no point then cleared.)
struct DescentStart {
  std::int32_t tri = -1;         ///< −1: none (every point starts at the root)
  std::uint64_t generation = 0;  ///< the sampler's trim count when it was found
  int level = 0;
  std::array<Vec3d, 3> normal{};  ///< cross(v_k, v_k+1): p is inside when every dot is > margin
  /// A few roundings of a determinant of unit vectors: 4 mm along the finest, 10 m edges.
  static constexpr double kMargin = 1e-15;
  bool holds(const Vec3d& p) const {
    return tri >= 0 && dot(normal[0], p) > kMargin && dot(normal[1], p) > kMargin &&
           dot(normal[2], p) > kMargin;
  }
};

/// A grid of directions for Sampler::grid, laid out as tiles are: `rows` × `cols`, row-major,
/// row r at geodetic latitude latitude[r] (non-increasing with r) and column c at longitude[c]
/// (increasing with c; may run past ±180°), with their sines and cosines (the longitude's of
/// the wrapped angle): the sample is Geodesy::direction(sin_lat[r], cos_lat[r], sin_lon[c],
/// cos_lon[c]).
struct SampleGrid {
  int rows = 0, cols = 0;
  std::span<const double> latitude, longitude;  ///< degrees
  std::span<const double> sin_lat, cos_lat, sin_lon, cos_lon;
};

/// Where Sampler::grid puts each sample: its index (row · cols + column) and the sample.
using GridSink = std::function<void(std::size_t index, const PointSample& sample)>;

/// Evaluates points of one planet. Keeps the refined hierarchy between calls as a cache (results
/// never depend on it); not thread-safe: one per thread.
class Sampler {
 public:
  /// `trim_bound`: past this many cached triangles a sample or grid first trims the cache back
  /// to the base mesh (bounded memory for long-lived samplers; results never depend on it).
  explicit Sampler(std::shared_ptr<const Planet> planet, std::size_t trim_bound = kTrimTriangles);

  const Planet& planet() const { return *planet_; }

  /// At full detail (the finest level, detail down to a centimetre).
  PointSample sample(double latitude, double longitude);
  /// At the level of detail of samples `spacing` metres apart.
  PointSample sample(double latitude, double longitude, double spacing);
  /// At a direction, mesh level and octave count. The descent starts from the last one's leaf
  /// or path where they hold the direction (identical results: see DescentStart).
  PointSample at(const Vec3d& direction, int level, double octaves);
  /// The same, descending from `start` when neither does and it holds the direction.
  PointSample at(const Vec3d& direction, int level, double octaves, const DescentStart& start);
  /// The same, descending from the octahedron as a lone sample does: what every start, path and
  /// walk must agree with, bit for bit (the tests' reference).
  PointSample at_from_root(const Vec3d& direction, int level, double octaves);
  /// Many samples, into out[0, directions.size()): each what at(direction, level, octaves,
  /// start) gives, bit for bit, with the detail noise of all of them computed together (several
  /// at once where the CPU has vectors for it).
  void at(std::span<const Vec3d> directions, int level, double octaves, const DescentStart& start,
          std::span<PointSample> out);
  /// Every sample of a grid, handed to `out` with its index: each what at(direction, level,
  /// octaves) gives, bit for bit, computed together (descents started per block, the detail noise
  /// batched, the drainage model's floors drawn edge by edge instead of walked to per sample).
  void grid(const SampleGrid& grid, int level, double octaves, const GridSink& out);
  /// The deepest triangle, at most `level`, on the way down to `centre` that holds every one
  /// of `points` by the margin: a start for the samples in and around them.
  DescentStart descent_start(const Vec3d& centre, std::span<const Vec3d> points, int level);

  /// Triangles in the cache; trim() drops everything beyond the base mesh.
  std::size_t cached_triangles() const { return hierarchy_.tris.size(); }
  /// The default trim bound (planet.cpp says why this many).
  static constexpr std::size_t kTrimTriangles = std::size_t{1} << 20;
  void trim();

 private:
  /// A sample before its detail noise, and what adding it needs.
  struct Undetailed {
    PointSample out;  ///< ground before the detail and its clamp; level and river fields final
    double water = 0.0;
    double weight = 0.0;   ///< of the detail
    double channel = 0.0;  ///< metres from a river in which its water stands
    FaceType face = FaceType::sea;
    bool coast = false;
  };
  PointSample evaluate(std::int32_t leaf, const Vec3d& direction, int level, double octaves);
  /// `with_floors`: the drainage model's floors by a walk (a lone sample's; grid() draws them).
  Undetailed undetailed(std::int32_t leaf, const Vec3d& direction, int level,
                        bool with_floors = true);
  bool drainage_floors() const {
    return planet_->definition().relief_model == ReliefModel::drainage;
  }
  /// grid()'s rows of `grid`, a band of the whole whose first sample is the whole's `base`:
  /// sampled, their floors drawn (`floors`) and handed to `out` with their index in the whole.
  void grid_rows(const SampleGrid& grid, std::size_t base, int level, double octaves, bool floors,
                 const GridSink& out);
  /// grid_rows()'s floors: every floored edge of `level` within reach of a sample drawn onto the
  /// samples it reaches (pending_[k] for the whole's sample order_[k], the band's
  /// order_[k] − base, in leaves_[k], at pending_directions_[k]).
  void draw_floors(const SampleGrid& grid, std::size_t base, int level);
  /// draw_floors() where the planet warps `level` (Planet::warps): the band's rows are no longer
  /// lines of latitude, so its land samples are binned by where the warp put them.
  void draw_floors_by_bins(int level);
  /// Both draw_floors()'s way to their edges: every floored edge of the level a sample's walk
  /// could reach, once, handed to `draw` (sample_grid.cpp).
  template <typename Near, typename Draw>
  void for_each_floored_edge(const Near& near, const Draw& draw);
  /// grid()'s pending_ samples with their detail noise, to `out` with their order_ index
  /// (pending_directions_ holds their directions).
  void finish_pending(double octaves, const GridSink& out);
  /// The sample with `detail` added (none: no detail at all), clamped, and its water and type.
  PointSample finish(const Undetailed& sample, std::optional<double> detail) const;
  void trim_when_large();
  /// The ground at w in land triangle t (its corners `corner`): the cubic where every corner is
  /// dry, else the valley floor. The last leaf's surface is kept for the samples that follow in
  /// it.
  double land_ground(std::int32_t t, const std::array<const Vertex*, 3>& corner,
                     const std::array<double, 3>& w);
  /// descent_start without trimming the cache first.
  DescentStart find_descent_start(const Vec3d& centre, std::span<const Vec3d> points, int level);
  /// Triangle t with its edges' planes.
  DescentStart start_at(std::int32_t t) const;
  /// The leaf holding p: the triangle locate(p, level) finds, bit for bit (at `level`, or the
  /// first open-sea triangle on the way: Hierarchy::open_sea), descending from the deepest
  /// triangle of the last descent that holds p, else from `start` when usable, else from the
  /// octahedron.
  std::int32_t descend(const Vec3d& p, int level, const DescentStart& start);
  /// Descends path_ from its last triangle, which holds p, to p's leaf.
  std::int32_t descend_path(const Vec3d& p, int level);
  /// p's leaf, given a triangle of a level's triangulation that holds p by the margin (the walk
  /// found it): it, its first open-sea ancestor, or the leaf below it.
  std::int32_t settle(const DescentStart& at, const Vec3d& p, int level);

  std::shared_ptr<const Planet> planet_;
  Hierarchy hierarchy_;
  std::size_t trim_bound_;
  std::uint64_t generation_ = 0;  ///< trims so far: a DescentStart of another is stale
  /// The last descent's triangles, its start first, each holding the last point (see
  /// DescentStart: any of them that holds the next point by the margin lies on its way down).
  std::vector<DescentStart> path_;
  int path_level_ = -1;  ///< the level that descent asked for
  DescentStart leaf_;    ///< the last point's leaf (at path_level_, or an open-sea triangle)
  // Scratch of the batch at() and grid(): kept between calls so that a tile allocates nothing.
  std::vector<Undetailed> pending_;
  std::vector<std::size_t> order_;         ///< grid(): the grid index of each pending_ sample
  std::vector<Vec3d> pending_directions_;  ///< grid(): the direction of each pending_ sample
  std::vector<std::int32_t> leaves_;       ///< grid(): the leaf of each pending_ sample
  std::vector<std::int32_t> walk_;         ///< a floor walk's triangles
  std::vector<std::int32_t> reached_;      ///< draw_floors(): the triangles within reach
  std::vector<std::uint32_t> marks_;       ///< draw_floors(): == mark_ for a triangle in reached_
  std::uint32_t mark_ = 0;
  std::vector<double> ground_;  ///< draw_floors(): each sample's ground, NaN off land
  std::array<std::vector<double>, 3> direction_;  ///< draw_floors(): each sample's direction
  std::vector<double> row_z_;                     ///< draw_floors(): each row's z
  std::vector<double> row_axis_;  ///< draw_floors(): each row's distance from the polar axis
  std::vector<double> floor_;     ///< draw_floors(): each sample's lowest floor so far
  // draw_floors_by_bins(): the land samples (pending_ indices), their bins, the bins' first
  // slots in the packed arrays above (one more at the end) and each land sample's slot.
  std::vector<std::size_t> land_, bin_of_, bin_start_, bin_next_, slot_;
  std::vector<double> warp_scratch_;  ///< grid() and the batch at(): the warp's sums
  std::vector<Vec3d> warped_;         ///< grid() and the batch at(): the directions, warped
  std::vector<Vec3d> detailed_;
  std::vector<double> detail_;
  /// The surface of a land leaf, this generation's (land_ground): its valley floor where it has
  /// one, else its cubic.
  struct LeafSurface {
    std::int32_t tri = -1;
    std::uint64_t generation = 0;
    std::optional<CloughTocher> cubic;
    std::optional<ValleyFloor> floor;
  };
  /// The surfaces of recent land leaves, by triangle index modulo their number: a tile's rows
  /// cross each leaf two or three times, and making a leaf's surface costs three evaluations
  /// of it. 64 hold a 16-sample block's rows of leaves at every zoom.
  static constexpr std::size_t kLeafSurfaces = 64;
  std::vector<LeafSurface> leaf_surfaces_ = std::vector<LeafSurface>(kLeafSurfaces);
  /// Steps across leaf edges before a point is looked for down the path instead.
  static constexpr int kWalkSteps = 4;
  /// Rows of a grid whose floors are drawn together (Sampler::grid): 32 was 3–10 % faster than
  /// a whole tile at once in most interleaved rounds, 16 and 64 no faster than 32.
  static constexpr int kFloorBandRows = 32;
};

/// {"latitude", "longitude", "ground", "water", "type", "level"}: the sample route's body.
nlohmann::json sample_json(double latitude, double longitude, const PointSample& sample);

}  // namespace planet
