// Command-line arguments of the project's tools: positionals, flags and options with values.
#pragma once

#include <cctype>
#include <cmath>
#include <initializer_list>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "terrain/result.hpp"

namespace tools {

struct CliArgs {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;  ///< flags map to "1"

  bool has(const std::string& key) const { return options.contains(key); }
  std::string get(const std::string& key, const std::string& fallback) const {
    auto it = options.find(key);
    return it == options.end() ? fallback : it->second;
  }
};

/// Splits argv. Arguments in `flags` take no value; any other argument starting with '-' (but
/// not a number such as -12.5) is an option that takes the next argument as its value.
inline terrain::Result<CliArgs> parse_cli_args(int argc, char** argv,
                                               std::initializer_list<const char*> flags) {
  const std::set<std::string> flag_set(flags.begin(), flags.end());
  CliArgs args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool option = a.size() > 1 && a[0] == '-' &&
                        !std::isdigit(static_cast<unsigned char>(a[1])) && a[1] != '.';
    if (!option) {
      args.positional.push_back(a);
    } else if (flag_set.contains(a)) {
      args.options[a] = "1";
    } else if (i + 1 < argc) {
      args.options[a] = argv[++i];
    } else {
      return terrain::Error{"option " + a + " needs a value", a};
    }
  }
  return args;
}

/// A whole argument as a finite number, or nothing (no exceptions, no trailing characters).
inline std::optional<double> parse_number(const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used != text.size() || !std::isfinite(v)) return std::nullopt;
    return v;
  } catch (...) {
    return std::nullopt;
  }
}

/// A whole argument as an integer in [lo, hi], or nothing.
inline std::optional<long long> parse_integer(const std::string& text, long long lo, long long hi) {
  const auto v = parse_number(text);
  if (!v || *v != std::floor(*v) || *v < static_cast<double>(lo) || *v > static_cast<double>(hi)) {
    return std::nullopt;
  }
  return static_cast<long long>(*v);
}

}  // namespace tools
