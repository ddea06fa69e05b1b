// The built-in example scenes (config/scenes), parsed and compiled once per benchmark process.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "terrain/program.hpp"
#include "terrain/scene.hpp"

namespace bench {

struct LoadedExample {
  terrain::Scene scene;
  terrain::Program program;
};

/// The example `name` (e.g. "craters"); aborts the benchmark run when it does not load.
inline const LoadedExample& load_example(const std::string& name) {
  static std::map<std::string, LoadedExample> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  const std::filesystem::path file =
      std::filesystem::path(TERRAIN_SOURCE_DIR) / "config" / "scenes" / (name + ".json");
  terrain::Scene scene = terrain::load_scene_file(file.string()).value();
  terrain::Program program = terrain::compile(scene).value();
  return cache.emplace(name, LoadedExample{std::move(scene), std::move(program)}).first->second;
}

}  // namespace bench
