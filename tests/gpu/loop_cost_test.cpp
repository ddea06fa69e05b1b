// The loop cost that decides whether llvmpipe may run a program (loops capped at 65 535 iterations
// an invocation) comes from each node type's own metadata: a quadrangle's corner coordinates are
// not loop counts, so an image far from the origin still runs on the GPU.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "gpu/backend.hpp"
#include "gpu/evaluator.hpp"
#include "terrain/node.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"
#include "terrain/tile_products.hpp"

namespace gpu {
namespace {

terrain::Result<terrain::Raster> ramp_image(std::string_view) {
  terrain::Raster r;
  r.width = 16;
  r.height = 16;
  for (int y = 0; y < r.height; ++y) {
    for (int x = 0; x < r.width; ++x) r.samples.push_back(static_cast<float>(x + y) / 30.0f);
  }
  return r;
}

// An image on a square whose north-west corner is at (x0, y0 + 1000).
terrain::Scene image_scene_at(double x0, double y0) {
  const nlohmann::json corner_nw{x0, y0 + 1000}, corner_ne{x0 + 1000, y0 + 1000},
      corner_se{x0 + 1000, y0}, corner_sw{x0, y0};
  const nlohmann::json doc{
      {"format", "terrain-scene/1"},
      {"name", "far image"},
      {"extent", {{"min", {x0 - 200, y0 - 200}}, {"max", {x0 + 1200, y0 + 1200}}}},
      {"root",
       {{"type", "image"},
        {"image", "ramp.png"},
        {"corners", {corner_nw, corner_ne, corner_se, corner_sw}},
        {"elevation", 10},
        {"height_scale", 300},
        {"margin", 0.1}}}};
  terrain::ParseOptions options;
  options.images = ramp_image;
  terrain::Result<terrain::Scene> scene = terrain::parse_scene(doc, options);
  EXPECT_TRUE(scene.ok()) << scene.error().pointer << ": " << scene.error().message;
  return std::move(scene).value();
}

std::size_t loop_cost_of(const terrain::Scene& scene) {
  terrain::Result<terrain::Program> program = terrain::compile(scene);
  EXPECT_TRUE(program.ok());
  return loop_iterations_per_evaluation(*program);
}

TEST(LoopCost, OfAnImageDoesNotDependOnWhereItsCornersAre) {
  const std::size_t at_origin = loop_cost_of(image_scene_at(-500, -500));
  EXPECT_EQ(loop_cost_of(image_scene_at(40000, 40000)), at_origin);
  EXPECT_EQ(loop_cost_of(image_scene_at(-90000, 90000)), at_origin);
  EXPECT_LT(at_origin, 100u);
}

// A program that llvmpipe refused would fall back to the CPU without a word: the tile must say it
// came from the GPU, and agree with the CPU within one terrain-RGB quantum (0.1 m).
TEST(LoopCost, FarImageTilesAreEvaluatedOnTheGpu) {
  terrain::Result<BackendChoice> choice = choose_backend("gpu");
  ASSERT_TRUE(choice.ok()) << choice.error().message;
  ASSERT_NE(choice->backend, nullptr);
  auto source = terrain::TileSource::from_scene(image_scene_at(40000, 40000));
  ASSERT_TRUE(source.ok()) << source.error().message;
  terrain::ProductMaker cpu(*source), on_gpu(*source);
  on_gpu.set_backend(choice->backend);
  terrain::ProductOptions options;
  options.size = 64;
  for (const terrain::TileAddress address :
       {terrain::TileAddress{0, 0, 0}, terrain::TileAddress{1, 0, 1}}) {
    auto made =
        on_gpu.make(terrain::TileScheme::local, address, terrain::TileFormat::terrain_rgb, options);
    ASSERT_TRUE(made.ok()) << made.error().message;
    EXPECT_EQ(made->backend.rfind("gpu: ", 0), 0u) << made->backend;
    auto a = cpu.height_tile(terrain::TileScheme::local, address, terrain::TileFormat::terrain_rgb,
                             options);
    auto b = on_gpu.height_tile(terrain::TileScheme::local, address,
                                terrain::TileFormat::terrain_rgb, options);
    ASSERT_TRUE(a.ok() && b.ok());
    ASSERT_EQ(a->elevation.size(), b->elevation.size());
    for (std::size_t i = 0; i < a->elevation.size(); ++i) {
      ASSERT_NEAR(a->elevation[i], b->elevation[i], 0.1) << "sample " << i;
    }
  }
}

}  // namespace
}  // namespace gpu
