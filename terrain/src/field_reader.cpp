#include "field_reader.hpp"

#include <cmath>
#include <limits>

namespace terrain {

const nlohmann::json FieldReader::kEmptyObject = nlohmann::json::object();

std::string pointer_join(std::string_view pointer, std::string_view token) {
  std::string out(pointer);
  out += '/';
  for (char c : token) {
    if (c == '~') {
      out += "~0";
    } else if (c == '/') {
      out += "~1";
    } else {
      out += c;
    }
  }
  return out;
}

std::string pointer_join(std::string_view pointer, std::size_t index) {
  return std::string(pointer) + "/" + std::to_string(index);
}

FieldReader::FieldReader(const nlohmann::json& object, std::string pointer)
    : object_(object.is_object() ? object : kEmptyObject), pointer_(std::move(pointer)) {
  if (!object.is_object()) fail_at("must be a JSON object", pointer_);
}

const nlohmann::json* FieldReader::find(std::string_view key) {
  read_.emplace(key);
  auto it = object_.find(std::string(key));
  return it == object_.end() ? nullptr : &*it;
}

bool FieldReader::has(std::string_view key) const {
  return object_.contains(std::string(key));
}

void FieldReader::fail(std::string message, std::string_view key) {
  fail_at(std::move(message), key.empty() ? pointer_ : pointer_join(pointer_, key));
}

void FieldReader::fail_at(std::string message, std::string pointer) {
  if (!error_) error_ = Error{std::move(message), std::move(pointer)};
}

bool within_as_float(double value, const NumberRule& rule) {
  const float stored = static_cast<float>(value);
  if (!std::isfinite(stored)) return false;
  if (value != 0.0 && std::abs(stored) < std::numeric_limits<float>::min()) return false;
  const float min = static_cast<float>(rule.min), max = static_cast<float>(rule.max);
  return stored >= min && stored <= max && !(rule.exclusive_min && stored <= min);
}

std::string describe_rule(const NumberRule& rule) {
  return "must be " + std::string(rule.exclusive_min ? "greater than " : "at least ") +
         nlohmann::json(rule.min).dump() + " and at most " + nlohmann::json(rule.max).dump();
}

void FieldReader::declare_number(std::string pointer, const NumberRule& rule) {
  if (declared_ != nullptr) {
    declared_->push_back({std::move(pointer), rule.min, rule.max, rule.exclusive_min, false});
  }
}

void FieldReader::skip(std::string_view key) {
  read_.emplace(key);
}

double FieldReader::number(std::string_view key, std::optional<double> fallback, NumberRule rule) {
  const nlohmann::json* value = find(key);
  double v = fallback.value_or(0.0);
  if (value == nullptr) {
    if (!fallback) fail("is required", key);
  } else if (!value->is_number()) {
    fail("must be a number", key);
  } else {
    v = value->get<double>();
    if (!std::isfinite(v)) {
      fail("must be a finite number", key);
      v = fallback.value_or(0.0);
    }
  }
  declare_number(pointer_join(pointer_, key), rule);
  if (ok() && !within_as_float(v, rule)) {
    const bool underflows =
        v != 0.0 && std::abs(static_cast<float>(v)) < std::numeric_limits<float>::min();
    fail(describe_rule(rule) +
             (underflows ? " (it is stored as a float32, where " + nlohmann::json(v).dump() +
                               " is below the "
                               "smallest normal magnitude 1.17549435e-38)"
                         : ""),
         key);
  }
  canonical_[std::string(key)] = v;
  return v;
}

std::int64_t FieldReader::integer(std::string_view key, std::optional<std::int64_t> fallback,
                                  std::int64_t min, std::int64_t max) {
  const nlohmann::json* value = find(key);
  if (declared_ != nullptr) {
    declared_->push_back({pointer_join(pointer_, key), static_cast<double>(min),
                          static_cast<double>(max), false, true});
  }
  std::int64_t v = fallback.value_or(0);
  if (value == nullptr) {
    if (!fallback) fail("is required", key);
  } else if (value->is_number_integer()) {
    v = value->get<std::int64_t>();
  } else if (value->is_number_float() && std::floor(value->get<double>()) == value->get<double>() &&
             std::abs(value->get<double>()) < 9e15) {
    v = static_cast<std::int64_t>(value->get<double>());
  } else {
    fail("must be an integer", key);
  }
  if (ok() && (v < min || v > max)) {
    fail("must be an integer from " + std::to_string(min) + " to " + std::to_string(max), key);
  }
  canonical_[std::string(key)] = v;
  return v;
}

bool FieldReader::boolean(std::string_view key, std::optional<bool> fallback) {
  const nlohmann::json* value = find(key);
  bool v = fallback.value_or(false);
  if (value == nullptr) {
    if (!fallback) fail("is required", key);
  } else if (!value->is_boolean()) {
    fail("must be true or false", key);
  } else {
    v = value->get<bool>();
  }
  canonical_[std::string(key)] = v;
  return v;
}

std::string FieldReader::string(std::string_view key, std::optional<std::string_view> fallback) {
  const nlohmann::json* value = find(key);
  std::string v(fallback.value_or(""));
  if (value == nullptr) {
    if (!fallback) fail("is required", key);
  } else if (!value->is_string()) {
    fail("must be a string", key);
  } else {
    v = value->get<std::string>();
  }
  canonical_[std::string(key)] = v;
  return v;
}

std::string FieldReader::choice(std::string_view key, std::optional<std::string_view> fallback,
                                std::span<const std::string_view> allowed) {
  std::string v = string(key, fallback);
  if (!ok()) return v;
  for (std::string_view a : allowed) {
    if (a == v) return v;
  }
  std::string list;
  for (std::string_view a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
  fail("must be one of: " + list, key);
  return std::string(allowed.front());
}

Vec2 FieldReader::vec2(std::string_view key, std::optional<Vec2> fallback, NumberRule rule) {
  const nlohmann::json* value = find(key);
  Vec2 v = fallback.value_or(Vec2{});
  nlohmann::json canonical = nlohmann::json::array({v.x, v.y});
  declare_number(pointer_join(pointer_join(pointer_, key), 0), rule);
  declare_number(pointer_join(pointer_join(pointer_, key), 1), rule);
  if (value == nullptr) {
    if (!fallback) fail("is required", key);
  } else if (!value->is_array() || value->size() != 2 || !(*value)[0].is_number() ||
             !(*value)[1].is_number()) {
    fail("must be an array of two numbers [x, y]", key);
  } else {
    const double x = (*value)[0].get<double>();
    const double y = (*value)[1].get<double>();
    if (!std::isfinite(x) || !std::isfinite(y) || !within_as_float(x, rule) ||
        !within_as_float(y, rule)) {
      fail("coordinates must be finite and within [" + nlohmann::json(rule.min).dump() + ", " +
               nlohmann::json(rule.max).dump() + "]",
           key);
    } else {
      v = {static_cast<float>(x), static_cast<float>(y)};
      canonical = nlohmann::json::array({x, y});
    }
  }
  canonical_[std::string(key)] = canonical;
  return v;
}

const nlohmann::json* FieldReader::raw(std::string_view key) {
  return find(key);
}

FieldReader FieldReader::nested(std::string_view key) {
  const nlohmann::json* value = find(key);
  FieldReader reader(value != nullptr ? *value : kEmptyObject, pointer_join(pointer_, key));
  reader.declared_ = declared_;
  return reader;
}

void FieldReader::adopt(std::string_view key, FieldReader& nested) {
  nested.reject_unknown();
  if (!nested.ok()) fail_at(nested.error().message, nested.error().pointer);
  canonical_[std::string(key)] = nested.canonical();
}

void FieldReader::reject_unknown() {
  if (!ok()) return;
  for (const auto& [key, value] : object_.items()) {
    if (!read_.contains(key)) {
      fail("is not a known field here", key);
      return;
    }
  }
}

}  // namespace terrain
