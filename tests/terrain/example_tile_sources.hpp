// The built-in example scenes (config/scenes) as tile sources, for the tile tests.
#pragma once

#include <algorithm>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "terrain/tile_source.hpp"

namespace terrain::testing {

inline const std::filesystem::path kExampleScenes =
    std::filesystem::path(TERRAIN_SOURCE_DIR) / "config" / "scenes";

/// Every example scene's name (config/scenes/*.json), sorted.
inline std::vector<std::string> example_scene_names() {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(kExampleScenes)) {
    if (entry.path().extension() == ".json") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

/// Loads and compiles an example scene; a broken example fails the test that asked for it.
inline TileSource example_source(const std::string& name) {
  Result<Scene> scene = load_scene_file((kExampleScenes / (name + ".json")).string());
  if (!scene) throw std::runtime_error(name + ": " + scene.error().message);
  Result<TileSource> source = TileSource::from_scene(*scene);
  if (!source) throw std::runtime_error(name + ": " + source.error().message);
  return std::move(source).value();
}

/// An example scene's content hash ("sha256:…"), without baking its grids.
inline std::string example_scene_hash(const std::string& name) {
  ParseOptions options;
  options.bake = false;
  Result<Scene> scene = load_scene_file((kExampleScenes / (name + ".json")).string(), options);
  if (!scene) throw std::runtime_error(name + ": " + scene.error().message);
  return scene->hash;
}

}  // namespace terrain::testing
