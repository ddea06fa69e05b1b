// Reads one JSON object field by field, validating as it goes and recording the canonical form
// (every field explicit, defaults filled in). The first error wins and carries its JSON pointer.
#pragma once

#include <cstdint>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/math.hpp"
#include "terrain/result.hpp"
#include "terrain/scene.hpp"

namespace terrain {

/// Appends an RFC 6901 reference token (escaping ~ and /).
std::string pointer_join(std::string_view pointer, std::string_view token);
std::string pointer_join(std::string_view pointer, std::size_t index);

/// Accepted range of a number: inclusive bounds unless marked exclusive.
struct NumberRule {
  double min = -1e9;
  double max = 1e9;
  bool exclusive_min = false;
};

/// Whether `value` is within `rule` as it will be stored: rounded to float32, compared with the
/// limits rounded to float32. So the documented limits themselves are accepted, the canonical
/// text (which may hold the float's value) parses to the same decision, and a value that rounds
/// to 0 or to a denormal (which the evaluators cannot divide by) is refused unless it is 0.
bool within_as_float(double value, const NumberRule& rule);

/// "must be greater than 0 and at most 10000000" for a rule.
std::string describe_rule(const NumberRule& rule);

class FieldReader {
 public:
  FieldReader(const nlohmann::json& object, std::string pointer);

  double number(std::string_view key, std::optional<double> fallback, NumberRule rule = {});
  std::int64_t integer(std::string_view key, std::optional<std::int64_t> fallback, std::int64_t min,
                       std::int64_t max);
  bool boolean(std::string_view key, std::optional<bool> fallback);
  std::string choice(std::string_view key, std::optional<std::string_view> fallback,
                     std::span<const std::string_view> allowed);
  std::string string(std::string_view key, std::optional<std::string_view> fallback);
  Vec2 vec2(std::string_view key, std::optional<Vec2> fallback, NumberRule rule = {});
  /// Raw access (marks the key as read); nullptr when absent. The caller writes canonical().
  const nlohmann::json* raw(std::string_view key);
  bool has(std::string_view key) const;

  /// A reader over a nested object (absent → empty object, so defaults apply). Merge its result
  /// back with adopt().
  FieldReader nested(std::string_view key);
  void adopt(std::string_view key, FieldReader& nested);

  /// Records the numbers checked from here on (nested readers included) with their rules.
  void declare_numbers_to(std::vector<DeclaredNumber>* declared) { declared_ = declared; }
  /// Records a number checked outside number()/vec2()/integer() (raw arrays).
  void declare_number(std::string pointer, const NumberRule& rule);

  void fail(std::string message, std::string_view key = {});
  void fail_at(std::string message, std::string pointer);
  /// Marks keys handled elsewhere (type, id, children, ref).
  void skip(std::string_view key);
  /// Reports the first unknown key as an error.
  void reject_unknown();

  bool ok() const { return !error_.has_value(); }
  const Error& error() const { return *error_; }
  const std::string& pointer() const { return pointer_; }
  nlohmann::json& canonical() { return canonical_; }
  const nlohmann::json& source() const { return object_; }

 private:
  const nlohmann::json* find(std::string_view key);

  const nlohmann::json& object_;
  std::string pointer_;
  nlohmann::json canonical_ = nlohmann::json::object();
  std::set<std::string, std::less<>> read_;
  std::optional<Error> error_;
  std::vector<DeclaredNumber>* declared_ = nullptr;
  static const nlohmann::json kEmptyObject;
};

}  // namespace terrain
