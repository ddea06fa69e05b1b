// Tiles evaluated on the GPU (llvmpipe here) against the same tiles from the CPU: the issue asks
// for ≥ 99.9 % byte-identical tiles. Every example scene (butte's image node included), terrain-RGB
// and normal maps of 64², every local tile of zooms 2..TERRAIN_GPU_TILES_MAX_ZOOM (default 2:
// 192 tiles, about 13 s on llvmpipe; scripts/gpu_tiles_figure.sh runs zoom 4, 4 032 tiles). The
// contour's angle is computed alike on both sides (portable_atan2); the residual (4 of 4 032
// tiles at zoom 4, mountain-range) is the float-vs-double log of visible_octaves (docs/gpu.md).
// A tile that differs is reported with its address and how far apart its terrain-RGB codes are.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "gpu/backend.hpp"
#include "terrain/tile_products.hpp"

namespace gpu {
namespace {

namespace fs = std::filesystem;

int max_zoom() {
  const char* text = std::getenv("TERRAIN_GPU_TILES_MAX_ZOOM");
  if (text == nullptr) return 2;
  return std::clamp(std::atoi(text), 0, 8);
}

TEST(GpuTiles, EncodeToTheSameBytesAsCpuTiles) {
  terrain::Result<BackendChoice> choice = choose_backend("gpu");
  ASSERT_TRUE(choice.ok()) << choice.error().message;
  ASSERT_NE(choice->backend, nullptr);
  int total = 0, identical = 0, gpu_made = 0;
  std::vector<fs::path> files;  // every example scene
  for (const auto& entry :
       fs::directory_iterator(fs::path(TERRAIN_SOURCE_DIR) / "config" / "scenes")) {
    if (entry.path().extension() == ".json") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    const std::string name = file.stem().string();
    auto scene = terrain::load_scene_file(file.string());
    ASSERT_TRUE(scene.ok()) << name << ": " << scene.error().message;
    auto source = terrain::TileSource::from_scene(*scene);
    ASSERT_TRUE(source.ok());
    terrain::ProductMaker cpu(*source), on_gpu(*source);
    on_gpu.set_backend(choice->backend);
    terrain::ProductOptions options;
    options.size = 64;
    for (int z = 2; z <= max_zoom(); ++z) {
      const std::int64_t side = std::int64_t{1} << z;
      for (std::int64_t y = 0; y < side; ++y) {
        for (std::int64_t x = 0; x < side; ++x) {
          for (terrain::TileFormat format :
               {terrain::TileFormat::terrain_rgb, terrain::TileFormat::normal_map}) {
            const terrain::TileAddress address{z, x, y};
            auto a = cpu.make(terrain::TileScheme::local, address, format, options);
            auto b = on_gpu.make(terrain::TileScheme::local, address, format, options);
            ASSERT_TRUE(a.ok() && b.ok());
            ++total;
            if (b->backend.rfind("gpu: ", 0) == 0) ++gpu_made;
            if (a->bytes == b->bytes) {
              ++identical;
              continue;
            }
            auto ta = cpu.height_tile(terrain::TileScheme::local, address, format, options);
            auto tb = on_gpu.height_tile(terrain::TileScheme::local, address, format, options);
            ASSERT_TRUE(ta.ok() && tb.ok());
            std::size_t differing = 0;
            double worst = 0.0;
            for (std::size_t i = 0; i < ta->elevation.size(); ++i) {
              const double ca = std::round((ta->elevation[i] + 10000.0) * 10.0);
              const double cb = std::round((tb->elevation[i] + 10000.0) * 10.0);
              worst = std::max(worst, std::abs(ca - cb));
              if (ca != cb) ++differing;
            }
            std::cout << "differs: " << name << " " << z << "/" << x << "/" << y << " "
                      << terrain::format_info(format).encoding << ": " << differing
                      << " terrain-RGB codes differ, largest step " << worst << "\n";
          }
        }
      }
    }
  }
  const double share = 100.0 * identical / total;
  std::cout << "GPU tiles byte-identical to CPU tiles: " << identical << " of " << total << " ("
            << share << " %), " << gpu_made << " evaluated on the GPU\n";
  EXPECT_EQ(gpu_made, total);
  EXPECT_GE(share, 99.9);
}

}  // namespace
}  // namespace gpu
