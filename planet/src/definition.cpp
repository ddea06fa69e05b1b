#include "planet/definition.hpp"

#include "terrain/json_text.hpp"
#include "terrain/scene.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <vector>

namespace planet {
namespace {

// One row per numeric field: where it lives, its accepted closed range, and whether a bound is
// exclusive. One table drives parsing, validation and the canonical form, so they cannot drift.
struct NumberField {
  const char* name;
  double PlanetDefinition::*member;
  double lo, hi;
  bool lo_open;
  /// Fields added after planets were published: written to the canonical form only when they
  /// differ from the default, so existing definitions keep their ids.
  bool written_when_set = false;
};
struct DetailField {
  const char* name;
  double DetailParams::*member;
  double lo, hi;
  bool lo_open;
};

const std::vector<NumberField>& number_fields() {
  static const std::vector<NumberField> table = {
      {"radius", &PlanetDefinition::radius, 1000.0, 1e8, false},
      {"flattening", &PlanetDefinition::flattening, 0.0, 0.1, false},
      {"land_fraction", &PlanetDefinition::land_fraction, 0.01, 0.95, false},
      {"sea_level", &PlanetDefinition::sea_level, -10000.0, 10000.0, false},
      {"sea_depth", &PlanetDefinition::sea_depth, 0.0, 20000.0, true},
      {"max_river_altitude", &PlanetDefinition::max_river_altitude, 0.0, 20000.0, true},
      {"max_mountain_altitude", &PlanetDefinition::max_mountain_altitude, 0.0, 30000.0, true},
      {"river_depth", &PlanetDefinition::river_depth, 0.0, 2000.0, true},
      {"min_river_length", &PlanetDefinition::min_river_length, 0.0, 1e7, false},
      {"min_river_slope", &PlanetDefinition::min_river_slope, 0.0, 1.0, true},
      {"min_riverbed_slope", &PlanetDefinition::min_riverbed_slope, 0.0, 10.0, true},
      {"min_slope_near_river", &PlanetDefinition::min_slope_near_river, 0.0, 1.0, false},
      {"riverbed_edge_height", &PlanetDefinition::riverbed_edge_height, 0.0, 1000.0, false},
      {"max_ground_slope", &PlanetDefinition::max_ground_slope, 0.0, 10.0, true},
      {"mountain_slope", &PlanetDefinition::mountain_slope, 0.0, 1.0, false},
      {"finest_edge", &PlanetDefinition::finest_edge, 0.01, 100000.0, false},
      {"min_drain_slope", &PlanetDefinition::min_drain_slope, 0.0, 1.0, true, true},
      {"relief_contrast", &PlanetDefinition::relief_contrast, 0.0, 2.0, false, true},
      {"belt_wavelength", &PlanetDefinition::belt_wavelength, 100000.0, 40000000.0, false, true},
      {"belt_height", &PlanetDefinition::belt_height, 0.0, 20000.0, false, true},
      {"plateau_height", &PlanetDefinition::plateau_height, 0.0, 20000.0, false, true},
      {"coastal_plain_width", &PlanetDefinition::coastal_plain_width, 0.0, 2000000.0, false, true},
      {"aridity", &PlanetDefinition::aridity, 0.0, 1.0, false, true},
      {"shelf_width", &PlanetDefinition::shelf_width, 0.0, 1000000.0, false, true},
      {"shelf_depth", &PlanetDefinition::shelf_depth, 1.0, 2000.0, false, true},
      {"river_concavity", &PlanetDefinition::river_concavity, 0.0, 1.0, false, true},
      {"river_slope_area", &PlanetDefinition::river_slope_area, 1.0, 1e14, false, true},
      {"warp", &PlanetDefinition::warp, 0.0, 0.12, false, true},
      {"warp_wavelength", &PlanetDefinition::warp_wavelength, 1000.0, 100000.0, false, true},
  };
  return table;
}

struct IntegerField {
  const char* name;
  int PlanetDefinition::*member;
  int lo, hi;
  bool written_when_set = false;  ///< as NumberField's
};

const std::vector<IntegerField>& integer_fields() {
  static const std::vector<IntegerField> table = {
      {"continents", &PlanetDefinition::continents, 1, 64},
      {"base_faces", &PlanetDefinition::base_faces, 64, 65536},
      {"lakes", &PlanetDefinition::lakes, 0, kMaxLakes, true},
  };
  return table;
}

const std::vector<DetailField>& detail_fields() {
  static const std::vector<DetailField> table = {
      {"amplitude", &DetailParams::amplitude, 0.0, 5000.0, false},
      {"wavelength", &DetailParams::wavelength, 1.0, 1e6, false},
      {"hurst", &DetailParams::hurst, 0.0, 1.5, true},
      {"lacunarity", &DetailParams::lacunarity, 1.5, 4.0, false},
  };
  return table;
}

std::string format_number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

Result<double> read_number(const nlohmann::json& value, const std::string& pointer, double lo,
                           double hi, bool lo_open) {
  if (!value.is_number()) return Error{"must be a number", pointer};
  const double v = value.get<double>();
  if (!std::isfinite(v) || v < lo || v > hi || (lo_open && v == lo)) {
    return Error{"must be " + std::string(lo_open ? "above " : "at least ") + format_number(lo) +
                     " and at most " + format_number(hi) + ", got " + format_number(v),
                 pointer};
  }
  return v;
}

Result<int> read_int(const nlohmann::json& value, const std::string& pointer, int lo, int hi) {
  if (!value.is_number_integer()) return Error{"must be an integer", pointer};
  // Non-negative literals parse as unsigned: compare those without a signed conversion.
  const bool above = value.is_number_unsigned()
                         ? value.get<std::uint64_t>() > static_cast<std::uint64_t>(hi)
                         : value.get<std::int64_t>() > hi;
  const bool below = !value.is_number_unsigned() && value.get<std::int64_t>() < lo;
  if (above || below ||
      (value.is_number_unsigned() && value.get<std::uint64_t>() < static_cast<std::uint64_t>(lo))) {
    return Error{"must be between " + std::to_string(lo) + " and " + std::to_string(hi), pointer};
  }
  return static_cast<int>(value.get<std::int64_t>());
}

// "sha256:" and 64 lowercase hex digits: the form POST /api/v1/images answers, and the only one,
// so that one image has one spelling and one planet id.
bool valid_image_reference(std::string_view text) {
  constexpr std::string_view prefix = "sha256:";
  if (text.size() != prefix.size() + 64 || !text.starts_with(prefix)) return false;
  return std::all_of(text.begin() + static_cast<std::ptrdiff_t>(prefix.size()), text.end(),
                     [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

}  // namespace

std::string_view relief_model_name(ReliefModel model) {
  return model == ReliefModel::drainage ? "drainage" : "displacement";
}

int PlanetDefinition::base_levels() const {
  // Bisection of the octahedron doubles the face count per level: 8·2^k faces.
  const double k = std::log2(static_cast<double>(base_faces) / 8.0);
  return std::clamp(static_cast<int>(std::lround(k)), 3, 13);
}

Result<PlanetDefinition> parse_planet(const nlohmann::json& document) {
  if (!document.is_object()) return Error{"a planet definition is a JSON object", ""};
  PlanetDefinition d;
  for (auto it = document.begin(); it != document.end(); ++it) {
    const std::string& key = it.key();
    const std::string pointer = "/" + key;
    const nlohmann::json& value = it.value();
    if (key == "seed") {
      // Seeds are 64-bit unsigned; a negative or fractional number is a mistake, not a seed.
      if (!value.is_number_unsigned() &&
          !(value.is_number_integer() && value.get<std::int64_t>() >= 0)) {
        return Error{"must be an integer between 0 and 18446744073709551615", pointer};
      }
      d.seed = value.get<std::uint64_t>();
      continue;
    }
    const auto integer = std::find_if(integer_fields().begin(), integer_fields().end(),
                                      [&](const IntegerField& f) { return key == f.name; });
    if (integer != integer_fields().end()) {
      Result<int> n = read_int(value, pointer, integer->lo, integer->hi);
      if (!n) return n.error();
      d.*(integer->member) = *n;
      continue;
    }
    if (key == "relief_model") {
      const ReliefModel models[] = {ReliefModel::displacement, ReliefModel::drainage};
      const auto named = std::find_if(std::begin(models), std::end(models), [&](ReliefModel m) {
        return value.is_string() && value.get<std::string>() == relief_model_name(m);
      });
      if (named == std::end(models)) {
        return Error{"must be \"displacement\" or \"drainage\"", pointer};
      }
      d.relief_model = *named;
      continue;
    }
    if (key == "continent_map") {
      if (!value.is_string() || !valid_image_reference(value.get<std::string>())) {
        return Error{
            "must be the hash of an uploaded image, \"sha256:\" and 64 lowercase hex digits "
            "(POST /api/v1/images answers it); paths and URLs are not accepted",
            pointer};
      }
      d.continent_map = value.get<std::string>();
      continue;
    }
    if (key == "material") {
      Result<terrain::Material> material = terrain::parse_material(value, pointer);
      if (!material) return material.error();
      d.material = *material;
      continue;
    }
    if (key == "detail") {
      if (!value.is_object()) return Error{"must be an object", pointer};
      for (auto jt = value.begin(); jt != value.end(); ++jt) {
        const DetailField* field = nullptr;
        for (const DetailField& f : detail_fields()) {
          if (jt.key() == f.name) field = &f;
        }
        if (field == nullptr) return Error{"unknown field", pointer + "/" + jt.key()};
        Result<double> v =
            read_number(jt.value(), pointer + "/" + jt.key(), field->lo, field->hi, field->lo_open);
        if (!v) return v.error();
        d.detail.*(field->member) = *v;
      }
      continue;
    }
    const NumberField* field = nullptr;
    for (const NumberField& f : number_fields()) {
      if (key == f.name) field = &f;
    }
    if (field == nullptr) return Error{"unknown field", pointer};
    Result<double> v = read_number(value, pointer, field->lo, field->hi, field->lo_open);
    if (!v) return v.error();
    d.*(field->member) = *v;
  }
  // Relations between fields, each reported at the field that breaks it.
  if (d.max_mountain_altitude < d.max_river_altitude) {
    return Error{"must be at least max_river_altitude", "/max_mountain_altitude"};
  }
  if (d.sea_depth <= d.river_depth) {
    return Error{"must exceed river_depth (river mouths lie below sea level)", "/sea_depth"};
  }
  if (d.max_mountain_altitude + d.detail.amplitude * 2.0 + d.sea_depth > 60000.0) {
    return Error{"mountains, detail and ocean depth together span more than 60 km",
                 "/max_mountain_altitude"};
  }
  if (d.continents * 8 > (8 << d.base_levels())) {
    return Error{"more continents than an eighth of the base faces", "/continents"};
  }
  return d;
}

Result<PlanetDefinition> parse_planet_text(std::string_view text) {
  Result<nlohmann::json> document = terrain::parse_json_text(text, "the planet definition");
  if (!document) return document.error();
  return parse_planet(*document);
}

Result<PlanetDefinition> load_planet_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{"cannot read " + path, ""};
  std::stringstream text;
  text << in.rdbuf();
  return parse_planet_text(text.str());
}

namespace {

// The fields of `d` as JSON: every one when `every_field`, else the canonical form's (those
// written when set only where they differ from the defaults).
nlohmann::json fields_json(const PlanetDefinition& d, bool every_field) {
  nlohmann::json out = nlohmann::json::object();
  out["seed"] = d.seed;
  static const PlanetDefinition defaults;
  for (const IntegerField& f : integer_fields()) {
    if (!every_field && f.written_when_set && d.*(f.member) == defaults.*(f.member)) continue;
    out[f.name] = d.*(f.member);
  }
  if (every_field || d.relief_model != defaults.relief_model) {
    out["relief_model"] = relief_model_name(d.relief_model);
  }
  for (const NumberField& f : number_fields()) {
    if (!every_field && f.written_when_set && d.*(f.member) == defaults.*(f.member)) continue;
    out[f.name] = d.*(f.member);
  }
  nlohmann::json detail = nlohmann::json::object();
  for (const DetailField& f : detail_fields()) detail[f.name] = d.detail.*(f.member);
  out["detail"] = std::move(detail);
  if (every_field || !d.continent_map.empty()) out["continent_map"] = d.continent_map;
  if (every_field || !terrain::same_material(d.material, terrain::Material{})) {
    out["material"] = terrain::material_json(d.material);
  }
  return out;
}

}  // namespace

nlohmann::json canonical_json(const PlanetDefinition& d) {
  return fields_json(d, false);
}

nlohmann::json definition_defaults() {
  return fields_json(PlanetDefinition{}, true);
}

std::vector<FieldRange> numeric_field_ranges() {
  std::vector<FieldRange> ranges;
  for (const NumberField& f : number_fields()) {
    ranges.push_back({std::string("/") + f.name, f.lo, f.hi, f.lo_open, false});
  }
  for (const DetailField& f : detail_fields()) {
    ranges.push_back({std::string("/detail/") + f.name, f.lo, f.hi, f.lo_open, false});
  }
  for (const IntegerField& f : integer_fields()) {
    ranges.push_back({std::string("/") + f.name, static_cast<double>(f.lo),
                      static_cast<double>(f.hi), false, true});
  }
  return ranges;
}

std::string canonical_text(const PlanetDefinition& d) {
  return canonical_json(d).dump();
}

std::string planet_id(const PlanetDefinition& d) {
  const std::string text = canonical_text(d);
  return terrain::sha256_hex(text);
}

}  // namespace planet
