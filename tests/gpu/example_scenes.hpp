// The example scenes (config/scenes/*.json) that the GPU tests run, and their test names.
#pragma once

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

namespace gpu::examples {

/// Paths of every example scene, sorted.
inline std::vector<std::string> scene_files() {
  std::vector<std::string> files;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes")) {
    if (entry.path().extension() == ".json") files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

/// A scene file's name as a test name: its stem, '-' as '_'.
inline std::string test_name(const std::string& path) {
  std::string name = std::filesystem::path(path).stem().string();
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

}  // namespace gpu::examples
