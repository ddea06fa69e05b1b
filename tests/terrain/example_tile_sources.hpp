// The built-in example scenes (config/scenes) as tile sources, for the tile tests.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>

#include "terrain/tile_source.hpp"

namespace terrain::testing {

inline const std::filesystem::path kExampleScenes =
    std::filesystem::path(TERRAIN_SOURCE_DIR) / "config" / "scenes";

/// Loads and compiles an example scene; a broken example fails the test that asked for it.
inline TileSource example_source(const std::string& name) {
  Result<Scene> scene = load_scene_file((kExampleScenes / (name + ".json")).string());
  if (!scene) throw std::runtime_error(name + ": " + scene.error().message);
  Result<TileSource> source = TileSource::from_scene(*scene);
  if (!source) throw std::runtime_error(name + ": " + source.error().message);
  return std::move(source).value();
}

}  // namespace terrain::testing
