// The planet routes end to end (the real terrain-server binary, real sockets): definitions are
// stored by content hash, the built-in default planet has an alias, products on the geographic
// tiling carry strong ETags and are the planet library's bytes whichever process makes them,
// and bad input is refused with problem+json naming the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>
#include <tuple>

#include "http_harness.hpp"
#include "planet/continent_map.hpp"
#include "planet/definition.hpp"
#include "planet/planet.hpp"
#include "planet/tiles.hpp"
#include "terrain/gzip.hpp"
#include "terrain/image_io.hpp"
#include "terrain/quantized_mesh.hpp"

namespace http_test {
namespace {

constexpr const char* kImmutable = "public, max-age=31536000, immutable";
constexpr const char* kQuantizedMeshWithExtensions =
    "application/vnd.quantized-mesh;extensions=octvertexnormals-watermask-metadata";
// A small planet of its own (fewer base faces build faster), for writes.
constexpr const char* kSmallPlanet = R"({"seed": 77, "base_faces": 600, "land_fraction": 0.4})";

planet::PlanetDefinition default_definition() {
  return planet::load_planet_file(std::string(TERRAIN_SOURCE_DIR) + "/config/planets/default.json")
      .value();
}

std::vector<std::uint8_t> bytes_of(const std::string& s) {
  return {s.begin(), s.end()};
}

void expect_problem(const Response& r, unsigned status, const std::string& pointer) {
  EXPECT_EQ(r.result_int(), status) << r.body();
  EXPECT_EQ(header(r, http::field::content_type), "application/problem+json");
  const json body = json::parse(r.body(), nullptr, false);
  ASSERT_TRUE(body.is_object()) << r.body();
  EXPECT_EQ(body.value("status", 0), static_cast<int>(status));
  if (!pointer.empty()) {
    EXPECT_EQ(body.value("pointer", std::string("(none)")), pointer);
  }
}

class HttpPlanets : public SharedServerTest<HttpPlanets> {
 public:
  static constexpr const char* kFolder = "planets";
  static std::vector<std::string> server_arguments() {
    return {"--write-token", kToken, "--cors-origins", "https://a.example"};
  }
  static void SetUpTestSuite() {
    SharedServerTest::SetUpTestSuite();
    default_id_ = planet::planet_id(default_definition());
  }

 protected:
  Response post(std::string_view body, const Headers& headers = with_token()) const {
    return http_test::fetch(port_, "POST", "/api/v1/planets", headers, body);
  }
  std::size_t planet_count() const { return body_json(get("/api/v1/planets"))["planets"].size(); }

  static inline std::string default_id_;
};

TEST_F(HttpPlanets, ListHoldsTheBuiltInDefaultPlanet) {
  const Response r = get("/api/v1/planets");
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  const json list = body_json(r);
  EXPECT_EQ(list["default"], default_id_);
  bool found = false;
  for (const json& p : list["planets"]) {
    if (p["id"] != default_id_) continue;
    found = true;
    EXPECT_TRUE(p["default"].get<bool>());
    EXPECT_EQ(p["url"], "/api/v1/planets/" + default_id_);
    EXPECT_EQ(p["definition"], planet::canonical_json(default_definition()));
  }
  EXPECT_TRUE(found) << r.body();
}

TEST_F(HttpPlanets, DefinitionIsCanonicalWithAnImmutableStrongEtag) {
  const std::string url = "/api/v1/planets/" + default_id_;
  const Response r = get(url);
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(r.body(), planet::canonical_text(default_definition()));
  EXPECT_EQ(header(r, http::field::etag), etag_of(default_id_));
  EXPECT_EQ(header(r, http::field::cache_control), kImmutable);
  EXPECT_EQ(get(url, {{"If-None-Match", etag_of(default_id_)}}).result_int(), 304u);
  // The alias answers the same definition, revalidated now and then rather than kept forever.
  const Response alias = get("/api/v1/planets/default");
  ASSERT_EQ(alias.result_int(), 200u);
  EXPECT_EQ(alias.body(), r.body());
  EXPECT_EQ(header(alias, http::field::etag), etag_of(default_id_));
  EXPECT_EQ(header(alias, http::field::content_location), url);
  EXPECT_NE(header(alias, http::field::cache_control), kImmutable);
}

TEST_F(HttpPlanets, PostingADefinitionAnswers201ThenTheSameIdWith200) {
  const Response created = post(kSmallPlanet);
  ASSERT_TRUE(created.result_int() == 201u || created.result_int() == 200u) << created.body();
  const json body = body_json(created);
  const planet::PlanetDefinition expected = planet::parse_planet_text(kSmallPlanet).value();
  EXPECT_EQ(body["id"], planet::planet_id(expected));
  EXPECT_EQ(body["url"], "/api/v1/planets/" + planet::planet_id(expected));
  EXPECT_EQ(body["definition"], planet::canonical_json(expected));
  EXPECT_EQ(header(created, http::field::location), body["url"]);
  // Another spelling of the same definition (key order, whitespace, explicit defaults) is the
  // same planet: 200 and the same id, nothing new stored.
  const std::size_t count = planet_count();
  const Response again =
      post(R"({"land_fraction":0.4,"base_faces":600,"seed":77,"radius":6371000})");
  ASSERT_EQ(again.result_int(), 200u) << again.body();
  EXPECT_EQ(body_json(again)["id"], body["id"]);
  EXPECT_EQ(planet_count(), count);
  // And it serves tiles.
  const Response tile =
      get(body["url"].get<std::string>() + "/tiles/1/0/0.png?encoding=terrarium&size=64");
  EXPECT_EQ(tile.result_int(), 200u) << tile.body();
}

TEST_F(HttpPlanets, BadInputIsAProblemNamingTheFieldAndStoresNothing) {
  const std::size_t count = planet_count();
  expect_problem(post("{\"seed\": 1,"), 400, "");
  expect_problem(post(R"({"radius": -5})"), 400, "/radius");
  expect_problem(post(R"({"detail": {"hurst": "rough"}})"), 400, "/detail/hurst");
  expect_problem(post(R"({"seed": 1, "colour": "blue"})"), 400, "/colour");
  expect_problem(post(R"({"seed": 1, "material": {"rock": "grey"}})"), 400, "/material/rock");
  expect_problem(post(R"({"seed": 1, "material": {"tree_line": [0.6, 0.5]}})"), 400,
                 "/material/tree_line/1");
  expect_problem(post(kSmallPlanet, {}), 401, "");
  expect_problem(post(kSmallPlanet, {{"Authorization", "Bearer wrong"}}), 403, "");
  EXPECT_EQ(planet_count(), count);

  const std::string p = "/api/v1/planets/default";
  expect_problem(get(p + "/sample?lat=91&lon=0"), 400, "/lat");
  expect_problem(get(p + "/sample?lat=north&lon=0"), 400, "/lat");
  expect_problem(get(p + "/sample?lon=0"), 400, "/lat");
  expect_problem(get(p + "/sample?lat=0&lon=-180.5"), 400, "/lon");
  expect_problem(get(p + "/tiles/1/0/0.png?scheme=local"), 400, "/scheme");
  expect_problem(get(p + "/mesh/1/0/0.terrain?scheme=webmercator"), 400, "/scheme");
  expect_problem(get(p + "/tilejson.json?scheme=local"), 400, "/scheme");
  expect_problem(get(p + "/mesh/1/0/0.glb?scheme=local"), 400, "/scheme");
  expect_problem(get(p + "/tiles/1/0/0.png?scheme=nowhere"), 400, "/scheme");
  expect_problem(get(p + "/layer.json?scheme=webmercator"), 400, "/scheme");
  expect_problem(get(p + "/tiles/0/2/0.png"), 400, "/x");  // two tiles at zoom 0
  expect_problem(get(p + "/tiles/1/0/2.png"), 400, "/y");
  expect_problem(get(p + "/tiles/99/0/0.png"), 400, "/z");
  expect_problem(get(p + "/tiles/1/0/0.png?size=100"), 400, "/size");
  expect_problem(get(p + "/mesh/1/0/0.terrain?grid=10"), 400, "/grid");
  expect_problem(get(p + "/mesh/1/0/0.drc?max_error=-1"), 400, "/max_error");
  expect_problem(get(p + "/tiles/1/0/0.png?encoding=sepia"), 400, "/encoding");
  expect_problem(get(p + "/tilejson.json?encoding=gray16"), 400, "/encoding");
  expect_problem(get(p + "/tilejson.json?encoding=color&format=tif"), 400, "/format");
  expect_problem(get(p + "/tiles/1/0/0.jpg?encoding=gray16"), 400, "/encoding");
  expect_problem(get(p + "/tiles/1/0/0.webp"), 404, "/format");
  expect_problem(get(p + "/tiles/1/0/0.terrain"), 404, "/format");
  expect_problem(get(p + "/volcanoes"), 404, "");
  expect_problem(get("/api/v1/planets/" + std::string(64, '0') + "/tiles/1/0/0.png"), 404, "");
  expect_problem(get("/api/v1/planets/" + std::string(64, '0')), 404, "");
  expect_problem(get("/api/v1/planets/Not-A-Hash/layer.json"), 400, "/id");
  expect_problem(http_test::fetch(port_, "PUT", p, with_token(), "{}"), 405, "");
}

TEST_F(HttpPlanets, TilesComeInEveryFormatOfTheSceneRoutes) {
  const std::string p = "/api/v1/planets/default";
  for (const char* encoding : {"terrain-rgb", "terrarium", "gray16", "normals", "hillshade"}) {
    SCOPED_TRACE(encoding);
    const Response r = get(p + "/tiles/2/5/2.png?size=64&encoding=" + encoding);
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    EXPECT_EQ(header(r, http::field::content_type), "image/png");
    EXPECT_EQ(header(r, "X-Terrain-Backend"), "cpu");
    EXPECT_EQ(header(r, http::field::cache_control), "public, max-age=60, must-revalidate");
    const auto raster = terrain::decode_heightfield(bytes_of(r.body()), "png");
    ASSERT_TRUE(raster.ok()) << raster.error().message;
    EXPECT_EQ(raster->width, 64);
    EXPECT_EQ(std::string_view(encoding) == "gray16", !header(r, "X-Gray16-Scale").empty());
  }
  const Response bordered = get(p + "/tiles/2/5/2.png?size=64&border=1");
  ASSERT_EQ(bordered.result_int(), 200u) << bordered.body();
  EXPECT_EQ(terrain::decode_heightfield(bytes_of(bordered.body()), "png")->width, 66);
  const Response tif = get(p + "/tiles/2/5/2.tif?size=64");
  ASSERT_EQ(tif.result_int(), 200u) << tif.body();
  const auto heights = terrain::decode_heightfield(bytes_of(tif.body()), "tif");
  ASSERT_TRUE(heights.ok()) << heights.error().message;
  const auto [lo, hi] = std::minmax_element(heights->samples.begin(), heights->samples.end());
  EXPECT_LT(*lo, *hi);  // the planet has relief
  const Response glb = get(p + "/mesh/2/5/2.glb?grid=17");
  ASSERT_EQ(glb.result_int(), 200u) << glb.body();
  EXPECT_EQ(header(glb, http::field::content_type), "model/gltf-binary");
  EXPECT_EQ(glb.body().substr(0, 4), "glTF");
  const Response drc = get(p + "/mesh/2/5/2.drc?grid=17&max_error=50");
  ASSERT_EQ(drc.result_int(), 200u) << drc.body();
  EXPECT_EQ(drc.body().substr(0, 5), "DRACO");
}

TEST_F(HttpPlanets, QuantizedMeshIsGzippedWithAWaterMaskWhenAsked) {
  const std::string url = "/api/v1/planets/" + default_id_ + "/mesh/1/1/0.terrain?grid=33";
  const Response r =
      get(url, {{"Accept-Encoding", "gzip"}, {"Accept", kQuantizedMeshWithExtensions}});
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(header(r, http::field::content_type), "application/vnd.quantized-mesh");
  EXPECT_EQ(header(r, http::field::content_encoding), "gzip");
  EXPECT_EQ(header(r, http::field::cache_control), kImmutable);
  const auto raw = terrain::gzip_decompress(bytes_of(r.body()), std::size_t{64} << 20);
  ASSERT_TRUE(raw.ok()) << raw.error().message;
  const auto mesh = terrain::decode_quantized_mesh(*raw);
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;
  EXPECT_GT(mesh->vertex_count(), 3u);
  ASSERT_TRUE(mesh->water_mask.has_value());
  EXPECT_EQ(mesh->water_mask->size(), 65536u);  // a quarter of the planet: sea and land
  EXPECT_TRUE(mesh->normals.has_value());
  EXPECT_TRUE(mesh->metadata.has_value());
  EXPECT_EQ(header(r, http::field::vary), "Accept, Accept-Encoding, Origin");
  // Without Accept-Encoding: the same mesh, inflated, under another strong ETag.
  const Response plain = get(url, {{"Accept", kQuantizedMeshWithExtensions}});
  ASSERT_EQ(plain.result_int(), 200u);
  EXPECT_FALSE(has_header(plain, http::field::content_encoding));
  EXPECT_EQ(bytes_of(plain.body()), *raw);
  EXPECT_NE(header(plain, http::field::etag), header(r, http::field::etag));
}

TEST_F(HttpPlanets, ProductsHaveStrongEtagsThatRevalidateAndHitTheCache) {
  const std::string id = "/api/v1/planets/" + default_id_;
  for (const std::string& url :
       {id + "/tiles/3/9/5.png?size=128", id + "/layer.json", id + "/tilejson.json",
        id + "/sample?lat=12.5&lon=-33.25", id + "/mesh/3/9/5.glb?grid=9"}) {
    SCOPED_TRACE(url);
    const Response first = get(url);
    ASSERT_EQ(first.result_int(), 200u) << first.body();
    const std::string etag = header(first, http::field::etag);
    ASSERT_TRUE(etag.size() > 2 && etag.front() == '"' && etag.back() == '"') << etag;
    EXPECT_EQ(header(first, http::field::cache_control), kImmutable);
    const Response again = get(url, {{"If-None-Match", etag}});
    EXPECT_EQ(again.result_int(), 304u);
    EXPECT_TRUE(again.body().empty());
    const Response second = get(url);
    EXPECT_EQ(second.body(), first.body());
    EXPECT_EQ(header(second, http::field::etag), etag);
  }
  const double hits = metric(port_, "terrain_cache_hits_total");
  get(id + "/tiles/3/9/5.png?size=128");
  EXPECT_GT(metric(port_, "terrain_cache_hits_total"), hits);
  // The alias shares the cache entries of the id it names (same bytes, same ETag).
  const Response alias = get("/api/v1/planets/default/tiles/3/9/5.png?size=128");
  EXPECT_EQ(alias.body(), get(id + "/tiles/3/9/5.png?size=128").body());
}

// The server's tiles are the planet library's: the same bytes as PlanetTiles in this process.
TEST_F(HttpPlanets, TilesAreTheBytesOfThePlanetLibrary) {
  const auto world = planet::Planet::create(default_definition());
  planet::PlanetTiles tiles(world);
  struct Case {
    std::string url;
    terrain::TileAddress address;
    terrain::TileFormat format;
    terrain::ProductOptions options;
  };
  terrain::ProductOptions small;
  small.size = 64;
  terrain::ProductOptions mesh;
  mesh.grid = 33;
  // No Accept header asks for extensions: the server's mesh is bare.
  mesh.octvertexnormals = mesh.watermask = mesh.metadata = false;
  for (const Case& c :
       {Case{"/tiles/4/20/11.png?size=64", {4, 20, 11}, terrain::TileFormat::terrain_rgb, small},
        Case{"/tiles/9/600/300.tif?size=64", {9, 600, 300}, terrain::TileFormat::geotiff, small},
        Case{"/mesh/6/70/40.terrain?grid=33",
             {6, 70, 40},
             terrain::TileFormat::quantized_mesh,
             mesh}}) {
    SCOPED_TRACE(c.url);
    const Response r = get("/api/v1/planets/" + default_id_ + c.url, {{"Accept-Encoding", "gzip"}});
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    const auto product = tiles.make(c.address, c.format, c.options);
    ASSERT_TRUE(product.ok()) << product.error().message;
    EXPECT_EQ(bytes_of(r.body()), product->bytes);
  }
}

TEST_F(HttpPlanets, LayerJsonAndTileJsonDescribeTheGeographicTiles) {
  const Response layer = get("/api/v1/planets/default/layer.json");
  ASSERT_EQ(layer.result_int(), 200u) << layer.body();
  const json l = body_json(layer);
  EXPECT_EQ(l["projection"], "EPSG:4326");
  EXPECT_EQ(l["scheme"], "tms");
  // The alias's layer.json points at the immutable tiles of the id it names.
  EXPECT_EQ(l["tiles"][0], "/api/v1/planets/" + default_id_ + "/mesh/{z}/{x}/{y}.terrain");
  ASSERT_EQ(l["available"].size(), static_cast<std::size_t>(planet::PlanetTiles::max_zoom() + 1));
  EXPECT_EQ(l["available"][0][0]["endX"], 1);  // two root tiles
  EXPECT_EQ(l["metadataAvailability"], terrain::kMetadataAvailabilityLevels);

  const Response tj = get("/api/v1/planets/" + default_id_ + "/tilejson.json?encoding=terrarium");
  ASSERT_EQ(tj.result_int(), 200u) << tj.body();
  const json t = body_json(tj);
  EXPECT_EQ(t["tilejson"], "3.0.0");
  EXPECT_EQ(t["scheme"], "tms");
  EXPECT_EQ(t["encoding"], "terrarium");
  EXPECT_EQ(t["bounds"], json({-180.0, -90.0, 180.0, 90.0}));
  const std::string tiles = t["tiles"][0];
  EXPECT_NE(
      tiles.find("/api/v1/planets/" + default_id_ + "/tiles/{z}/{x}/{y}.png?encoding=terrarium"),
      std::string::npos)
      << tiles;

  // For MapLibre: Web Mercator XYZ, whose tiles are the planet library's.
  const Response wm = get("/api/v1/planets/default/tilejson.json?scheme=webmercator");
  ASSERT_EQ(wm.result_int(), 200u) << wm.body();
  const json w = body_json(wm);
  EXPECT_EQ(w["scheme"], "xyz");
  EXPECT_NEAR(w["bounds"][3].get<double>(), 85.0511, 1e-4);
  const std::string wm_tiles = w["tiles"][0];
  const std::string prefix = "/api/v1/planets/" + default_id_ + "/tiles/";
  ASSERT_NE(wm_tiles.find(prefix + "{z}/{x}/{y}.png?encoding=terrain-rgb&scheme=webmercator"),
            std::string::npos)
      << wm_tiles;
  const Response tile = get(prefix + "3/4/3.png?scheme=webmercator");
  ASSERT_EQ(tile.result_int(), 200u) << tile.body();
  planet::PlanetTiles library(planet::Planet::create(default_definition()));
  const auto expected =
      library.make(terrain::TileScheme::webmercator, {3, 4, 3}, terrain::TileFormat::terrain_rgb);
  ASSERT_TRUE(expected.ok()) << expected.error().message;
  EXPECT_EQ(bytes_of(tile.body()), expected->bytes);

  // Colour imagery for Cesium's UrlTemplateImageryProvider (geographic TMS) and MapLibre.
  const Response ctj = get("/api/v1/planets/default/tilejson.json?encoding=color");
  ASSERT_EQ(ctj.result_int(), 200u) << ctj.body();
  const json c = body_json(ctj);
  EXPECT_EQ(c["scheme"], "tms");
  EXPECT_FALSE(c.contains("encoding")) << c.dump();
  EXPECT_NE(c["tiles"][0].get<std::string>().find(prefix + "{z}/{x}/{y}.png?encoding=color"),
            std::string::npos)
      << c.dump();
  const Response colour = get(prefix + "3/9/5.jpg?encoding=color");
  ASSERT_EQ(colour.result_int(), 200u) << colour.body();
  EXPECT_EQ(header(colour, http::field::content_type), "image/jpeg");
  const auto expected_colour = library.make({3, 9, 5}, terrain::TileFormat::color_jpeg);
  ASSERT_TRUE(expected_colour.ok()) << expected_colour.error().message;
  EXPECT_EQ(bytes_of(colour.body()), expected_colour->bytes);
}

TEST_F(HttpPlanets, SampleAtALevelOfDetailIsTheTilesHeight) {
  planet::Sampler sampler(planet::Planet::create(default_definition()));
  const std::string p = "/api/v1/planets/" + default_id_ + "/sample?lat=12.5&lon=33.25";
  const json coarse = body_json(get(p + "&lod=5000"));
  EXPECT_EQ(coarse["ground"].get<double>(), sampler.sample(12.5, 33.25, 5000.0).ground);
  EXPECT_EQ(body_json(get(p + "&lod=0"))["ground"].get<double>(),
            sampler.sample(12.5, 33.25).ground);
  expect_problem(get(p + "&lod=-1"), 400, "/lod");
  expect_problem(get(p + "&lod=far"), 400, "/lod");
}

TEST_F(HttpPlanets, SampleGivesGroundWaterAndTypeAsThePlanetLibraryDoes) {
  planet::Sampler sampler(planet::Planet::create(default_definition()));
  const std::set<std::string> types = {"sea", "coast", "land", "river"};
  for (const auto& [lat, lon] : {std::pair{20.0, 20.0}, std::pair{-45.5, 170.25},
                                 std::pair{90.0, 0.0}, std::pair{0.0, -180.0}}) {
    const Response r = get("/api/v1/planets/" + default_id_ + "/sample?lat=" + std::to_string(lat) +
                           "&lon=" + std::to_string(lon));
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    const json s = body_json(r);
    EXPECT_TRUE(types.contains(s["type"].get<std::string>())) << s;
    EXPECT_GE(s["water"].get<double>(), s["ground"].get<double>());
    EXPECT_EQ(s["id"], default_id_);
    const planet::PointSample expected = sampler.sample(lat, lon);
    EXPECT_EQ(s["ground"].get<double>(), expected.ground);
    EXPECT_EQ(s["water"].get<double>(), expected.water);
    EXPECT_EQ(s["type"], planet::surface_name(expected.type));
  }
}

TEST_F(HttpPlanets, CorsAndMetricLabelsCoverPlanetRoutes) {
  const Response r =
      get("/api/v1/planets/default/tiles/0/0/0.png?size=64", {{"Origin", "https://a.example"}});
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(header(r, http::field::access_control_allow_origin), "https://a.example");
  get("/api/v1/planets");
  const std::string metrics = get("/metrics").body();
  EXPECT_NE(metrics.find("route=\"planet_tiles\",status=\"200\""), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("route=\"planets\""), std::string::npos);
}

// Another process with its own empty store makes the same bytes, and refuses work above its
// cost limit before doing any.
TEST_F(HttpPlanets, AnotherServerProcessServesIdenticalBytesAndRefusesCostlyTiles) {
  TempDir other_dir("planets-other");
  ServerProcess other(other_dir.path() / "data", {"--max-cost", "1000000"});
  for (const std::string url : {"/tiles/5/40/20.png?size=64&encoding=terrarium",
                                "/mesh/5/40/20.terrain?grid=17", "/mesh/5/40/20.glb?grid=17"}) {
    SCOPED_TRACE(url);
    const Response mine = get("/api/v1/planets/default" + url, {{"Accept-Encoding", "gzip"}});
    const Response theirs = http_test::get(other.port(), "/api/v1/planets/" + default_id_ + url,
                                           {{"Accept-Encoding", "gzip"}});
    ASSERT_EQ(mine.result_int(), 200u) << mine.body();
    ASSERT_EQ(theirs.result_int(), 200u) << theirs.body();
    EXPECT_EQ(mine.body(), theirs.body());
    EXPECT_EQ(header(mine, http::field::etag), header(theirs, http::field::etag));
  }
  const Response costly = http_test::get(other.port(), "/api/v1/planets/default/tiles/5/40/20.png");
  expect_problem(costly, 422, "");
  EXPECT_EQ(metric(other.port(), "terrain_cache_misses_total"), 3.0);  // refused before the cache
}

// ---------------------------------------------------------------------------------------------
// Continent maps: an uploaded image, named by its hash.

// An equirectangular greyscale PNG, land (white) inside a spherical cap around (20°N, 30°E)
// of radius 40°.
std::string cap_png(int width = 256, int height = 128) {
  constexpr double degree = 3.14159265358979323846 / 180.0;
  std::vector<std::uint8_t> pixels(static_cast<std::size_t>(width * height));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double lat = (90.0 - 180.0 * (y + 0.5) / height) * degree;
      const double lon = (-180.0 + 360.0 * (x + 0.5) / width) * degree;
      const double c = std::sin(lat) * std::sin(20 * degree) +
                       std::cos(lat) * std::cos(20 * degree) * std::cos(lon - 30 * degree);
      pixels[static_cast<std::size_t>(y * width + x)] = c >= std::cos(40 * degree) ? 255 : 0;
    }
  }
  const auto png = terrain::encode_png_gray8(width, height, pixels.data()).value();
  return {png.begin(), png.end()};
}

std::string upload(int port, const std::string& image) {
  const Response r = http_test::fetch(port, "POST", "/api/v1/images", with_token(), image);
  EXPECT_EQ(r.result_int(), 201u) << r.body();
  return body_json(r).value("hash", std::string());
}

std::string map_planet(const std::string& hash) {
  return R"({"seed": 78, "base_faces": 600, "continent_map": ")" + hash + R"("})";
}

TEST_F(HttpPlanets, AContinentMapFromAnUploadedImageShapesThePlanet) {
  const std::string image = cap_png();
  const std::string hash = upload(port_, image);
  ASSERT_EQ(hash, planet::continent_map_reference(bytes_of(image)));
  const Response created = post(map_planet(hash));
  ASSERT_TRUE(created.result_int() == 201u || created.result_int() == 200u) << created.body();
  const std::string id = body_json(created)["id"];
  EXPECT_EQ(body_json(created)["definition"]["continent_map"], hash);
  // The stored definition names the map, and the id hashes it.
  const Response definition = get("/api/v1/planets/" + id);
  ASSERT_EQ(definition.result_int(), 200u) << definition.body();
  const planet::PlanetDefinition parsed = planet::parse_planet_text(definition.body()).value();
  EXPECT_EQ(parsed.continent_map, hash);
  EXPECT_EQ(planet::planet_id(parsed), id);

  const Response tile = get("/api/v1/planets/" + id + "/tiles/1/1/0.png?size=64");
  ASSERT_EQ(tile.result_int(), 200u) << tile.body();
  // Land where the map is white, sea elsewhere; the library, given the same bytes, agrees.
  const auto map = planet::decode_continent_map(bytes_of(image));
  ASSERT_TRUE(map.ok()) << map.error().message;
  auto world = planet::Planet::build(parsed, &*map);
  ASSERT_TRUE(world.ok()) << world.error().message;
  planet::Sampler sampler(*world);
  for (const auto& [lat, lon, sea] :
       {std::tuple{20.0, 30.0, false}, std::tuple{-40.0, -120.0, true}}) {
    const Response r = get("/api/v1/planets/" + id + "/sample?lat=" + std::to_string(lat) +
                           "&lon=" + std::to_string(lon));
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    const json s = body_json(r);
    EXPECT_EQ(s["type"] == "sea", sea) << s;
    const planet::PointSample expected = sampler.sample(lat, lon);
    EXPECT_EQ(s["ground"].get<double>(), expected.ground);
    EXPECT_EQ(s["type"], planet::surface_name(expected.type));
  }
}

TEST_F(HttpPlanets, AContinentMapMustBeAnUploadedUsableImageAndARefusalStoresNothing) {
  const std::size_t count = planet_count();
  // Never seen: the server has nothing to build from.
  expect_problem(post(map_planet("sha256:" + std::string(64, 'e'))), 400, "/continent_map");
  // Not a hash: paths and URLs are refused by the definition's parser.
  expect_problem(post(R"({"continent_map": "/etc/passwd"})"), 400, "/continent_map");
  expect_problem(post(R"({"continent_map": "https://example.com/map.png"})"), 400,
                 "/continent_map");
  // Uploaded images that cannot be maps: colour, square.
  std::vector<std::uint8_t> rgb(64 * 32 * 3, 0);
  const auto colour = terrain::encode_png_rgb8(64, 32, rgb.data()).value();
  const std::string colour_hash = upload(port_, std::string(colour.begin(), colour.end()));
  expect_problem(post(map_planet(colour_hash)), 422, "/continent_map");
  const std::string square_hash = upload(port_, cap_png(64, 64));
  expect_problem(post(map_planet(square_hash)), 422, "/continent_map");
  EXPECT_EQ(planet_count(), count);
}

// The map is an image in the store like the definition: a restarted server finds both again
// and serves the same bytes.
TEST(HttpPlanetRestart, AContinentMapPlanetIsRebuiltFromTheStoreAfterARestart) {
  TempDir dir("planets-restart");
  const std::vector<std::string> flags = {"--write-token", kToken};
  std::string id, before;
  const std::string tile = "/tiles/2/3/1.png?size=64&encoding=terrarium";
  {
    ServerProcess server(dir.path() / "data", flags);
    const std::string hash = upload(server.port(), cap_png());
    const Response created =
        http_test::fetch(server.port(), "POST", "/api/v1/planets", with_token(), map_planet(hash));
    ASSERT_EQ(created.result_int(), 201u) << created.body();
    id = body_json(created)["id"];
    const Response r = http_test::get(server.port(), "/api/v1/planets/" + id + tile);
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    before = r.body();
    server.stop();
  }
  ServerProcess again(dir.path() / "data", flags);
  const Response r = http_test::get(again.port(), "/api/v1/planets/" + id + tile);
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(r.body(), before);
  // A tile never made before the restart: built now, from the stored image, as the library does.
  const std::string image = cap_png();
  const auto map = planet::decode_continent_map(bytes_of(image));
  ASSERT_TRUE(map.ok()) << map.error().message;
  const auto definition = planet::parse_planet_text(map_planet(map->hash));
  ASSERT_TRUE(definition.ok());
  auto world = planet::Planet::build(*definition, &*map);
  ASSERT_TRUE(world.ok()) << world.error().message;
  planet::PlanetTiles tiles(*world);
  terrain::ProductOptions small;
  small.size = 64;
  const auto expected = tiles.make({3, 9, 5}, terrain::TileFormat::terrain_rgb, small);
  ASSERT_TRUE(expected.ok()) << expected.error().message;
  const Response fresh =
      http_test::get(again.port(), "/api/v1/planets/" + id + "/tiles/3/9/5.png?size=64");
  ASSERT_EQ(fresh.result_int(), 200u) << fresh.body();
  EXPECT_EQ(bytes_of(fresh.body()), expected->bytes);
}

}  // namespace
}  // namespace http_test
