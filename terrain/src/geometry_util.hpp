// Small helpers shared by the geometry builders (profiles, contours): number formatting for
// messages, outward float rounding for bounds, and preset error messages.
#pragma once

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "terrain/result.hpp"

namespace terrain::geometry_util {

inline std::string num(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

/// Largest float not above v (v finite).
inline float round_down(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}

/// Smallest float not below v (v finite).
inline float round_up(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

inline Error preset_error(const char* preset, const char* field, const std::string& what,
                          float got) {
  return Error{std::string(preset) + ": " + field + " " + what + ", got " + num(got),
               std::string("/") + field};
}

}  // namespace terrain::geometry_util
