// Continents from a bitmap instead of grown at random: land faces where the map is land,
// continents as its connected components, the map's land share, rivers that still reach the sea,
// the same mesh from the same bytes whatever the threads or process, and bad maps refused with
// the field named. The maps are drawn here from spherical caps, so the test knows the truth.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <numbers>

#include "default_definition.hpp"
#include "planet/continent_map.hpp"
#include "planet/planet.hpp"
#include "river_walk.hpp"
#include "terrain/image_io.hpp"

namespace planet {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

struct Cap {
  double latitude, longitude, radius;  // degrees
  bool holds(double lat, double lon) const {
    const double c = std::sin(lat * kDegree) * std::sin(latitude * kDegree) +
                     std::cos(lat * kDegree) * std::cos(latitude * kDegree) *
                         std::cos((lon - longitude) * kDegree);
    return c >= std::cos(radius * kDegree);
  }
  double area_share() const { return (1.0 - std::cos(radius * kDegree)) / 2.0; }
};

// One big continent astride nothing special, and a small island across the antimeridian.
constexpr Cap kBlob{20.0, 30.0, 50.0};
constexpr Cap kIsland{-35.0, 178.0, 8.0};

bool truth(double lat, double lon) {
  return kBlob.holds(lat, lon) || kIsland.holds(lat, lon);
}

// An 8-bit greyscale PNG of the two caps, pixel-is-area (sampled at pixel centres).
std::vector<std::uint8_t> caps_png(int width = 512, int height = 256) {
  std::vector<std::uint8_t> pixels(static_cast<std::size_t>(width) *
                                   static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double lat = 90.0 - 180.0 * (y + 0.5) / height;
      const double lon = -180.0 + 360.0 * (x + 0.5) / width;
      pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
             static_cast<std::size_t>(x)] = truth(lat, lon) ? 255 : 0;
    }
  }
  return terrain::encode_png_gray8(width, height, pixels.data()).value();
}

const std::vector<std::uint8_t>& png() {
  static const std::vector<std::uint8_t> bytes = caps_png();
  return bytes;
}

const ContinentMap& map() {
  static const ContinentMap decoded = decode_continent_map(png()).value();
  return decoded;
}

PlanetDefinition definition() {
  PlanetDefinition d = test::default_definition(5);
  d.land_fraction = 0.7;  // ignored with a map
  d.continents = 9;       // ignored with a map
  d.continent_map = map().hash;
  return d;
}

const BaseMesh& mesh() {
  static const std::unique_ptr<BaseMesh> built = build_base_mesh(definition(), {}, &map());
  return *built;
}

Vec3d centroid(const Hierarchy& h, std::int32_t t) {
  const Tri& tri = h.tris[static_cast<std::size_t>(t)];
  return normalize(
      add(add(h.vertices[tri.v[0]].p, h.vertices[tri.v[1]].p), h.vertices[tri.v[2]].p));
}

TEST(PlanetContinentMap, DecodesAGreyscalePngWithItsHash) {
  const ContinentMap& m = map();
  EXPECT_EQ(m.width, 512);
  EXPECT_EQ(m.height, 256);
  EXPECT_EQ(m.hash, continent_map_reference(png()));
  EXPECT_EQ(m.hash.rfind("sha256:", 0), 0u);
  EXPECT_EQ(m.sample(kBlob.latitude, kBlob.longitude), 1.0);
  EXPECT_EQ(m.sample(-60.0, -60.0), 0.0);
  // 16-bit maps are as good: values are v / 65535.
  std::vector<std::uint16_t> grey(64 * 32, 0);
  grey[5] = 65535;
  const auto bytes16 = terrain::encode_png16(64, 32, grey.data()).value();
  Result<ContinentMap> m16 = decode_continent_map(bytes16);
  ASSERT_TRUE(m16.ok()) << m16.error().message;
  EXPECT_EQ(m16->values[5], 1.0f);
  EXPECT_EQ(m16->values[6], 0.0f);
}

TEST(PlanetContinentMap, SamplesBilinearlyAcrossTheAntimeridianAndClampsAtThePoles) {
  ContinentMap m;
  m.width = 16;
  m.height = 8;
  m.values.assign(16 * 8, 0.0f);
  for (int y = 0; y < 8; ++y) m.values[static_cast<std::size_t>(y) * 16] = 1.0f;  // column 0
  ASSERT_TRUE(m.validate().ok());
  // Column 0's centre is at −180 + 11.25: half way to column 15's centre lies the antimeridian.
  EXPECT_DOUBLE_EQ(m.sample(10.0, -180.0 + 11.25), 1.0);
  EXPECT_DOUBLE_EQ(m.sample(10.0, -180.0), 0.5);
  EXPECT_DOUBLE_EQ(m.sample(10.0, 180.0), 0.5);
  EXPECT_DOUBLE_EQ(m.sample(90.0, -180.0 + 11.25), 1.0);
  EXPECT_DOUBLE_EQ(m.sample(-90.0, -180.0 + 22.5 + 11.25), 0.0);
  EXPECT_TRUE(m.land(0.0, -180.0));  // 0.5 is land: the threshold is inclusive
  EXPECT_FALSE(m.land(0.0, -180.0 + 22.5 + 11.25));
}

TEST(PlanetContinentMap, LandFacesAreWhereTheBitmapIsLand) {
  const BaseMesh& m = mesh();
  const Geodesy geodesy(definition().radius, definition().flattening);
  int agree = 0, island = 0;
  for (std::int32_t t : m.river_faces) {
    double lat = 0, lon = 0;
    geodesy.direction_to_geographic(centroid(m.hierarchy, t), lat, lon);
    const bool land = m.hierarchy.tris[static_cast<std::size_t>(t)].face == FaceType::land;
    agree += land == truth(lat, lon) ? 1 : 0;
    island += land && kIsland.holds(lat, lon) ? 1 : 0;
  }
  EXPECT_GE(agree, 0.98 * static_cast<double>(m.river_faces.size()))
      << agree << " of " << m.river_faces.size();
  EXPECT_GT(island, 5);  // the island is there (about 20 faces' worth of area)
  // The blob and the island are apart: at least two continents, not the definition's nine.
  EXPECT_GE(m.stats.continents, 2);
  EXPECT_LT(m.stats.continents, 9);
}

TEST(PlanetContinentMap, LandFractionIsTheMapsAreaWeightedLandShare) {
  const double share = map().land_fraction();
  EXPECT_NEAR(share, kBlob.area_share() + kIsland.area_share(), 0.005);
  EXPECT_NEAR(mesh().stats.land_fraction, share, 0.02);
  // The definition's 0.7 was ignored.
  EXPECT_LT(mesh().stats.land_fraction, 0.3);
}

TEST(PlanetContinentMap, RiversStillFallToAMouthAtSeaLevel) {
  const BaseMesh& m = mesh();
  const auto& vertices = m.hierarchy.vertices;
  int rivers = 0;
  for (std::size_t v = 0; v < m.downstream.size(); ++v) {
    if ((vertices[v].flags & kLand) == 0) continue;
    ASSERT_NE(vertices[v].flags & kRiver, 0) << "every continental vertex is on a river";
    ++rivers;
    const std::size_t at = test::follow_river(m, v);
    if ((vertices[at].flags & kLake) != 0) continue;  // or in a lake (PlanetLakes.*)
    ASSERT_NE(vertices[at].flags & kCoast, 0) << "a river ends in the sea";
    EXPECT_EQ(vertices[at].water, definition().sea_level);
    EXPECT_LT(vertices[at].ground, vertices[at].water);
  }
  EXPECT_EQ(m.stats.endorheic, 0);
  EXPECT_GT(rivers, 100);
  EXPECT_GT(m.stats.mouths, 10);
}

TEST(PlanetContinentMap, SamplesAreLandOnTheMapsLandAndSeaElsewhere) {
  Result<std::shared_ptr<const Planet>> world = Planet::build(definition(), &map());
  ASSERT_TRUE(world.ok()) << world.error().message;
  Sampler sampler(*world);
  const PointSample inland = sampler.sample(kBlob.latitude, kBlob.longitude);
  EXPECT_NE(inland.type, SurfaceType::sea);
  EXPECT_GT(inland.ground, definition().sea_level);
  const PointSample ocean = sampler.sample(-60.0, -60.0);
  EXPECT_EQ(ocean.type, SurfaceType::sea);
  EXPECT_LT(ocean.ground, ocean.water);
}

TEST(PlanetContinentMap, ConePointsStaySeaUnderTheMapsLand) {
  // The blob holds 0° N 0°, one of the octahedron's cone points (base_mesh.hpp kConePointSea):
  // the faces beside it are sea all the same, and so is the point.
  ASSERT_TRUE(kBlob.holds(0.0, 0.0));
  const BaseMesh& m = mesh();
  int beside = 0;
  for (std::int32_t t : m.river_faces) {
    const Tri& tri = m.hierarchy.tris[static_cast<std::size_t>(t)];
    if (!touches_cone_point(m.hierarchy, tri)) continue;
    ++beside;
    EXPECT_EQ(tri.face, FaceType::sea) << "face " << t;
  }
  EXPECT_GE(beside, 4);
  Result<std::shared_ptr<const Planet>> world = Planet::build(definition(), &map());
  ASSERT_TRUE(world.ok()) << world.error().message;
  Sampler sampler(*world);
  EXPECT_EQ(sampler.sample(0.0, 0.0).type, SurfaceType::sea);
  EXPECT_NE(sampler.sample(0.0, 10.0).type, SurfaceType::sea);
}

TEST(PlanetContinentMap, SameBytesGiveTheSameMeshWhateverTheThreads) {
  const PlanetDefinition d = definition();
  const ContinentMap again = decode_continent_map(caps_png()).value();
  const std::string one = build_base_mesh(d, {1}, &map())->hash();
  EXPECT_EQ(one, build_base_mesh(d, {1}, &again)->hash());
  EXPECT_EQ(one, build_base_mesh(d, {2}, &again)->hash());
  EXPECT_EQ(one, build_base_mesh(d, {4}, &again)->hash());
  EXPECT_NE(one, build_base_mesh(d, {1})->hash());  // random continents are another planet
  Result<std::shared_ptr<const Planet>> world = Planet::build(d, &again, {2});
  ASSERT_TRUE(world.ok()) << world.error().message;
  EXPECT_EQ((*world)->base_mesh().hash(), one);
  EXPECT_EQ((*world)->id(), planet_id(d));
}

TEST(PlanetContinentMap, MeshHashIsIdenticalInAnotherProcess) {
  const std::string dir = testing::TempDir();
  const std::string image = dir + "/continent_map_caps.png";
  const std::string planet_file = dir + "/continent_map_planet.json";
  const std::string out = dir + "/continent_map_mesh.json";
  std::ofstream(image, std::ios::binary)
      .write(reinterpret_cast<const char*>(png().data()),
             static_cast<std::streamsize>(png().size()));
  // The file names no map: the CLI's --continent-map sets it to the file's hash.
  PlanetDefinition d = definition();
  d.continent_map.clear();
  std::ofstream(planet_file) << canonical_json(d).dump();
  const std::string command = std::string(PLANET_CLI) + " mesh " + planet_file +
                              " --continent-map " + image + " --threads 2 > " + out;
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  std::ifstream in(out);
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report.at("hash").get<std::string>(), mesh().hash());
  EXPECT_EQ(report.at("id").get<std::string>(), planet_id(definition()));
  // A definition that names a map cannot be built without it.
  std::ofstream(planet_file) << canonical_json(definition()).dump();
  const std::string without =
      std::string(PLANET_CLI) + " mesh " + planet_file + " > " + out + " 2>&1";
  EXPECT_NE(std::system(without.c_str()), 0);
}

// A PNG whose header claims other dimensions: refused from the header alone (the pixel data no
// longer matches and is never decoded).
std::vector<std::uint8_t> with_header_size(std::vector<std::uint8_t> bytes, std::uint32_t width,
                                           std::uint32_t height) {
  for (int i = 0; i < 4; ++i) {
    bytes[static_cast<std::size_t>(16 + i)] = static_cast<std::uint8_t>(width >> (24 - 8 * i));
    bytes[static_cast<std::size_t>(20 + i)] = static_cast<std::uint8_t>(height >> (24 - 8 * i));
  }
  return bytes;
}

TEST(PlanetContinentMap, BadMapsAreRefusedNamingTheField) {
  std::vector<std::uint8_t> grey(64 * 64, 0);
  std::vector<std::uint8_t> rgb(32 * 16 * 3, 0);
  const std::string text = "not an image at all, not even close to one";
  const std::vector<std::uint8_t> truncated(png().begin(), png().begin() + 60);
  const struct {
    const char* what;
    std::vector<std::uint8_t> bytes;
  } cases[] = {
      {"empty", {}},
      {"text", std::vector<std::uint8_t>(text.begin(), text.end())},
      {"TIFF", terrain::encode_float_tiff(32, 16, std::vector<float>(32 * 16, 0.f).data()).value()},
      {"colour", terrain::encode_png_rgb8(32, 16, rgb.data()).value()},
      {"square", terrain::encode_png_gray8(64, 64, grey.data()).value()},
      {"too small", terrain::encode_png_gray8(8, 4, grey.data()).value()},
      {"three to one", terrain::encode_png_gray8(48, 16, grey.data()).value()},
      {"too large", with_header_size(png(), 16384, 8192)},
      {"too high", with_header_size(png(), 8192, 4097)},
      {"truncated", truncated},
  };
  for (const auto& c : cases) {
    Result<ContinentMap> m = decode_continent_map(c.bytes);
    ASSERT_FALSE(m.ok()) << c.what;
    EXPECT_EQ(m.error().pointer, "/continent_map") << c.what << ": " << m.error().message;
    EXPECT_FALSE(m.error().message.empty());
  }
  // Pixels made in memory are checked too.
  ContinentMap bad;
  bad.width = 32;
  bad.height = 16;
  bad.values.assign(32 * 16, 0.0f);
  bad.values[40] = 2.0f;
  PlanetDefinition d = definition();
  Result<std::shared_ptr<const Planet>> built = Planet::build(d, &bad);
  ASSERT_FALSE(built.ok());
  EXPECT_EQ(built.error().pointer, "/continent_map");
  bad.values[40] = std::nanf("");
  EXPECT_FALSE(bad.validate().ok());
}

TEST(PlanetContinentMap, PlanetsAreBuiltOnlyWithTheMapTheirDefinitionNames) {
  const PlanetDefinition named = definition();
  PlanetDefinition unnamed = named;
  unnamed.continent_map.clear();
  const ContinentMap other = decode_continent_map(caps_png(256, 128)).value();
  // Named but not given; given but not named; given another.
  for (Result<std::shared_ptr<const Planet>> r :
       {Planet::build(named, nullptr), Planet::build(unnamed, &map()),
        Planet::build(named, &other)}) {
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().pointer, "/continent_map") << r.error().message;
  }
  EXPECT_EQ(Planet::create(named), nullptr);
  Result<std::shared_ptr<const Planet>> from_json = Planet::from_json(canonical_json(named));
  ASSERT_FALSE(from_json.ok());
  EXPECT_EQ(from_json.error().pointer, "/continent_map");
  // A map made in memory has no hash: the caller vouches for it.
  ContinentMap in_memory = map();
  in_memory.hash.clear();
  Result<std::shared_ptr<const Planet>> vouched = Planet::build(named, &in_memory);
  ASSERT_TRUE(vouched.ok()) << vouched.error().message;
  EXPECT_EQ((*vouched)->base_mesh().hash(), mesh().hash());
}

}  // namespace
}  // namespace planet
