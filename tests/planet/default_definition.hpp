// The definition of config/planets/default.json, for tests that need the default planet (or the
// same definition with another seed or land fraction), and that planet itself, built once per
// test binary.
#pragma once

#include <cstdint>
#include <memory>

#include "planet/definition.hpp"
#include "planet/planet.hpp"

namespace planet::test {

inline constexpr std::uint64_t kDefaultSeed = 20110627;

inline PlanetDefinition default_definition(std::uint64_t seed = kDefaultSeed, double land = 0.35) {
  PlanetDefinition d = load_planet_file(TERRAIN_SOURCE_DIR "/config/planets/default.json").value();
  d.seed = seed;
  d.land_fraction = land;
  return d;
}

/// The default planet, built once for every test of the binary that asks.
inline const std::shared_ptr<const Planet>& default_planet() {
  static const std::shared_ptr<const Planet> planet = Planet::create(default_definition());
  return planet;
}

}  // namespace planet::test
