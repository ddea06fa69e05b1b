// Definitions at the ends of their fields' ranges (planet::numeric_field_ranges, the parser's own
// tables): just outside is refused naming the field; at either end a definition is refused only
// by a relation between fields, or makes a planet whose tiles, coarse and deepest, have finite
// heights. A hostile definition need not be malformed to be expensive or degenerate.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "planet/definition.hpp"
#include "planet/planet.hpp"
#include "planet/tiles.hpp"

namespace planet {
namespace {

using terrain::TileAddress;
using terrain::TileFormat;

// {"seed": 7} with the field at `pointer` set to `value`, as an integer where the field is one.
nlohmann::json definition_with(const FieldRange& range, double value) {
  nlohmann::json document = {{"seed", 7}};
  const nlohmann::json::json_pointer pointer(range.pointer);
  if (range.integer) {
    document[pointer] = static_cast<std::int64_t>(value);
  } else {
    document[pointer] = value;
  }
  return document;
}

// The zoom-z tile holding 20° N 20° E (land on most seeds' planets, sea on the rest).
TileAddress tile_at(int z) {
  return {z, static_cast<std::int64_t>((200.0 / 180.0) * std::ldexp(1.0, z)),
          static_cast<std::int64_t>((110.0 / 180.0) * std::ldexp(1.0, z))};
}

TEST(PlanetDefinitionRanges, EveryNumericFieldIsListedOnce) {
  const std::vector<FieldRange> ranges = numeric_field_ranges();
  const nlohmann::json defaults = definition_defaults();
  std::size_t numeric = 0;
  for (const auto& [name, value] : defaults.items()) {
    if (name == "detail") {
      numeric += value.size();
    } else if (value.is_number() && name != "seed") {
      ++numeric;
    }
  }
  EXPECT_EQ(ranges.size(), numeric);
  std::set<std::string> pointers;
  for (const FieldRange& range : ranges) {
    EXPECT_TRUE(pointers.insert(range.pointer).second) << range.pointer << " is listed twice";
    const nlohmann::json::json_pointer pointer(range.pointer);
    ASSERT_TRUE(defaults.contains(pointer)) << range.pointer << " is no field of a definition";
    const double default_value = defaults[pointer].get<double>();
    EXPECT_TRUE(default_value >= range.lo && default_value <= range.hi)
        << range.pointer << "'s default lies outside its range";
    EXPECT_LT(range.lo, range.hi) << range.pointer;
  }
}

TEST(PlanetDefinitionRanges, ValuesJustOutsideARangeAreRefusedNamingTheField) {
  for (const FieldRange& range : numeric_field_ranges()) {
    const double below = range.lo_open   ? range.lo
                         : range.integer ? range.lo - 1.0
                                         : std::nextafter(range.lo, -HUGE_VAL);
    const double above = range.integer ? range.hi + 1.0 : std::nextafter(range.hi, HUGE_VAL);
    for (const double value : {below, above}) {
      const nlohmann::json document = definition_with(range, value);
      const Result<PlanetDefinition> parsed = parse_planet(document);
      ASSERT_FALSE(parsed.ok()) << document.dump() << " was accepted";
      EXPECT_EQ(parsed.error().pointer, range.pointer) << document.dump();
    }
  }
}

TEST(PlanetDefinitionRanges, EveryFieldAtEitherEndIsRefusedByARelationOrMakesFiniteTiles) {
  std::size_t planets = 0, refused = 0;
  for (const FieldRange& range : numeric_field_ranges()) {
    // The least value accepted: lo, or the next double above it where lo itself is refused (a
    // subnormal above 0, which a client can send as 5e-324).
    const double least = range.lo_open ? std::nextafter(range.lo, HUGE_VAL) : range.lo;
    for (const double value : {least, range.hi}) {
      const nlohmann::json document = definition_with(range, value);
      SCOPED_TRACE(document.dump());
      const Result<PlanetDefinition> definition = parse_planet(document);
      if (!definition.ok()) {
        // Only a relation between fields (sea_depth above river_depth, …) may refuse a value
        // inside its range, and it names a field.
        const std::string& message = definition.error().message;
        EXPECT_FALSE(definition.error().pointer.empty()) << message;
        EXPECT_EQ(message.find("at most"), std::string::npos) << message;
        EXPECT_EQ(message.find("between"), std::string::npos) << message;
        ++refused;
        continue;
      }
      ++planets;
      PlanetTiles tiles(Planet::create(*definition));
      for (const int z : {0, 11, PlanetTiles::max_zoom()}) {
        const Result<terrain::HeightTile> tile =
            tiles.height_tile(tile_at(z), TileFormat::terrain_rgb);
        ASSERT_TRUE(tile.ok()) << "zoom " << z << ": " << tile.error().message;
        std::size_t not_finite = 0;
        for (const float h : tile->elevation) not_finite += std::isfinite(h) ? 0 : 1;
        EXPECT_EQ(not_finite, 0u) << "zoom " << z;
      }
      // Every product reads the planet's constants (its elevation range, the encodings' quanta);
      // small ones, since the constants, not the samples, are what differs between formats.
      terrain::ProductOptions small;
      small.size = 64;
      small.grid = 17;
      for (const terrain::TileFormatInfo& info : terrain::tile_formats()) {
        const Result<terrain::Product> product = tiles.make(tile_at(5), info.format, small);
        EXPECT_TRUE(product.ok()) << info.extension << " " << info.encoding << ": "
                                  << product.error().message;
      }
    }
  }
  // Most ends make planets: the test exercises them, not only the parser.
  EXPECT_GT(planets, 4 * refused);
}

}  // namespace
}  // namespace planet
