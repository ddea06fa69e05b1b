// The built-in example scenes (config/scenes), parsed and compiled once per benchmark process.
#pragma once

#include <algorithm>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "terrain/program.hpp"
#include "terrain/scene.hpp"

namespace bench {

struct LoadedExample {
  terrain::Scene scene;
  terrain::Program program;
};

inline std::filesystem::path examples_folder() {
  return std::filesystem::path(TERRAIN_SOURCE_DIR) / "config" / "scenes";
}

/// The file of the example `name`.
inline std::string example_file(const std::string& name) {
  return (examples_folder() / (name + ".json")).string();
}

/// The example scenes' names (config/scenes/*.json), sorted: every benchmark covers them all.
inline std::vector<std::string> example_names() {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(examples_folder())) {
    if (entry.path().extension() == ".json") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

/// The example `name` (e.g. "craters"); aborts the benchmark run when it does not load.
inline const LoadedExample& load_example(const std::string& name) {
  static std::map<std::string, LoadedExample> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  terrain::Scene scene = terrain::load_scene_file(example_file(name)).value();
  terrain::Program program = terrain::compile(scene).value();
  return cache.emplace(name, LoadedExample{std::move(scene), std::move(program)}).first->second;
}

}  // namespace bench
