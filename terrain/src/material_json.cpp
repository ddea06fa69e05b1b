// The material's parameters as JSON (parse_material, material_json), as the floats its
// evaluators read (pack_material) and as the GLSL that names their offsets: all walk
// kMaterialFields, the one list of parameters.
#include <charconv>
#include <cmath>
#include <numbers>
#include <system_error>

#include "field_reader.hpp"
#include "terrain/material.hpp"

namespace terrain {

namespace {

using nlohmann::json;

// The shortest decimal that reads back as `v` (0.36f → 0.36), so that canonical JSON shows the
// numbers people wrote, not their float's binary expansion.
double tidy(float v) {
  char text[32];
  const auto [end, ec] = std::to_chars(text, text + sizeof text, v);
  double out = 0.0;
  std::from_chars(text, end, out);
  return out;
}

float sine_of_degrees(float degrees) {
  return static_cast<float>(std::sin(static_cast<double>(degrees) * std::numbers::pi / 180.0));
}

std::string range_text(const MaterialField& field) {
  return "between " + json(tidy(field.min)).dump() + " and " + json(tidy(field.max)).dump();
}

// One number of a field, checked as it will be stored (a float).
Result<float> read_number(const json& value, const MaterialField& field, std::string pointer) {
  if (!value.is_number()) return Error{"must be a number", std::move(pointer)};
  const double v = value.get<double>();
  const auto stored = static_cast<float>(v);
  if (!std::isfinite(v) || !(stored >= field.min && stored <= field.max)) {
    return Error{"must be " + range_text(field), std::move(pointer)};
  }
  return stored;
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

Result<Rgb> read_colour(const json& value, const MaterialField& field, const std::string& pointer) {
  if (value.is_string()) {
    const std::string& text = value.get_ref<const std::string&>();
    float channels[3] = {};
    bool ok = text.size() == 7 && text[0] == '#';
    for (int i = 0; ok && i < 3; ++i) {
      const int hi = hex_digit(text[1 + 2 * i]), lo = hex_digit(text[2 + 2 * i]);
      ok = hi >= 0 && lo >= 0;
      channels[i] = static_cast<float>(hi * 16 + lo) / 255.0f;
    }
    if (!ok) return Error{"must be \"#rrggbb\" or [r, g, b] with channels 0 to 1", pointer};
    return Rgb{channels[0], channels[1], channels[2]};
  }
  if (!value.is_array() || value.size() != 3) {
    return Error{"must be [r, g, b] with channels 0 to 1, or \"#rrggbb\"", pointer};
  }
  float channels[3] = {};
  for (std::size_t i = 0; i < 3; ++i) {
    Result<float> c = read_number(value[i], field, pointer_join(pointer, i));
    if (!c) return c.error();
    channels[i] = *c;
  }
  return Rgb{channels[0], channels[1], channels[2]};
}

Result<Interval> read_band(const json& value, const MaterialField& field,
                           const std::string& pointer) {
  const bool slopes = field.kind == MaterialFieldKind::slopes;
  if (!value.is_array() || value.size() != 2) {
    return Error{std::string("must be [from, to]: ") +
                     (slopes ? "slopes in degrees" : "heights as fractions of the relief"),
                 pointer};
  }
  Result<float> lo = read_number(value[0], field, pointer_join(pointer, 0));
  if (!lo) return lo.error();
  Result<float> hi = read_number(value[1], field, pointer_join(pointer, 1));
  if (!hi) return hi.error();
  // The model divides by hi − lo, of the sines for slopes: they must differ as stored.
  const bool increasing = slopes ? sine_of_degrees(*lo) < sine_of_degrees(*hi) : *lo < *hi;
  if (!increasing) {
    return Error{"must be greater than the band's start (" + json(tidy(*lo)).dump() + ")",
                 pointer_join(pointer, 1)};
  }
  return Interval{*lo, *hi};
}

}  // namespace

PackedMaterial pack_material(const Material& material) {
  PackedMaterial packed{};
  std::size_t at = 0;
  for (const MaterialField& field : kMaterialFields) {
    if (const auto* colour = std::get_if<Rgb Material::*>(&field.member)) {
      const Rgb& c = material.*(*colour);
      packed[at] = c.r;
      packed[at + 1] = c.g;
      packed[at + 2] = c.b;
    } else if (const auto* band = std::get_if<Interval Material::*>(&field.member)) {
      const Interval& b = material.*(*band);
      const bool slopes = field.kind == MaterialFieldKind::slopes;
      packed[at] = slopes ? sine_of_degrees(b.lo) : b.lo;
      packed[at + 1] = slopes ? sine_of_degrees(b.hi) : b.hi;
    } else {
      packed[at] = material.*std::get<float Material::*>(field.member);
    }
    at += material_field_width(field.kind);
  }
  return packed;
}

std::string material_glsl_declarations() {
  std::string out = "// The material's parameters (terrain::pack_material) and their offsets.\n";
  std::size_t at = 0;
  for (const MaterialField& field : kMaterialFields) {
    std::string name(field.name);
    for (char& c : name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    out += "#define MATERIAL_" + name + " " + std::to_string(at) + "\n";
    at += material_field_width(field.kind);
  }
  out += "#define MATERIAL_FLOATS " + std::to_string(kMaterialFloats) + "\n";
  out += "uniform float u_material[MATERIAL_FLOATS];\n";
  return out;
}

bool same_material(const Material& a, const Material& b) {
  return pack_material(a) == pack_material(b);
}

Result<Material> parse_material(const json& object, std::string_view pointer) {
  if (!object.is_object()) return Error{"must be a JSON object", std::string(pointer)};
  Material material;
  for (auto it = object.begin(); it != object.end(); ++it) {
    const std::string at = pointer_join(pointer, it.key());
    const MaterialField* field = nullptr;
    for (const MaterialField& f : kMaterialFields) {
      if (f.name == it.key()) field = &f;
    }
    if (field == nullptr) {
      std::string known;
      for (const MaterialField& f : kMaterialFields)
        known += (known.empty() ? "" : ", ") + std::string(f.name);
      return Error{"unknown material parameter (known: " + known + ")", at};
    }
    if (const auto* colour = std::get_if<Rgb Material::*>(&field->member)) {
      Result<Rgb> c = read_colour(it.value(), *field, at);
      if (!c) return c.error();
      material.*(*colour) = *c;
    } else if (const auto* band = std::get_if<Interval Material::*>(&field->member)) {
      Result<Interval> b = read_band(it.value(), *field, at);
      if (!b) return b.error();
      material.*(*band) = *b;
    } else {
      Result<float> v = read_number(it.value(), *field, at);
      if (!v) return v.error();
      material.*std::get<float Material::*>(field->member) = *v;
    }
  }
  return material;
}

json material_json(const Material& material) {
  json out = json::object();
  for (const MaterialField& field : kMaterialFields) {
    const std::string name(field.name);
    if (const auto* colour = std::get_if<Rgb Material::*>(&field.member)) {
      const Rgb& c = material.*(*colour);
      out[name] = json::array({tidy(c.r), tidy(c.g), tidy(c.b)});
    } else if (const auto* band = std::get_if<Interval Material::*>(&field.member)) {
      const Interval& b = material.*(*band);
      out[name] = json::array({tidy(b.lo), tidy(b.hi)});
    } else {
      out[name] = tidy(material.*std::get<float Material::*>(field.member));
    }
  }
  return out;
}

}  // namespace terrain
