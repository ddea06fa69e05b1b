// Issue 20's targets on one square of a planet's land, measured as bench/planet_realism.sh
// measures them: pits ≤ 0.1 % of land cells, closed depressions ≤ 2 %, and slope falling with
// drainage area as Flint's law has it, 0.3 ≤ θ ≤ 0.8 with r² ≥ 0.3.
#pragma once

#include <gtest/gtest.h>

#include <memory>

#include "planet/analysis.hpp"
#include "planet/planet.hpp"

namespace planet::test {

/// The 256² square at zoom `zoom` centred on (latitude, longitude) meets the three targets.
inline void expect_square_meets_issue20_targets(const std::shared_ptr<const Planet>& world,
                                                double latitude, double longitude, int zoom) {
  PlanetAnalysisOptions square;
  square.latitude = latitude;
  square.longitude = longitude;
  square.zoom = zoom;
  square.size = 256;
  const auto figures = analyze_planet(world, square);
  ASSERT_TRUE(figures) << figures.error().message;
  const nlohmann::json& f = *figures;
  EXPECT_LE(f["pits"]["share"].get<double>(), 0.001);
  EXPECT_LE(f["closed_depression_share"].get<double>(), 0.02);
  ASSERT_TRUE(f["flint"].is_object());
  EXPECT_GE(f["flint"]["theta"].get<double>(), 0.3);
  EXPECT_LE(f["flint"]["theta"].get<double>(), 0.8);
  EXPECT_GE(f["flint"]["r_squared"].get<double>(), 0.3);
}

}  // namespace planet::test
