// Every example scene's tile in every format, pinned by the SHA-256 of its bytes
// (goldens/scene_products.json; accept new ones with scripts/accept-product-goldens.sh).
#include <gtest/gtest.h>

#include <string>

#include "../product_goldens.hpp"
#include "example_tile_sources.hpp"
#include "terrain/tile_products.hpp"

namespace terrain {
namespace {

using testing::ProductHashes;

// The tile of the middle of the scene's area at zoom z of a scheme.
TileAddress middle_tile(const TileSource& source, TileScheme scheme, int z) {
  const TileRange r = tiles_covering_area(source, scheme, z);
  return {z, (r.min_x + r.max_x) / 2, (r.min_y + r.max_y) / 2};
}

TEST(ProductGoldens, EveryExampleSceneMakesTheBytesOfItsGeneration) {
  ProductHashes made;
  testing::InputHashes inputs;
  for (const std::string& scene : testing::example_scene_names()) {
    inputs[scene] = testing::example_scene_hash(scene);
    ProductMaker maker(testing::example_source(scene));
    const TileSource& source = maker.source();
    // Each format where clients ask for it: meshes and images in the scene's own grid, images
    // for MapLibre on Web Mercator, quantized-mesh on Cesium's geographic grid.
    const TileAddress local = middle_tile(source, TileScheme::local, 1);
    const int deep = maker.constants().max_useful_zoom[static_cast<int>(TileScheme::geographic)];
    for (const TileFormatInfo& info : tile_formats()) {
      std::vector<std::pair<TileScheme, TileAddress>> where;
      if (info.format == TileFormat::quantized_mesh) {
        where.push_back({TileScheme::geographic,
                         middle_tile(source, TileScheme::geographic, std::max(deep - 3, 0))});
      } else {
        where.push_back({TileScheme::local, local});
        if (!info.mesh) {
          const int z =
              maker.constants().max_useful_zoom[static_cast<int>(TileScheme::webmercator)];
          where.push_back({TileScheme::webmercator,
                           middle_tile(source, TileScheme::webmercator, std::max(z - 3, 0))});
        }
      }
      for (const auto& [scheme, address] : where) {
        const std::string name =
            std::string(scene) + "/" + testing::product_name(scheme, address, info);
        Result<Product> product = maker.make(scheme, address, info.format, {});
        ASSERT_TRUE(product.ok()) << name << ": " << product.error().message;
        made[name] = testing::hash_of(product->bytes);
      }
    }
  }
  testing::check_product_goldens(TERRAIN_SOURCE_DIR "/tests/terrain/goldens/scene_products.json",
                                 inputs, made);
}

}  // namespace
}  // namespace terrain
