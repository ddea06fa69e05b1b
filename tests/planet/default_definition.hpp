// The definition of config/planets/default.json, built in code, for tests that need the default
// planet (or the same definition with another seed or land fraction) without reading the file.
#pragma once

#include <cstdint>

#include "planet/definition.hpp"

namespace planet::test {

inline constexpr std::uint64_t kDefaultSeed = 20110627;

inline PlanetDefinition default_definition(std::uint64_t seed = kDefaultSeed, double land = 0.35) {
  PlanetDefinition d;
  d.seed = seed;
  d.land_fraction = land;
  d.max_river_altitude = 4500;
  d.max_mountain_altitude = 8000;
  return d;
}

}  // namespace planet::test
