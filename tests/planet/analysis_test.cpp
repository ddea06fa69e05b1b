// Geomorphometry of planets (planet/analysis.hpp): the scene figures over a square of a planet,
// sea as outlets, reproducible, and bad options refused naming the field.
#include "planet/analysis.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <tuple>
#include <vector>

#include "default_definition.hpp"
#include "planet/tiles.hpp"

namespace planet {
namespace {

const std::shared_ptr<const Planet>& default_planet() {
  static const std::shared_ptr<const Planet> planet = Planet::create(test::default_definition());
  return planet;
}

PlanetAnalysisOptions around(double latitude, double longitude, int size, int zoom) {
  PlanetAnalysisOptions o;
  o.latitude = latitude;
  o.longitude = longitude;
  o.size = size;
  o.zoom = zoom;
  return o;
}

TEST(PlanetAnalysis, MeasuresLandWithTheSceneFigures) {
  // Inland on the default planet's continent across the antimeridian (bench/planet_realism.sh's
  // point).
  const auto figures = analyze_planet(default_planet(), around(5.0, -175.0, 96, 11));
  ASSERT_TRUE(figures) << figures.error().message;
  const nlohmann::json& f = *figures;
  EXPECT_EQ(f["input"]["kind"], "planet");
  EXPECT_EQ(f["input"]["planet_id"], default_planet()->id());
  EXPECT_NEAR(f["input"]["cell_size_m"].get<double>(), default_planet()->ground_spacing(11, 256),
              1e-9);
  EXPECT_EQ(f["grid"]["width"], 96);
  EXPECT_EQ(f["land_cells"], 96 * 96);
  EXPECT_GT(f["elevation_m"]["min"].get<double>(), 0.0);
  EXPECT_GE(f["pits"]["share"].get<double>(), 0.0);
  EXPECT_GT(f["channels"]["cells"].get<int>(), 0);
}

TEST(PlanetAnalysis, LandDrainsWithoutPitsOrClosedDepressions) {
  // Issue 20's targets on a zoom-11 square of land (bench/planet_realism.sh measures 512² at
  // zooms 8, 11 and 14 on three planets): pits ≤ 0.1 % of land cells, closed depressions ≤ 2 %.
  const auto figures = analyze_planet(default_planet(), around(5.0, -175.0, 128, 11));
  ASSERT_TRUE(figures) << figures.error().message;
  EXPECT_LE((*figures)["pits"]["share"].get<double>(), 0.001);
  EXPECT_LE((*figures)["closed_depression_share"].get<double>(), 0.02);
}

TEST(PlanetAnalysis, SeaIsWaterNotLand) {
  // A square across the west coast of the continent on the antimeridian (generation 19), 9.8 km
  // apart: some sea, some land.
  terrain::AnalysisPicture picture;
  const auto figures = analyze_planet(default_planet(), around(5.0, 178.0, 64, 3), &picture);
  ASSERT_TRUE(figures) << figures.error().message;
  const auto sea = (*figures)["input"]["sea_cells"].get<std::int64_t>();
  EXPECT_GT(sea, 0);
  EXPECT_LT(sea, 64 * 64);
  EXPECT_EQ((*figures)["land_cells"].get<std::int64_t>() + sea, 64 * 64);
  // The picture paints the sea cells, and only them, the sea's colour.
  ASSERT_EQ(picture.width, 64);
  ASSERT_EQ(picture.rgb.size(), 64u * 64u * 3u);
  std::int64_t sea_pixels = 0;
  for (std::size_t k = 0; k < picture.rgb.size(); k += 3) {
    sea_pixels += picture.rgb[k] == 20 && picture.rgb[k + 1] == 40 && picture.rgb[k + 2] == 110;
  }
  EXPECT_EQ(sea_pixels, sea);
}

// A margin is sampled and drained with the square but not measured: the square's own samples
// and counts, and valleys that enter it drain the margin too.
TEST(PlanetAnalysis, AMarginIsDrainedButNotMeasured) {
  // Across the continent's west coast on the antimeridian, as above, so that the margin holds
  // sea the square does not count.
  PlanetAnalysisOptions square = around(5.0, 178.0, 64, 3);
  PlanetAnalysisOptions with_margin = square;
  with_margin.margin = 32;
  const auto a = analyze_planet(default_planet(), square);
  const auto b = analyze_planet(default_planet(), with_margin);
  ASSERT_TRUE(a && b);
  EXPECT_EQ((*b)["input"]["margin"], 32);
  EXPECT_EQ((*b)["grid"]["width"], 64);
  EXPECT_EQ((*b)["grid"]["height"], 64);
  // The same samples: the same land, sea and elevations (positions to rounding).
  EXPECT_EQ((*b)["land_cells"], (*a)["land_cells"]);
  EXPECT_EQ((*b)["input"]["sea_cells"], (*a)["input"]["sea_cells"]);
  for (const char* figure : {"min", "mean", "max"}) {
    EXPECT_NEAR((*b)["elevation_m"][figure].get<double>(),
                (*a)["elevation_m"][figure].get<double>(), 1e-3)
        << figure;
  }
  // Water from the margin reaches the square: its largest drainage area grows.
  EXPECT_GT((*b)["channels"]["max_drainage_area_m2"].get<double>(),
            (*a)["channels"]["max_drainage_area_m2"].get<double>());
}

TEST(PlanetAnalysis, IsReproducible) {
  PlanetAnalysisOptions o = around(20.0, 30.0, 48, 0);
  o.cell_size = 500.0;
  const auto a = analyze_planet(default_planet(), o);
  const auto b = analyze_planet(default_planet(), o);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->dump(), b->dump());
  EXPECT_EQ((*a)["input"]["cell_size_m"], 500.0);
  EXPECT_FALSE((*a)["input"].contains("zoom"));
}

// Bad options, each refused naming its field.
TEST(PlanetAnalysis, RefusesBadOptionsNamingTheField) {
  const struct {
    PlanetAnalysisOptions options;
    const char* pointer;
  } cases[] = {
      {around(86.0, 0.0, 64, 8), "/latitude"},
      {around(NAN, 0.0, 64, 8), "/latitude"},
      {around(0.0, 181.0, 64, 8), "/longitude"},
      {around(0.0, 0.0, 1, 8), "/size"},
      {around(0.0, 0.0, 5000, 8), "/size"},
      {around(0.0, 0.0, 64, -1), "/zoom"},
      {around(0.0, 0.0, 64, 99), "/zoom"},
      {around(0.0, 0.0, 2048, 0), "/size"},  // a quarter of the planet: not a plane
  };
  PlanetAnalysisOptions bad_margin = around(0.0, 0.0, 64, 8);
  for (const int margin : {-1, (kMaxPlanetAnalysisSide - 64) / 2 + 1}) {
    bad_margin.margin = margin;
    EXPECT_EQ(analyze_planet(default_planet(), bad_margin).error().pointer, "/margin") << margin;
  }
  bad_margin = around(0.0, 0.0, 512, 4);
  ASSERT_TRUE(analyze_planet(default_planet(), bad_margin));  // 2 500 km: the square fits
  bad_margin.margin = 512;                                    // 7 500 km: too much of the planet
  EXPECT_EQ(analyze_planet(default_planet(), bad_margin).error().pointer, "/margin");
  for (const auto& c : cases) {
    const auto result = analyze_planet(default_planet(), c.options);
    ASSERT_FALSE(result) << c.pointer;
    EXPECT_EQ(result.error().pointer, c.pointer);
  }
  PlanetAnalysisOptions bad_cell = around(0.0, 0.0, 64, 8);
  bad_cell.cell_size = -3.0;
  EXPECT_EQ(analyze_planet(default_planet(), bad_cell).error().pointer, "/cell_size");
  bad_cell.cell_size = NAN;
  EXPECT_EQ(analyze_planet(default_planet(), bad_cell).error().pointer, "/cell_size");
}

TEST(PlanetRealismSurvey, AnalysesASquareAtEachLandPointOfTheLattice) {
  PlanetSurveyOptions options;
  options.points = 40;
  options.zoom = 11;
  options.size = 48;
  const auto world = default_planet();
  const auto survey = planet_realism_survey(world, options);
  ASSERT_TRUE(survey) << survey.error().message;
  const nlohmann::json& s = *survey;
  // A square at every lattice point within 80° of the equator that is land at the zoom's level,
  // and at no other.
  const double cell = world->ground_spacing(11, 256);
  Sampler sampler(world);
  std::size_t land_points = 0;
  const int level = world->level_for_spacing(cell);
  const double octaves = world->octaves_for_spacing(cell);
  for (int i = 0; i < options.points; ++i) {
    const Vec3d direction = fibonacci_direction(i, options.points);
    double lat = 0.0, lon = 0.0;
    world->geodesy().direction_to_geographic(direction, lat, lon);
    if (std::abs(lat) <= 80.0 && sampler.at(direction, level, octaves).type == SurfaceType::land) {
      ++land_points;
    }
  }
  ASSERT_GT(land_points, 5u);
  ASSERT_EQ(s["squares"].size(), land_points);
  // Each square's verdicts follow from its figures, and the summary counts them.
  int pits = 0, closed = 0, flint = 0, all = 0, flint_inside = 0;
  for (const nlohmann::json& square : s["squares"]) {
    const auto figures = analyze_planet(
        world, around(square["latitude"].get<double>(), square["longitude"].get<double>(), 48, 11));
    ASSERT_TRUE(figures);
    EXPECT_EQ(square["pit_share"], (*figures)["pits"]["share"]);
    const bool pits_met = square["pit_share"].get<double>() <= 0.001;
    const bool closed_met = square["closed_depression_share"].get<double>() <= 0.02;
    const bool flint_met = !square["theta"].is_null() && square["theta"].get<double>() >= 0.3 &&
                           square["theta"].get<double>() <= 0.8 &&
                           square["r_squared"].get<double>() >= 0.3;
    EXPECT_EQ(square["meets"]["pits"], pits_met);
    EXPECT_EQ(square["meets"]["closed_depressions"], closed_met);
    EXPECT_EQ(square["meets"]["flint"], flint_met);
    // The fit without edge-fed channels, beside the verdicts and not in them.
    const nlohmann::json& inside = (*figures)["flint_inside"];
    if (inside.is_null()) {
      EXPECT_TRUE(square["flint_inside"].is_null());
    } else {
      EXPECT_EQ(square["flint_inside"]["theta"], inside["theta"]);
      EXPECT_EQ(square["flint_inside"]["r_squared"], inside["r_squared"]);
      const bool met = inside["theta"].get<double>() >= 0.3 &&
                       inside["theta"].get<double>() <= 0.8 &&
                       inside["r_squared"].get<double>() >= 0.3;
      EXPECT_EQ(square["flint_inside"]["meets_flint"], met);
      flint_inside += met;
    }
    pits += pits_met;
    closed += closed_met;
    flint += flint_met;
    all += pits_met && closed_met && flint_met;
  }
  EXPECT_EQ(s["summary"]["squares"], land_points);
  EXPECT_EQ(s["summary"]["meeting"]["pits"], pits);
  EXPECT_EQ(s["summary"]["meeting"]["closed_depressions"], closed);
  EXPECT_EQ(s["summary"]["meeting"]["flint"], flint);
  EXPECT_EQ(s["summary"]["meeting_all"], all);
  EXPECT_EQ(s["summary"]["flint_inside"]["meeting"], flint_inside);
  EXPECT_EQ(s["input"]["planet_id"], world->id());
}

TEST(PlanetRealismSurvey, MostOfTheDefaultPlanetsLandMeetsIssue20sTargets) {
  // Not one tuned square but the land at large: at zooms 8 and 11, two thirds of the land squares
  // of the 64-point lattice, 128² each, meet all three targets, and every one the pits target
  // (generation 20: 20 and 20 of 21, pits on all; generation 19: 17 and 18; generation 18: 18 and
  // 21 of 24; bench/planet_realism.sh surveys 512² squares of three planets at zooms 8, 11 and
  // 14). A guard against broad losses: in generation 18, links steepening as l^−1.4 (7 and 15 of
  // 24) or land splits keeping 60 % of eq. 2's offset (7 and 7) failed it; smaller changes need
  // the bench.
  for (const int zoom : {8, 11}) {
    PlanetSurveyOptions options;
    options.zoom = zoom;
    options.size = 128;
    const auto survey = planet_realism_survey(default_planet(), options);
    ASSERT_TRUE(survey) << survey.error().message;
    const nlohmann::json& summary = (*survey)["summary"];
    ASSERT_GE(summary["squares"].get<int>(), 20);
    EXPECT_GE(3 * summary["meeting_all"].get<int>(), 2 * summary["squares"].get<int>())
        << "zoom " << zoom << ": " << summary.dump();
    EXPECT_EQ(summary["meeting"]["pits"], summary["squares"]) << "zoom " << zoom;
  }
}

TEST(PlanetRealismSurvey, RefusesBadOptionsNamingTheField) {
  PlanetSurveyOptions options;
  options.points = 0;
  EXPECT_EQ(planet_realism_survey(default_planet(), options).error().pointer, "/points");
  options.points = kMaxSurveyPoints + 1;
  EXPECT_EQ(planet_realism_survey(default_planet(), options).error().pointer, "/points");
  options.points = 8;
  options.zoom = PlanetTiles::max_zoom() + 1;
  EXPECT_EQ(planet_realism_survey(default_planet(), options).error().pointer, "/zoom");
  options.zoom = 8;
  options.size = 1;
  EXPECT_EQ(planet_realism_survey(default_planet(), options).error().pointer, "/size");
  options.size = 512;
  options.margin = -2;
  EXPECT_EQ(planet_realism_survey(default_planet(), options).error().pointer, "/margin");
}

TEST(PlanetHypsometry, SummarisesTheLandsAltitudes) {
  PlanetHypsometryOptions options;
  options.samples = 4000;
  const auto result = planet_hypsometry(default_planet(), options);
  ASSERT_TRUE(result) << result.error().message;
  const nlohmann::json& h = *result;
  // The lattice is equal-area: the land share is the definition's land fraction.
  EXPECT_NEAR(h.at("land_share").get<double>(), test::default_definition().land_fraction, 0.03);
  const nlohmann::json& e = h.at("elevation_m");
  double previous = e.at("min").get<double>();
  for (const char* key : {"p10", "p25", "median", "p75", "p90", "max"}) {
    EXPECT_LE(previous, e.at(key).get<double>()) << key;
    previous = e.at(key).get<double>();
  }
  EXPECT_GT(e.at("mean").get<double>(), e.at("min").get<double>());
  EXPECT_LT(e.at("mean").get<double>(), e.at("max").get<double>());
  double share = 0.0;
  for (const nlohmann::json& below : h.at("land_below")) {
    EXPECT_GE(below.at("share").get<double>(), share);
    share = below.at("share").get<double>();
  }
  const double integral = h.at("hypsometric_integral").get<double>();
  EXPECT_GT(integral, 0.0);
  EXPECT_LT(integral, 1.0);
  EXPECT_EQ(*planet_hypsometry(default_planet(), options), h);  // reproducible
}

TEST(PlanetHypsometry, FollowsTheRiversAltitudes) {
  // Displacement-model rivers rising to half the altitude put the land lower.
  PlanetDefinition high_rivers = test::default_definition();
  high_rivers.relief_model = ReliefModel::displacement;
  PlanetDefinition low = high_rivers;
  low.max_river_altitude /= 2.0;
  PlanetHypsometryOptions options;
  options.samples = 4000;
  const auto high = planet_hypsometry(Planet::create(high_rivers), options);
  const auto lower = planet_hypsometry(Planet::create(low), options);
  ASSERT_TRUE(high && lower);
  EXPECT_LT(lower->at("elevation_m").at("median").get<double>(),
            high->at("elevation_m").at("median").get<double>() - 200.0);
}

TEST(PlanetHypsometry, FollowsTheBeltsAndPlateausUnderTheDrainageModel) {
  // The drainage model's rivers climb with the belts' and plateaus' uplift: at half of it, the
  // land stands lower (the median by 135 m, measured).
  PlanetDefinition low = test::default_definition();
  low.belt_height /= 2.0;
  low.plateau_height /= 2.0;
  PlanetHypsometryOptions options;
  options.samples = 4000;
  const auto high = planet_hypsometry(default_planet(), options);
  const auto lower = planet_hypsometry(Planet::create(low), options);
  ASSERT_TRUE(high && lower);
  EXPECT_LT(lower->at("elevation_m").at("median").get<double>(),
            high->at("elevation_m").at("median").get<double>() - 100.0);
}

TEST(PlanetHypsometry, RefusesBadOptionsNamingTheField) {
  for (const auto& [samples, cell, pointer] :
       std::vector<std::tuple<int, double, std::string>>{{99, 200.0, "/samples"},
                                                         {2000000, 200.0, "/samples"},
                                                         {1000, 0.0, "/cell_size"},
                                                         {1000, NAN, "/cell_size"},
                                                         {1000, 1e6, "/cell_size"}}) {
    PlanetHypsometryOptions options;
    options.samples = samples;
    options.cell_size = cell;
    const auto result = planet_hypsometry(default_planet(), options);
    ASSERT_FALSE(result) << pointer;
    EXPECT_EQ(result.error().pointer, pointer);
  }
}

}  // namespace
}  // namespace planet
