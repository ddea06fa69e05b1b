// The default planet's tiles in every format, pinned by the SHA-256 of their bytes
// (goldens/planet_products.json; accept new ones with scripts/accept-product-goldens.sh).
#include <gtest/gtest.h>

#include <string>

#include "../product_goldens.hpp"
#include "planet/definition.hpp"
#include "planet/planet.hpp"
#include "planet/tiles.hpp"

namespace planet {
namespace {

using terrain::TileAddress;
using terrain::TileFormatInfo;
using terrain::TileScheme;

TEST(ProductGoldens, TheDefaultPlanetMakesTheBytesOfItsGeneration) {
  auto definition = load_planet_file(TERRAIN_SOURCE_DIR "/config/planets/default.json");
  ASSERT_TRUE(definition.ok()) << definition.error().message;
  const std::shared_ptr<const Planet> planet = Planet::create(*definition);
  PlanetTiles tiles(planet);
  // A continent from afar, a coast at zoom 6, land at zoom 9 and at zoom 16 near 5° N 175° W,
  // where the detail noise's octaves are drawn (the geographic grid), an open lake at zoom 6
  // (near 6.5° N 105° W since generation 17; 9 % of the tile's samples), and the Web Mercator
  // tiles MapLibre asks for; since generation 22 also the open sea beside the cone point at
  // 0° N 180° at zoom 10, whose floor is refined to edges of about 2 km and no finer.
  const std::pair<TileScheme, TileAddress> places[] = {
      {TileScheme::geographic, {3, 9, 5}},       {TileScheme::geographic, {6, 70, 40}},
      {TileScheme::geographic, {9, 600, 300}},   {TileScheme::geographic, {16, 1820, 34588}},
      {TileScheme::geographic, {6, 26, 34}},     {TileScheme::webmercator, {5, 17, 11}},
      {TileScheme::geographic, {10, 2047, 512}},
  };
  terrain::testing::ProductHashes made;
  const terrain::testing::InputHashes inputs{{"default", planet->id()}};
  for (const auto& [scheme, a] : places) {
    for (const TileFormatInfo& info : terrain::tile_formats()) {
      if (info.mesh && scheme != TileScheme::geographic) continue;
      const std::string name = "default/" + terrain::testing::product_name(scheme, a, info);
      Result<terrain::Product> product = tiles.make(scheme, a, info.format, {});
      ASSERT_TRUE(product.ok()) << name << ": " << product.error().message;
      made[name] = terrain::testing::hash_of(product->bytes);
    }
  }
  terrain::testing::check_product_goldens(
      TERRAIN_SOURCE_DIR "/tests/planet/goldens/planet_products.json", inputs, made);
}

}  // namespace
}  // namespace planet
