// Geomorphometry of a planet (docs/analysis.md, "Planets"): the figures `terrain analyze` gives
// scenes — pits, closed depressions, Flint's law, Horton–Strahler, drainage density — over a
// square of the planet's surface sampled as its tiles are, so that the realism of planets is
// measured by the same definitions as the realism of scenes.
#pragma once

#include <memory>

#include <nlohmann/json.hpp>

#include "planet/planet.hpp"
#include "terrain/geomorphometry.hpp"
#include "terrain/result.hpp"

namespace planet {

/// The largest side of the analysed square, in samples.
inline constexpr int kMaxPlanetAnalysisSide = 2048;

struct PlanetAnalysisOptions {
  double latitude = 0.0;   ///< degrees, the square's centre
  double longitude = 0.0;  ///< degrees
  /// Metres between samples, east and north; each sample is taken at the level of detail of a
  /// tile of this ground spacing (Sampler::sample). 0: the spacing of a 256² tile at `zoom`.
  double cell_size = 0.0;
  int zoom = 8;    ///< used when cell_size is 0 (geographic tiles: 265 m per sample at zoom 8)
  int size = 512;  ///< samples per side
  /// Samples added on every side and drained with the square, but not measured
  /// (terrain::AnalysisOptions::window): valleys that enter the square bring the area they
  /// drain out to `margin` samples beyond its edge. size + 2·margin is at most
  /// kMaxPlanetAnalysisSide.
  int margin = 0;
  terrain::AnalysisOptions analysis;
};

/// Samples `size` × `size` points on the plane tangent at the centre (east, north), `cell_size`
/// apart, and `margin` more on every side, and analyses the square: sea samples are water
/// (outlets), river samples wet land. The JSON is terrain::to_json's figures plus "input" (the
/// planet id, centre, cell size, level, margin, sea and river cells of the square). Errors name
/// the field: /latitude, /longitude, /cell_size, /zoom, /size, /margin, and terrain::analyze's.
/// With `picture`, also draws the whole grid, margin included (terrain::draw_drainage).
terrain::Result<nlohmann::json> analyze_planet(const std::shared_ptr<const Planet>& planet,
                                               const PlanetAnalysisOptions& options,
                                               terrain::AnalysisPicture* picture = nullptr);

/// The most samples planet_hypsometry takes.
inline constexpr int kMaxHypsometrySamples = 1000000;

struct PlanetHypsometryOptions {
  int samples = 20000;     ///< points of an equal-area (Fibonacci) lattice over the sphere
  double cell_size = 200;  ///< metres: each point at the level of detail of a tile this fine
};

/// The land's hypsometry over the whole planet (docs/analysis.md, "Hypsometry"): the ground of
/// every lattice point that is not sea (rivers and lakes at their beds), its mean, percentiles,
/// the share below fixed altitudes and the hypsometric integral. Errors name /samples or
/// /cell_size.
terrain::Result<nlohmann::json> planet_hypsometry(const std::shared_ptr<const Planet>& planet,
                                                  const PlanetHypsometryOptions& options);

/// Issue 20's realism targets for land (docs/analysis.md "Planets"): pits and closed
/// depressions as shares of dry land cells, Flint's law's exponent and fit.
struct RealismTargets {
  double max_pit_share = 0.001;
  double max_closed_depression_share = 0.02;
  double min_theta = 0.3, max_theta = 0.8;
  double min_r_squared = 0.3;
};

/// The most lattice points planet_realism_survey looks at.
inline constexpr int kMaxSurveyPoints = 4096;

struct PlanetSurveyOptions {
  /// Points of an equal-area (Fibonacci) lattice over the sphere; each within 80° of the equator
  /// whose centre is land at the zoom's level of detail is the centre of a square.
  int points = 64;
  int zoom = 8;    ///< each square's samples are a 256² tile's of this zoom apart
  int size = 512;  ///< samples per side of each square
  int margin = 0;  ///< drained around each square, not measured (PlanetAnalysisOptions)
  RealismTargets targets;
};

/// Geomorphometry of land squares spread over the whole planet, so that realism is measured
/// wherever land is, not only where a fixed square lies: each square's figures (analyze_planet)
/// and whether it meets each target, and over all squares how many meet each and all of them
/// and the medians. Errors name /points, or analyze_planet's /zoom, /size and /margin.
terrain::Result<nlohmann::json> planet_realism_survey(const std::shared_ptr<const Planet>& planet,
                                                      const PlanetSurveyOptions& options);

}  // namespace planet
