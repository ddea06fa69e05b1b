#include "planet/analysis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "planet/tiles.hpp"
#include "terrain/drainage.hpp"

namespace planet {
namespace {

// The checks a square's side and zoom share between analyze_planet and the survey.
std::optional<terrain::Error> bad_size(int size) {
  if (size >= 2 && size <= kMaxPlanetAnalysisSide) return std::nullopt;
  return terrain::Error{"must be an integer from 2 to " + std::to_string(kMaxPlanetAnalysisSide),
                        "/size"};
}

std::optional<terrain::Error> bad_margin(int size, int margin) {
  if (margin >= 0 && margin <= (kMaxPlanetAnalysisSide - size) / 2) return std::nullopt;
  return terrain::Error{
      "must be an integer from 0 to (" + std::to_string(kMaxPlanetAnalysisSide) + " - size) / 2",
      "/margin"};
}

std::optional<terrain::Error> bad_zoom(int zoom) {
  if (zoom >= 0 && zoom <= PlanetTiles::max_zoom()) return std::nullopt;
  return terrain::Error{"must be a zoom from 0 to " + std::to_string(PlanetTiles::max_zoom()),
                        "/zoom"};
}

}  // namespace

terrain::Result<nlohmann::json> analyze_planet(const std::shared_ptr<const Planet>& planet,
                                               const PlanetAnalysisOptions& options,
                                               terrain::AnalysisPicture* picture) {
  using terrain::Error;
  if (!(std::abs(options.latitude) <= 85.0)) {
    return Error{"must be a latitude from -85 to 85 degrees", "/latitude"};
  }
  if (!(std::abs(options.longitude) <= 180.0)) {
    return Error{"must be a longitude from -180 to 180 degrees", "/longitude"};
  }
  if (auto bad = bad_size(options.size)) return *bad;
  if (auto bad = bad_margin(options.size, options.margin)) return *bad;
  if (auto bad = bad_zoom(options.zoom); bad && options.cell_size == 0.0) return *bad;
  const double cell =
      options.cell_size == 0.0 ? planet->ground_spacing(options.zoom, 256) : options.cell_size;
  if (!std::isfinite(cell) || !(cell >= 0.01) || !(cell <= 1e5)) {
    return Error{"must be a number of metres from 0.01 to 100000", "/cell_size"};
  }
  const int n = options.size + 2 * options.margin;
  const double radius = planet->definition().radius;
  const double degree = std::numbers::pi / 180.0;
  const double half = 0.5 * (n - 1) * cell;
  // The square spans at most n·cell along a great circle: the tangent plane's east and north
  // axes become latitude and longitude offsets (exact on the central meridian and parallel,
  // within (side / radius)² elsewhere).
  // The square alone first, so that the error names what is too large.
  if (0.5 * (options.size - 1) * cell / radius > 0.2) {
    return Error{"covers too much of the planet (size × cell_size)", "/size"};
  }
  if (half / radius > 0.2) {
    return Error{"covers too much of the planet ((size + 2 × margin) × cell_size)", "/margin"};
  }
  // The square within the margin: what every figure describes.
  const int first = options.margin, end = options.margin + options.size;
  const auto in_square = [&](int i, int j) {
    return i >= first && j >= first && i < end && j < end;
  };
  std::vector<float> elevation(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  std::vector<std::uint8_t> sea(elevation.size(), 0), wet(elevation.size(), 0);
  std::int64_t sea_cells = 0, river_cells = 0, lake_cells = 0;
  Sampler sampler(planet);
  const double cos_centre = std::cos(options.latitude * degree);
  for (int j = 0; j < n; ++j) {
    const double north = -half + j * cell;
    const double latitude = options.latitude + north / radius / degree;
    for (int i = 0; i < n; ++i) {
      const double east = -half + i * cell;
      double longitude = options.longitude + east / (radius * cos_centre) / degree;
      if (longitude < -180.0) longitude += 360.0;
      if (longitude >= 180.0) longitude -= 360.0;
      const PointSample s = sampler.sample(latitude, longitude, cell);
      const std::size_t c =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(n) + static_cast<std::size_t>(i);
      elevation[c] = static_cast<float>(s.ground);
      const int counted = in_square(i, j) ? 1 : 0;
      if (s.type == SurfaceType::sea) {
        sea[c] = 1;
        sea_cells += counted;
      } else if (s.type == SurfaceType::river) {
        wet[c] = terrain::kFlowingWater;
        river_cells += counted;
      } else if (s.type == SurfaceType::lake) {
        wet[c] = terrain::kStandingWater;  // a lake's floor is a depression by nature
        lake_cells += counted;
      }
    }
  }
  const terrain::ElevationGrid grid{n, n, cell, elevation, std::nullopt, sea, wet};
  terrain::AnalysisOptions analysis = options.analysis;
  if (options.margin > 0) analysis.window = terrain::AnalysisWindow{first, first, end, end};
  terrain::Result<terrain::Geomorphometry> figures = terrain::analyze(grid, analysis, picture);
  if (!figures) return figures.error();
  nlohmann::json out = terrain::to_json(*figures);
  out["input"] = {{"kind", "planet"},
                  {"planet_id", planet->id()},
                  {"latitude", options.latitude},
                  {"longitude", options.longitude},
                  {"cell_size_m", cell},
                  {"level", planet->level_for_spacing(cell)},
                  {"margin", options.margin},
                  {"sea_cells", sea_cells},
                  {"river_cells", river_cells},
                  {"lake_cells", lake_cells}};
  if (options.cell_size == 0.0) out["input"]["zoom"] = options.zoom;
  return out;
}

terrain::Result<nlohmann::json> planet_hypsometry(const std::shared_ptr<const Planet>& planet,
                                                  const PlanetHypsometryOptions& options) {
  using terrain::Error;
  if (options.samples < 100 || options.samples > kMaxHypsometrySamples) {
    return Error{"must be an integer from 100 to " + std::to_string(kMaxHypsometrySamples),
                 "/samples"};
  }
  if (!(options.cell_size >= 0.01 && options.cell_size <= 1e5)) {
    return Error{"must be a number of metres from 0.01 to 100000", "/cell_size"};
  }
  const int level = planet->level_for_spacing(options.cell_size);
  const double octaves = planet->octaves_for_spacing(options.cell_size);
  Sampler sampler(planet);
  std::vector<double> land;
  const int n = options.samples;
  for (int i = 0; i < n; ++i) {
    const PointSample s = sampler.at(fibonacci_direction(i, n), level, octaves);
    if (s.type != SurfaceType::sea) land.push_back(s.ground);
  }
  nlohmann::json out;
  out["input"] = {{"kind", "planet"},
                  {"planet_id", planet->id()},
                  {"samples", n},
                  {"cell_size_m", options.cell_size},
                  {"level", level}};
  out["land_samples"] = land.size();
  out["land_share"] = static_cast<double>(land.size()) / n;
  if (land.empty()) return out;
  std::sort(land.begin(), land.end());
  double sum = 0.0;
  for (double h : land) sum += h;
  const double mean = sum / static_cast<double>(land.size());
  const auto percentile = [&](double q) {
    return land[std::min(land.size() - 1,
                         static_cast<std::size_t>(q * static_cast<double>(land.size())))];
  };
  out["elevation_m"] = {{"mean", mean},
                        {"min", land.front()},
                        {"max", land.back()},
                        {"p10", percentile(0.1)},
                        {"p25", percentile(0.25)},
                        {"median", percentile(0.5)},
                        {"p75", percentile(0.75)},
                        {"p90", percentile(0.9)}};
  nlohmann::json below = nlohmann::json::array();
  for (const double altitude : {0.0, 200.0, 500.0, 1000.0, 2000.0, 4000.0}) {
    const auto count = std::lower_bound(land.begin(), land.end(), altitude) - land.begin();
    below.push_back({{"altitude_m", altitude},
                     {"share", static_cast<double>(count) / static_cast<double>(land.size())}});
  }
  out["land_below"] = below;
  out["hypsometric_integral"] =
      land.back() > land.front() ? (mean - land.front()) / (land.back() - land.front()) : 0.0;
  return out;
}

terrain::Result<nlohmann::json> planet_realism_survey(const std::shared_ptr<const Planet>& planet,
                                                      const PlanetSurveyOptions& options) {
  using terrain::Error;
  if (options.points < 1 || options.points > kMaxSurveyPoints) {
    return Error{"must be an integer from 1 to " + std::to_string(kMaxSurveyPoints), "/points"};
  }
  if (auto bad = bad_zoom(options.zoom)) return *bad;
  if (auto bad = bad_size(options.size)) return *bad;
  if (auto bad = bad_margin(options.size, options.margin)) return *bad;
  const RealismTargets& target = options.targets;
  const double cell = planet->ground_spacing(options.zoom, 256);
  const int level = planet->level_for_spacing(cell);
  const double octaves = planet->octaves_for_spacing(cell);
  Sampler sampler(planet);
  nlohmann::json squares = nlohmann::json::array();
  std::vector<double> pits, closed, thetas, fits, inside_thetas, inside_fits;
  int meeting_pits = 0, meeting_closed = 0, meeting_flint = 0, meeting_all = 0;
  int meeting_flint_inside = 0;
  for (int i = 0; i < options.points; ++i) {
    const Vec3d direction = fibonacci_direction(i, options.points);
    double latitude = 0.0, longitude = 0.0;
    planet->geodesy().direction_to_geographic(direction, latitude, longitude);
    if (std::abs(latitude) > 80.0) continue;
    if (sampler.at(direction, level, octaves).type != SurfaceType::land) continue;
    PlanetAnalysisOptions square;
    square.latitude = latitude;
    square.longitude = longitude;
    square.zoom = options.zoom;
    square.size = options.size;
    square.margin = options.margin;
    terrain::Result<nlohmann::json> figures = analyze_planet(planet, square);
    if (!figures) return figures.error();
    const nlohmann::json& f = *figures;
    const double pit_share = f["pits"]["share"].get<double>();
    const double closed_share = f["closed_depression_share"].get<double>();
    const bool fitted = !f["flint"].is_null();
    const double theta = fitted ? f["flint"]["theta"].get<double>() : 0.0;
    const double r_squared = fitted ? f["flint"]["r_squared"].get<double>() : 0.0;
    const bool pits_met = pit_share <= target.max_pit_share;
    const bool closed_met = closed_share <= target.max_closed_depression_share;
    const auto meets_flint = [&](double t, double r2) {
      return t >= target.min_theta && t <= target.max_theta && r2 >= target.min_r_squared;
    };
    const bool flint_met = fitted && meets_flint(theta, r_squared);
    // The same fit without the channels fed from beyond the square (docs/analysis.md): reported
    // beside the targets, not counted in them.
    nlohmann::json inside = nullptr;
    if (const nlohmann::json& fit = f["flint_inside"]; !fit.is_null()) {
      const double t = fit["theta"].get<double>(), r2 = fit["r_squared"].get<double>();
      inside = {{"theta", t}, {"r_squared", r2}, {"meets_flint", meets_flint(t, r2)}};
      meeting_flint_inside += meets_flint(t, r2) ? 1 : 0;
      inside_thetas.push_back(t);
      inside_fits.push_back(r2);
    }
    meeting_pits += pits_met ? 1 : 0;
    meeting_closed += closed_met ? 1 : 0;
    meeting_flint += flint_met ? 1 : 0;
    meeting_all += pits_met && closed_met && flint_met ? 1 : 0;
    pits.push_back(pit_share);
    closed.push_back(closed_share);
    if (fitted) {
      thetas.push_back(theta);
      fits.push_back(r_squared);
    }
    squares.push_back(
        {{"latitude", latitude},
         {"longitude", longitude},
         {"land_cells", f["land_cells"]},
         {"pit_share", pit_share},
         {"closed_depression_share", closed_share},
         {"theta", fitted ? nlohmann::json(theta) : nlohmann::json(nullptr)},
         {"r_squared", fitted ? nlohmann::json(r_squared) : nlohmann::json(nullptr)},
         {"flint_inside", inside},
         {"meets",
          {{"pits", pits_met}, {"closed_depressions", closed_met}, {"flint", flint_met}}}});
  }
  const auto median = [](std::vector<double> values) -> nlohmann::json {
    if (values.empty()) return nullptr;
    std::sort(values.begin(), values.end());
    const std::size_t half = values.size() / 2;
    return values.size() % 2 == 1 ? values[half] : 0.5 * (values[half - 1] + values[half]);
  };
  nlohmann::json out;
  out["input"] = {{"kind", "planet"},     {"planet_id", planet->id()}, {"points", options.points},
                  {"zoom", options.zoom}, {"size", options.size},      {"margin", options.margin},
                  {"cell_size_m", cell}};
  out["targets"] = {{"max_pit_share", target.max_pit_share},
                    {"max_closed_depression_share", target.max_closed_depression_share},
                    {"theta", {target.min_theta, target.max_theta}},
                    {"min_r_squared", target.min_r_squared}};
  out["squares"] = squares;
  out["summary"] = {
      {"squares", squares.size()},
      {"meeting_all", meeting_all},
      {"meeting",
       {{"pits", meeting_pits}, {"closed_depressions", meeting_closed}, {"flint", meeting_flint}}},
      {"median",
       {{"pit_share", median(pits)},
        {"closed_depression_share", median(closed)},
        {"theta", median(thetas)},
        {"r_squared", median(fits)}}},
      {"flint_inside",
       {{"meeting", meeting_flint_inside},
        {"median", {{"theta", median(inside_thetas)}, {"r_squared", median(inside_fits)}}}}}};
  return out;
}

}  // namespace planet
