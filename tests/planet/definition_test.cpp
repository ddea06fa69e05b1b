// Planet definitions: defaults, canonical JSON and id, and every kind of bad input refused with
// the offending field's JSON pointer.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "planet/definition.hpp"

namespace planet {
namespace {

TEST(PlanetDefinition, MissingFieldsTakeTableTwoDefaults) {
  Result<PlanetDefinition> d = parse_planet_text("{}");
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->radius, 6371000.0);
  EXPECT_EQ(d->continents, 6);
  EXPECT_EQ(d->land_fraction, 0.5);
  EXPECT_EQ(d->river_depth, 300.0);
  EXPECT_EQ(d->min_river_length, 200000.0);
  EXPECT_EQ(d->max_ground_slope, 1.0);
  EXPECT_EQ(d->flattening, 0.0);           // a sphere unless asked otherwise
  EXPECT_EQ(8 << d->base_levels(), 4096);  // ~5000 faces rounded to 8·2^k
}

TEST(PlanetDefinition, CanonicalJsonRoundTripsAndFixesTheId) {
  Result<PlanetDefinition> a = parse_planet_text(
      R"({"seed": 7, "land_fraction": 0.3, "detail": {"hurst": 0.7}, "flattening": 0.0033})");
  ASSERT_TRUE(a.ok()) << a.error().message;
  Result<PlanetDefinition> b = parse_planet(canonical_json(*a));
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(canonical_text(*a), canonical_text(*b));
  EXPECT_EQ(planet_id(*a), planet_id(*b));
  EXPECT_EQ(planet_id(*a).size(), 64u);
  // Key order and whitespace are not part of the identity; every value is.
  Result<PlanetDefinition> c = parse_planet_text(
      R"({ "flattening": 0.0033, "detail": {"hurst": 0.7},  "land_fraction": 0.3, "seed": 7 })");
  EXPECT_EQ(planet_id(*a), planet_id(*c));
  PlanetDefinition d = *a;
  d.seed = 8;
  EXPECT_NE(planet_id(*a), planet_id(d));
  d = *a;
  d.detail.amplitude += 1.0;
  EXPECT_NE(planet_id(*a), planet_id(d));
}

TEST(PlanetDefinition, BadDefinitionsAreRejectedNamingTheField) {
  const struct {
    const char* text;
    const char* pointer;
  } cases[] = {
      {"[1, 2]", ""},
      {"{\"seed\": ", ""},
      {R"({"colour": "blue"})", "/colour"},
      {R"({"seed": -1})", "/seed"},
      {R"({"seed": 1.5})", "/seed"},
      {R"({"radius": "big"})", "/radius"},
      {R"({"radius": 10})", "/radius"},
      {R"({"land_fraction": 1.5})", "/land_fraction"},
      {R"({"continents": 0})", "/continents"},
      {R"({"continents": 2.5})", "/continents"},
      {R"({"base_faces": 10})", "/base_faces"},
      {R"({"river_depth": 0})", "/river_depth"},
      {R"({"max_ground_slope": -1})", "/max_ground_slope"},
      {R"({"flattening": 0.5})", "/flattening"},
      {R"({"min_drain_slope": 0})", "/min_drain_slope"},
      {R"({"min_drain_slope": 2})", "/min_drain_slope"},
      {R"({"relief_model": "eroded"})", "/relief_model"},
      {R"({"relief_model": 1})", "/relief_model"},
      {R"({"relief_contrast": -0.5})", "/relief_contrast"},
      {R"({"relief_contrast": 3})", "/relief_contrast"},
      {R"({"belt_wavelength": 1000})", "/belt_wavelength"},
      {R"({"belt_height": "high"})", "/belt_height"},
      {R"({"belt_height": 50000})", "/belt_height"},
      {R"({"plateau_height": -100})", "/plateau_height"},
      {R"({"river_concavity": 1.5})", "/river_concavity"},
      {R"({"river_slope_area": 0})", "/river_slope_area"},
      {R"({"coastal_plain_width": 3e6})", "/coastal_plain_width"},
      {R"({"coastal_plain_width": null})", "/coastal_plain_width"},
      {R"({"lakes": -1})", "/lakes"},
      {R"({"lakes": 2.5})", "/lakes"},
      {R"({"lakes": 100000})", "/lakes"},
      {R"({"aridity": 1.5})", "/aridity"},
      {R"({"aridity": "dry"})", "/aridity"},
      {R"({"shelf_width": -1})", "/shelf_width"},
      {R"({"shelf_depth": 0})", "/shelf_depth"},
      {R"({"detail": 3})", "/detail"},
      {R"({"detail": {"hurst": 0}})", "/detail/hurst"},
      {R"({"detail": {"octaves": 3}})", "/detail/octaves"},
      {R"({"max_river_altitude": 9000, "max_mountain_altitude": 5000})", "/max_mountain_altitude"},
      {R"({"sea_depth": 100, "river_depth": 300})", "/sea_depth"},
  };
  for (const auto& c : cases) {
    Result<PlanetDefinition> d = parse_planet_text(c.text);
    ASSERT_FALSE(d.ok()) << c.text;
    EXPECT_EQ(d.error().pointer, c.pointer) << c.text << ": " << d.error().message;
    EXPECT_FALSE(d.error().message.empty());
  }
}

TEST(PlanetDefinition, TheBuiltInDefaultPlanetParses) {
  Result<PlanetDefinition> d = load_planet_file(TERRAIN_SOURCE_DIR "/config/planets/default.json");
  ASSERT_TRUE(d.ok()) << d.error().pointer << ": " << d.error().message;
  EXPECT_LT(d->max_river_altitude, d->max_mountain_altitude);
}

TEST(PlanetDefinition, ContinentMapIsPartOfTheCanonicalJsonAndTheId) {
  const std::string hash = "sha256:" + std::string(64, 'a');
  Result<PlanetDefinition> with =
      parse_planet_text(R"({"seed": 7, "continent_map": ")" + hash + R"("})");
  ASSERT_TRUE(with.ok()) << with.error().message;
  EXPECT_EQ(with->continent_map, hash);
  EXPECT_EQ(canonical_json(*with).at("continent_map"), hash);
  Result<PlanetDefinition> back = parse_planet(canonical_json(*with));
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(planet_id(*back), planet_id(*with));
  // Another image is another planet, and so is none.
  PlanetDefinition other = *with;
  other.continent_map = "sha256:" + std::string(64, 'b');
  EXPECT_NE(planet_id(other), planet_id(*with));
  Result<PlanetDefinition> without = parse_planet_text(R"({"seed": 7})");
  ASSERT_TRUE(without.ok());
  EXPECT_NE(planet_id(*without), planet_id(*with));
  // Without a map the field is left out, so planets defined before it existed keep their ids.
  EXPECT_FALSE(canonical_json(*without).contains("continent_map"));
}

TEST(PlanetDefinition, MaterialIsInTheIdOnlyWhenItDrawsDifferently) {
  Result<PlanetDefinition> plain = parse_planet_text(R"({"seed": 7})");
  Result<PlanetDefinition> defaults =
      parse_planet_text(R"({"seed": 7, "material": {"snow_polar": 0.7}})");
  Result<PlanetDefinition> arctic =
      parse_planet_text(R"({"seed": 7, "material": {"snow_polar": 1.2}})");
  ASSERT_TRUE(plain.ok() && defaults.ok() && arctic.ok());
  EXPECT_EQ(planet_id(*defaults), planet_id(*plain));
  EXPECT_FALSE(canonical_json(*plain).contains("material"));
  EXPECT_NE(planet_id(*arctic), planet_id(*plain));
  EXPECT_EQ(canonical_json(*arctic).at("material").at("snow_polar"), 1.2);
  Result<PlanetDefinition> back = parse_planet(canonical_json(*arctic));
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(planet_id(*back), planet_id(*arctic));
}

TEST(PlanetDefinition, FieldsAddedLaterAreInTheIdOnlyWhenTheyDifferFromTheDefaults) {
  // Each with its default and another value: planets defined before the field keep their ids.
  const struct {
    const char* name;
    nlohmann::json default_value, other;
  } fields[] = {
      {"min_drain_slope", 0.03, 0.01},
      {"relief_contrast", 1.0, 0.0},
      {"belt_wavelength", 4000000.0, 2000000.0},
      {"belt_height", 3000.0, 0.0},
      {"plateau_height", 1500.0, 0.0},
      {"coastal_plain_width", 300000.0, 100000.0},
      {"lakes", 24, 0},
      {"aridity", 0.35, 1.0},
      {"shelf_width", 80000.0, 0.0},
      {"shelf_depth", 130.0, 200.0},
      {"river_concavity", 0.5, 0.0},
      {"river_slope_area", 1e9, 1e10},
      {"relief_model", "drainage", "displacement"},
  };
  Result<PlanetDefinition> plain = parse_planet_text(R"({"seed": 7})");
  ASSERT_TRUE(plain.ok());
  for (const auto& field : fields) {
    SCOPED_TRACE(field.name);
    Result<PlanetDefinition> defaults =
        parse_planet({{"seed", 7}, {field.name, field.default_value}});
    Result<PlanetDefinition> changed = parse_planet({{"seed", 7}, {field.name, field.other}});
    ASSERT_TRUE(defaults.ok() && changed.ok());
    EXPECT_EQ(planet_id(*defaults), planet_id(*plain));  // the default is the missing field's
    EXPECT_FALSE(canonical_json(*plain).contains(field.name));
    EXPECT_NE(planet_id(*changed), planet_id(*plain));
    EXPECT_EQ(canonical_json(*changed).at(field.name), field.other);
    Result<PlanetDefinition> back = parse_planet(canonical_json(*changed));
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(planet_id(*back), planet_id(*changed));
  }
}

TEST(PlanetDefinition, BadMaterialsAreRejectedNamingTheField) {
  for (const auto& [text, pointer] : std::vector<std::pair<std::string, std::string>>{
           {R"({"material": 3})", "/material"},
           {R"({"material": {"lava": [1, 0, 0]}})", "/material/lava"},
           {R"({"material": {"snow_slope": [45, 30]}})", "/material/snow_slope/1"},
           {R"({"material": {"sand": [0.5, 0.5, -1]}})", "/material/sand/2"}}) {
    Result<PlanetDefinition> d = parse_planet_text(text);
    ASSERT_FALSE(d.ok()) << text;
    EXPECT_EQ(d.error().pointer, pointer) << text;
  }
}

TEST(PlanetDefinition, ContinentMapMustBeAnImageHashNeverAPathOrUrl) {
  const std::string hex(64, '0');
  for (const std::string& value :
       {std::string("5"), std::string("null"), std::string("\"maps/earth.png\""),
        std::string("\"https://example.com/earth.png\""), std::string("\"file:///etc/passwd\""),
        "\"" + hex + "\"", "\"sha256:" + hex.substr(1) + "\"", "\"sha256:" + hex + "0\"",
        "\"SHA256:" + hex + "\"", "\"sha256:" + std::string(64, 'A') + "\"",
        "\"sha256:" + std::string(63, '0') + "g\"", std::string("\"\"")}) {
    Result<PlanetDefinition> d = parse_planet_text(R"({"continent_map": )" + value + "}");
    ASSERT_FALSE(d.ok()) << value;
    EXPECT_EQ(d.error().pointer, "/continent_map") << value;
  }
}

// docs/planet.md's table of fields ("| `name` | default | …"), read as name → default cell.
std::map<std::string, std::string> documented_fields() {
  std::ifstream in(TERRAIN_SOURCE_DIR "/docs/planet.md");
  std::map<std::string, std::string> rows;
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (line.starts_with("| Field | Default |")) {
      inside = true;
      continue;
    }
    if (!inside || line.starts_with("|---")) continue;
    if (!line.starts_with("| `")) break;
    const std::size_t name_end = line.find('`', 3);
    const std::size_t cell = line.find('|', name_end) + 1;
    rows[line.substr(3, name_end - 3)] = line.substr(cell, line.find('|', cell) - cell);
  }
  return rows;
}

// A documented number: digits with spaces between thousands, a decimal point, or 10 with a
// superscript exponent ("10⁹"); whatever follows in parentheses is a gloss.
double documented_number(std::string text) {
  text = text.substr(0, text.find('('));
  std::string digits;
  int exponent = 0, sign = 1;
  bool superscript = false;
  static const std::vector<std::string> powers = {"⁰", "¹", "²", "³", "⁴", "⁵", "⁶", "⁷", "⁸", "⁹"};
  for (std::size_t i = 0; i < text.size();) {
    bool matched = false;
    for (int d = 0; d < 10; ++d) {
      if (text.compare(i, powers[static_cast<std::size_t>(d)].size(),
                       powers[static_cast<std::size_t>(d)]) == 0) {
        exponent = exponent * 10 + d;
        superscript = matched = true;
        i += powers[static_cast<std::size_t>(d)].size();
      }
    }
    if (matched) continue;
    if (text.compare(i, 3, "⁻") == 0) {
      sign = -1;
      i += 3;
      continue;
    }
    const char c = text[i++];
    if ((c >= '0' && c <= '9') || c == '.') digits += c;
  }
  const double mantissa = std::stod(digits);
  return superscript ? std::pow(mantissa, sign * exponent) : mantissa;
}

TEST(PlanetDocs, DescribeEveryFieldWithItsDefault) {
  const std::map<std::string, std::string> documented = documented_fields();
  ASSERT_GT(documented.size(), 20u) << "docs/planet.md's table of fields was not found";
  const nlohmann::json every_field = definition_defaults();
  std::map<std::string, nlohmann::json> defaults;
  for (const auto& [name, value] : every_field.items()) {
    if (name == "detail") {
      for (const auto& [inner, v] : value.items()) defaults["detail." + inner] = v;
    } else {
      defaults[name] = value;
    }
  }
  for (const auto& [name, value] : defaults) {
    const auto row = documented.find(name);
    if (row == documented.end()) {
      ADD_FAILURE() << "docs/planet.md has no row for " << name;
      continue;
    }
    if (!value.is_number()) continue;  // continent_map ("none"), material ("defaults")
    EXPECT_NEAR(documented_number(row->second), value.get<double>(),
                1e-9 * std::abs(value.get<double>()))
        << name << " is documented with the default" << row->second;
  }
  for (const auto& [name, cell] : documented) {
    EXPECT_TRUE(defaults.contains(name))
        << "docs/planet.md documents " << name << ", which is no field of a definition";
  }
}

}  // namespace
}  // namespace planet
