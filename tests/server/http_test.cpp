// The HTTP contract (../shared/ARCHITECTURE.md) end to end: the real terrain-server binary on a
// loopback port, real sockets. Every route answers as specified; products carry strong ETags
// and the cache lifetime their URL allows; writes are authorised, guarded by If-Match and
// atomic; malformed input is refused with problem+json naming the offending field; CORS follows
// the configured origins. One server serves the whole suite (writes use ids of their own).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>

#include "http_harness.hpp"
#include "terrain/gzip.hpp"
#include "terrain/image_io.hpp"
#include "terrain/quantized_mesh.hpp"

namespace http_test {
namespace {

constexpr const char* kImmutable = "public, max-age=31536000, immutable";
constexpr const char* kQuantizedMeshWithExtensions =
    "application/vnd.quantized-mesh;extensions=octvertexnormals-watermask-metadata";

class HttpApi : public SharedServerTest<HttpApi> {
 public:
  static constexpr const char* kFolder = "api";
  static std::vector<std::string> server_arguments() {
    return {"--write-token", kToken, "--cors-origins", "https://a.example"};
  }

 protected:
  /// Creates a scene with this id; fails the test unless the server answers 201.
  void create(const std::string& id, double elevation = 100.0) const {
    const Response r =
        fetch("POST", "/api/v1/scenes?id=" + id, with_token(), disc_scene(elevation));
    ASSERT_EQ(r.result_int(), 201u) << r.body();
  }
  std::size_t version_count(const std::string& id) const {
    const Response r = get("/api/v1/scenes/" + id + "/versions");
    EXPECT_EQ(r.result_int(), 200u) << r.body();
    return body_json(r)["versions"].size();
  }
};

void expect_problem(const Response& r, unsigned status, const std::string& pointer) {
  EXPECT_EQ(r.result_int(), status) << r.body();
  EXPECT_EQ(header(r, http::field::content_type), "application/problem+json");
  const json body = json::parse(r.body(), nullptr, false);
  ASSERT_TRUE(body.is_object()) << r.body();
  EXPECT_EQ(body.value("status", 0), static_cast<int>(status));
  EXPECT_TRUE(body.contains("title") && body.contains("detail") && body.contains("type"));
  if (!pointer.empty()) {
    EXPECT_EQ(body.value("pointer", std::string("(none)")), pointer);
  }
}

std::vector<std::uint8_t> bytes_of(const std::string& s) {
  return {s.begin(), s.end()};
}

// ---------------------------------------------------------------------------------------------
// Routes

TEST_F(HttpApi, HealthzAnswersOkAsJson) {
  const Response r = get("/healthz");
  EXPECT_EQ(r.result_int(), 200u);
  EXPECT_EQ(header(r, http::field::content_type), "application/json");
  EXPECT_EQ(body_json(r)["status"], "ok");
  EXPECT_EQ(header(r, http::field::cache_control), "no-store");
}

TEST_F(HttpApi, MetricsArePrometheusText) {
  get("/healthz");
  const Response r = get("/metrics");
  EXPECT_EQ(r.result_int(), 200u);
  EXPECT_TRUE(header(r, http::field::content_type).starts_with("text/plain"));
  for (const char* name : {"# TYPE terrain_requests_total counter", "terrain_cache_hits_total ",
                           "terrain_generation_queue ",
                           "terrain_requests_total{route=\"healthz\","
                           "status=\"200\"}"}) {
    EXPECT_NE(r.body().find(name), std::string::npos) << name;
  }
}

TEST_F(HttpApi, SceneListHoldsTheBuiltInScenes) {
  const Response r = get("/api/v1/scenes");
  ASSERT_EQ(r.result_int(), 200u);
  EXPECT_EQ(header(r, http::field::content_type), "application/json");
  std::set<std::string> ids;
  const json list = body_json(r);
  for (const json& s : list["scenes"]) {
    ids.insert(s["id"].get<std::string>());
    EXPECT_TRUE(s["hash"].get<std::string>().starts_with("sha256:"));
    EXPECT_GE(s["version"].get<int>(), 1);
    EXPECT_EQ(s["url"], "/api/v1/scenes/" + s["id"].get<std::string>());
  }
  for (const char* id :
       {"alpine-valleys", "butte", "coastal-range", "craters", "hills-river", "lake-dunes",
        "mountain-range", "river-basin", "river-lake", "winding-road"}) {
    EXPECT_TRUE(ids.contains(id)) << id;
  }
}

TEST_F(HttpApi, SceneGetCarriesTheVersionHashAsEtagAndRevalidates) {
  std::string hash;
  const json list = body_json(get("/api/v1/scenes"));
  for (const json& s : list["scenes"]) {
    if (s["id"] == "hills-river") hash = s["hash"];
  }
  ASSERT_FALSE(hash.empty());
  const Response r = get("/api/v1/scenes/hills-river");
  ASSERT_EQ(r.result_int(), 200u);
  EXPECT_EQ(header(r, http::field::etag), etag_of(hash));
  EXPECT_EQ(header(r, http::field::content_type), "application/json");
  EXPECT_EQ(body_json(r)["format"], "terrain-scene/1");
  EXPECT_EQ(header(r, "X-Scene-Version"), "1");

  const Response again = get("/api/v1/scenes/hills-river", {{"If-None-Match", etag_of(hash)}});
  EXPECT_EQ(again.result_int(), 304u);
  EXPECT_TRUE(again.body().empty());
  EXPECT_EQ(header(again, http::field::etag), etag_of(hash));

  const Response by_hash = get("/api/v1/scenes/hills-river@" + hash);
  EXPECT_EQ(by_hash.result_int(), 200u);
  EXPECT_EQ(header(by_hash, http::field::etag), etag_of(hash));
}

TEST_F(HttpApi, VersionsListTheHistory) {
  const Response r = get("/api/v1/scenes/craters/versions");
  ASSERT_EQ(r.result_int(), 200u);
  const json body = body_json(r);
  EXPECT_EQ(body["id"], "craters");
  ASSERT_GE(body["versions"].size(), 1u);
  const json& first = body["versions"][0];
  EXPECT_EQ(first["version"], 1);
  EXPECT_EQ(first["author"], "built-in");
  EXPECT_EQ(first["url"], "/api/v1/scenes/craters@1");
  EXPECT_TRUE(first["hash"].get<std::string>().starts_with("sha256:"));
}

TEST_F(HttpApi, ProgramIsTheCompiledSceneAsJson) {
  const Response r = get("/api/v1/scenes/hills-river@1/program");
  ASSERT_EQ(r.result_int(), 200u);
  EXPECT_EQ(header(r, http::field::content_type), "application/json");
  const json body = body_json(r);
  EXPECT_EQ(body["format"], "terrain-program/1");
  EXPECT_EQ(body["scene_id"], "hills-river");
  EXPECT_EQ(body["version"], 1);
  EXPECT_GT(body["instruction_count"].get<int>(), 0);
  EXPECT_TRUE(body["code"].is_string());
}

TEST_F(HttpApi, SampleGivesElevationWeightGradientAndLipschitzBound) {
  const Response r = get("/api/v1/scenes/hills-river/sample?x=10&y=-20&lod=2");
  ASSERT_EQ(r.result_int(), 200u);
  EXPECT_EQ(header(r, http::field::content_type), "application/json");
  const json body = body_json(r);
  EXPECT_EQ(body["x"], 10.0);
  EXPECT_EQ(body["y"], -20.0);
  EXPECT_EQ(body["lod"], 2.0);
  EXPECT_TRUE(std::isfinite(body["elevation"].get<double>()));
  EXPECT_GE(body["weight"].get<double>(), 0.0);
  EXPECT_EQ(body["gradient"].size(), 2u);
  EXPECT_GT(body["lipschitz"].get<double>(), 0.0);
  EXPECT_TRUE(body["water"].is_null()) << "hills-river has no water layer";
}

TEST_F(HttpApi, TheFirstRequestToABuiltInDrainedSceneIsAnsweredOnceItsGridsAreBaked) {
  // river-lake's first load bakes a 512² erosion and a 512² drainage (seconds under TSan): the
  // request waits for it and is answered, not refused as busy when the bake outlasts the
  // second a head ref stays fresh.
  const Response r = get("/api/v1/scenes/river-lake/sample?x=-300&y=-1800");
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  const json body = body_json(r);
  ASSERT_TRUE(body.at("water").is_object()) << body.dump();
  EXPECT_TRUE(body["water"].at("wet").get<bool>()) << "river-lake's lake is at (-300, -1800)";
}

TEST_F(HttpApi, SampleSaysWhereADrainagesLakeAndRiversAre) {
  // The bowl dug into the dome holds a lake.
  const Response created =
      fetch("POST", "/api/v1/scenes?id=drained", with_token(), drained_dome_scene());
  ASSERT_EQ(created.result_int(), 201u) << created.body();
  const Response lake = get("/api/v1/scenes/drained/sample?x=0&y=0");
  ASSERT_EQ(lake.result_int(), 200u) << lake.body();
  const json wet = body_json(lake);
  ASSERT_TRUE(wet.at("water").is_object()) << wet.dump();
  EXPECT_TRUE(wet["water"].at("wet").get<bool>()) << wet.dump();
  EXPECT_GT(wet["water"].at("surface").get<double>(), wet.at("elevation").get<double>());
  // The dome's flank is dry.
  const Response flank = get("/api/v1/scenes/drained/sample?x=700&y=300");
  ASSERT_EQ(flank.result_int(), 200u) << flank.body();
  const json dry = body_json(flank);
  EXPECT_FALSE(dry["water"].at("wet").get<bool>()) << dry.dump();
  EXPECT_TRUE(dry["water"].at("surface").is_null());
}

TEST_F(HttpApi, LayerJsonDescribesPinnedQuantizedMeshTiles) {
  const Response r = get("/api/v1/scenes/hills-river/layer.json");
  ASSERT_EQ(r.result_int(), 200u);
  const json body = body_json(r);
  EXPECT_EQ(body["format"], "quantized-mesh-1.0");
  EXPECT_EQ(body["scheme"], "tms");
  EXPECT_EQ(body["projection"], "EPSG:4326");
  ASSERT_EQ(body["tiles"].size(), 1u);
  // The template names the version, so the tiles it leads to are immutable.
  EXPECT_EQ(body["tiles"][0], "/api/v1/scenes/hills-river@1/mesh/{z}/{x}/{y}.terrain");
}

TEST_F(HttpApi, TileJsonDescribesPinnedRasterDemTiles) {
  const Response r = get("/api/v1/scenes/hills-river/tilejson.json?encoding=terrarium");
  ASSERT_EQ(r.result_int(), 200u);
  const json body = body_json(r);
  EXPECT_EQ(body["tilejson"], "3.0.0");
  EXPECT_EQ(body["encoding"], "terrarium");
  EXPECT_EQ(body["tileSize"], 256);
  ASSERT_EQ(body["tiles"].size(), 1u);
  EXPECT_NE(body["tiles"][0].get<std::string>().find(
                "/api/v1/scenes/hills-river@1/tiles/{z}/{x}/{y}.png?encoding=terrarium"),
            std::string::npos);
  EXPECT_EQ(body["bounds"].size(), 4u);
}

TEST_F(HttpApi, PngTilesDecodeAs256By256InEveryEncoding) {
  for (const char* encoding : {"terrain-rgb", "terrarium", "gray16", "normals", "hillshade"}) {
    SCOPED_TRACE(encoding);
    const Response r =
        get(std::string("/api/v1/scenes/hills-river@1/tiles/0/0/0.png?scheme=local&encoding=") +
            encoding);
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    EXPECT_EQ(header(r, http::field::content_type), "image/png");
    const auto raster = terrain::decode_heightfield(bytes_of(r.body()), "png");
    ASSERT_TRUE(raster.ok()) << raster.error().message;
    EXPECT_EQ(raster->width, 256);
    EXPECT_EQ(raster->height, 256);
    if (std::string_view(encoding) == "gray16") {
      EXPECT_FALSE(header(r, "X-Gray16-Offset").empty());
      EXPECT_FALSE(header(r, "X-Gray16-Scale").empty());
    }
  }
}

TEST_F(HttpApi, ColorTilesArePngOrJpegImageryDescribedByTileJson) {
  const std::string tiles = "/api/v1/scenes/lake-dunes@1/tiles/1/0/0";
  const Response png = get(tiles + ".png?scheme=local&encoding=color");
  ASSERT_EQ(png.result_int(), 200u) << png.body();
  EXPECT_EQ(header(png, http::field::content_type), "image/png");
  const auto raster = terrain::decode_heightfield(bytes_of(png.body()), "png");
  ASSERT_TRUE(raster.ok()) << raster.error().message;
  EXPECT_EQ(raster->width, 256);
  const Response jpeg = get(tiles + ".jpg?scheme=local");  // colour is JPEG's only encoding
  ASSERT_EQ(jpeg.result_int(), 200u) << jpeg.body();
  EXPECT_EQ(header(jpeg, http::field::content_type), "image/jpeg");
  EXPECT_EQ(header(jpeg, http::field::cache_control), "public, max-age=31536000, immutable");
  EXPECT_EQ(jpeg.body(), get(tiles + ".jpg?scheme=local&encoding=color").body());

  // A raster source's TileJSON: no raster-dem encoding, tiles in the format asked for.
  const Response r = get("/api/v1/scenes/lake-dunes/tilejson.json?encoding=color&format=jpg");
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  const json body = body_json(r);
  EXPECT_FALSE(body.contains("encoding")) << body.dump();
  EXPECT_NE(body["tiles"][0].get<std::string>().find(
                "/api/v1/scenes/lake-dunes@1/tiles/{z}/{x}/{y}.jpg?encoding=color&scheme="
                "webmercator"),
            std::string::npos)
      << body.dump();
  // For Cesium's UrlTemplateImageryProvider: geographic TMS tiles over the scene's bounds.
  const json tms =
      body_json(get("/api/v1/scenes/lake-dunes/tilejson.json?encoding=color&scheme=geographic"));
  EXPECT_EQ(tms["scheme"], "tms");
  EXPECT_EQ(tms["crs"], "EPSG:4326");
  EXPECT_EQ(tms["bounds"], body["bounds"]);
  EXPECT_NE(tms["tiles"][0].get<std::string>().find("&scheme=geographic"), std::string::npos);
}

TEST_F(HttpApi, TileSizeAndBorderOptionsShapeThePng) {
  const Response r =
      get("/api/v1/scenes/hills-river@1/tiles/1/1/0.png?scheme=local&size=64&border=1");
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  const auto raster = terrain::decode_heightfield(bytes_of(r.body()), "png");
  ASSERT_TRUE(raster.ok()) << raster.error().message;
  EXPECT_EQ(raster->width, 66);
  EXPECT_EQ(raster->height, 66);
}

TEST_F(HttpApi, TiffTileIsFloat32Heights) {
  const Response r = get("/api/v1/scenes/hills-river@1/tiles/0/0/0.tif?scheme=local");
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(header(r, http::field::content_type), "image/tiff");
  const auto raster = terrain::decode_heightfield(bytes_of(r.body()), "tif");
  ASSERT_TRUE(raster.ok()) << raster.error().message;
  EXPECT_EQ(raster->width, 256);
  EXPECT_EQ(raster->height, 256);
  const auto [lo, hi] = std::minmax_element(raster->samples.begin(), raster->samples.end());
  EXPECT_LT(*lo, *hi);  // the scene has relief
}

TEST_F(HttpApi, QuantizedMeshIsGzipWhenTheClientAcceptsGzip) {
  const Response r = get("/api/v1/scenes/hills-river@1/mesh/0/1/0.terrain",
                         {{"Accept-Encoding", "gzip, deflate"}});
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(header(r, http::field::content_type), "application/vnd.quantized-mesh");
  EXPECT_EQ(header(r, http::field::content_encoding), "gzip");
  EXPECT_NE(header(r, http::field::vary).find("Accept-Encoding"), std::string::npos);
  const auto raw = terrain::gzip_decompress(bytes_of(r.body()), std::size_t{64} << 20);
  ASSERT_TRUE(raw.ok()) << raw.error().message;
  const auto mesh = terrain::decode_quantized_mesh(*raw);
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;
  EXPECT_GT(mesh->vertex_count(), 3u);
  EXPECT_FALSE(mesh->indices.empty());
}

TEST_F(HttpApi, QuantizedMeshIsPlainWithoutAcceptEncoding) {
  const std::string url = "/api/v1/scenes/hills-river@1/mesh/0/1/0.terrain";
  const Response plain = get(url);
  ASSERT_EQ(plain.result_int(), 200u) << plain.body();
  EXPECT_FALSE(has_header(plain, http::field::content_encoding));
  const auto mesh = terrain::decode_quantized_mesh(bytes_of(plain.body()));
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;
  // The same mesh as the gzipped one; a different representation, so a different strong ETag.
  const Response gzipped = get(url, {{"Accept-Encoding", "gzip"}});
  ASSERT_EQ(gzipped.result_int(), 200u);
  const auto inflated = terrain::gzip_decompress(bytes_of(gzipped.body()), std::size_t{64} << 20);
  ASSERT_TRUE(inflated.ok());
  EXPECT_EQ(*inflated, bytes_of(plain.body()));
  EXPECT_NE(header(plain, http::field::etag), header(gzipped, http::field::etag));
  // Each ETag revalidates its own representation only.
  EXPECT_EQ(get(url, {{"If-None-Match", header(plain, http::field::etag)}}).result_int(), 304u);
  EXPECT_EQ(get(url, {{"If-None-Match", header(gzipped, http::field::etag)}}).result_int(), 200u);
}

TEST_F(HttpApi, QuantizedMeshExtensionsFollowTheAcceptHeader) {
  const std::string url = "/api/v1/scenes/lake-dunes@1/mesh/0/1/0.terrain";
  const Response with = get(url, {{"Accept", kQuantizedMeshWithExtensions}});
  ASSERT_EQ(with.result_int(), 200u) << with.body();
  const auto full = terrain::decode_quantized_mesh(bytes_of(with.body()));
  ASSERT_TRUE(full.ok()) << full.error().message;
  ASSERT_TRUE(full->normals.has_value());
  EXPECT_EQ(full->normals->size(), 2 * full->vertex_count());
  ASSERT_TRUE(full->water_mask.has_value());
  EXPECT_TRUE(full->water_mask->size() == 1 || full->water_mask->size() == 65536);
  ASSERT_TRUE(full->metadata.has_value());
  EXPECT_TRUE(json::parse(*full->metadata, nullptr, false).is_object());

  const Response only_normals =
      get(url, {{"Accept", "application/vnd.quantized-mesh;extensions=octvertexnormals"}});
  const auto some = terrain::decode_quantized_mesh(bytes_of(only_normals.body()));
  ASSERT_TRUE(some.ok()) << some.error().message;
  EXPECT_TRUE(some->normals.has_value());
  EXPECT_FALSE(some->water_mask.has_value());
  EXPECT_FALSE(some->metadata.has_value());

  const Response none = get(url, {{"Accept", "application/vnd.quantized-mesh"}});
  const auto bare = terrain::decode_quantized_mesh(bytes_of(none.body()));
  ASSERT_TRUE(bare.ok()) << bare.error().message;
  EXPECT_FALSE(bare->normals.has_value());
  EXPECT_FALSE(bare->water_mask.has_value());
  EXPECT_FALSE(bare->metadata.has_value());
  EXPECT_NE(header(with, http::field::etag), header(none, http::field::etag));
  // Negotiated answers say so, or a shared cache would hand one client's extensions to another.
  for (const Response* r : {&with, &only_normals, &none}) {
    EXPECT_EQ(header(*r, http::field::vary), "Accept, Accept-Encoding, Origin");
  }
  const Response revalidated = get(url, {{"Accept", kQuantizedMeshWithExtensions},
                                         {"If-None-Match", header(with, http::field::etag)}});
  EXPECT_EQ(revalidated.result_int(), 304u);
  EXPECT_EQ(header(revalidated, http::field::vary), "Accept, Accept-Encoding, Origin");
  const Response png = get("/api/v1/scenes/lake-dunes@1/tiles/0/0/0.png");
  EXPECT_EQ(header(png, http::field::vary), "Accept-Encoding, Origin");
}

TEST_F(HttpApi, GlbAndDracoMeshesCarryTheirFormats) {
  const Response glb = get("/api/v1/scenes/hills-river@1/mesh/1/0/0.glb?grid=33");
  ASSERT_EQ(glb.result_int(), 200u) << glb.body();
  EXPECT_EQ(header(glb, http::field::content_type), "model/gltf-binary");
  EXPECT_EQ(glb.body().substr(0, 4), "glTF");
  const Response drc = get("/api/v1/scenes/hills-river@1/mesh/1/0/0.drc?grid=33&max_error=0.5");
  ASSERT_EQ(drc.result_int(), 200u) << drc.body();
  EXPECT_EQ(header(drc, http::field::content_type), "application/vnd.google.draco");
  EXPECT_EQ(drc.body().substr(0, 5), "DRACO");
}

TEST_F(HttpApi, HeadAnswersTheHeadersOfGetWithoutABody) {
  for (const char* url : {"/api/v1/scenes/craters@1/tiles/1/0/1.png?scheme=local&size=64",
                          "/api/v1/scenes/craters@1/mesh/1/0/1.terrain?grid=9",
                          "/api/v1/scenes/craters@1/program", "/healthz"}) {
    SCOPED_TRACE(url);
    // HEAD before GET (a tile is generated for it), then after (from the cache): both agree
    // with GET on everything but the body.
    const Response generated = fetch("HEAD", url);
    const Response full = get(url);
    ASSERT_EQ(full.result_int(), 200u) << full.body();
    const Response cached = fetch("HEAD", url);
    for (const Response* head : {&generated, &cached}) {
      EXPECT_EQ(head->result_int(), 200u);
      EXPECT_TRUE(head->body().empty());
      EXPECT_EQ(header(*head, http::field::content_length), std::to_string(full.body().size()));
      EXPECT_EQ(header(*head, http::field::etag), header(full, http::field::etag));
      EXPECT_EQ(header(*head, http::field::content_type), header(full, http::field::content_type));
    }
  }
}

TEST_F(HttpApi, KeepAliveServesSeveralRequestsOnOneConnection) {
  Connection c(port_);
  for (int i = 0; i < 3; ++i) {
    c.send(request_text("GET", "/healthz"));
    const Response r = c.read();
    EXPECT_EQ(r.result_int(), 200u);
    EXPECT_TRUE(r.keep_alive());
  }
  c.send(request_text("GET", "/api/v1/scenes/hills-river@1/tiles/0/0/0.png?scheme=local&size=64"));
  EXPECT_EQ(c.read().result_int(), 200u);
  c.send(request_text("GET", "/healthz", {{"Connection", "close"}}));
  const Response last = c.read();
  EXPECT_EQ(last.result_int(), 200u);
  EXPECT_FALSE(last.keep_alive());
  EXPECT_TRUE(c.closed_within(Millis(2'000)));
}

TEST_F(HttpApi, UnknownRoutesAndMethodsAreProblems) {
  expect_problem(get("/nope"), 404, "");
  expect_problem(get("/api/v1/scenes/hills-river/teapot"), 404, "");
  const Response r = fetch("DELETE", "/api/v1/scenes/hills-river");
  expect_problem(r, 405, "");
  EXPECT_EQ(header(r, http::field::allow), "GET, HEAD, PUT");
  expect_problem(fetch("POST", "/api/v1/scenes/hills-river/tiles/0/0/0.png", with_token()), 405,
                 "");
  expect_problem(get("/api/v1/scenes/no-such-scene"), 404, "");
  expect_problem(get("/api/v1/scenes/hills-river@999/program"), 404, "");
}

// ---------------------------------------------------------------------------------------------
// Caching

TEST_F(HttpApi, VersionedUrlsAreImmutableAndHeadUrlsShortLived) {
  const std::vector<std::string> products = {"/tiles/0/0/0.png?scheme=local&size=64",
                                             "/mesh/0/1/0.terrain?grid=17",
                                             "/program",
                                             "/layer.json",
                                             "/tilejson.json",
                                             "/sample?x=1&y=2"};
  for (const std::string& product : products) {
    SCOPED_TRACE(product);
    const Response pinned = get("/api/v1/scenes/craters@1" + product);
    ASSERT_EQ(pinned.result_int(), 200u) << pinned.body();
    EXPECT_EQ(header(pinned, http::field::cache_control), kImmutable);
    const Response head = get("/api/v1/scenes/craters" + product);
    ASSERT_EQ(head.result_int(), 200u) << head.body();
    const std::string cc = header(head, http::field::cache_control);
    EXPECT_EQ(cc.find("immutable"), std::string::npos) << cc;
    const std::size_t at = cc.find("max-age=");
    ASSERT_NE(at, std::string::npos) << cc;
    EXPECT_LE(std::stoi(cc.substr(at + 8)), 60) << cc;
  }
  EXPECT_EQ(header(get("/api/v1/scenes/craters@1"), http::field::cache_control), kImmutable);
}

TEST_F(HttpApi, EveryProductHasAStrongEtagThatRevalidatesWith304) {
  const std::vector<std::string> products = {
      "/tiles/0/0/0.png?scheme=local&size=64",
      "/tiles/0/0/0.png?scheme=local&size=64&encoding=gray16",
      "/tiles/0/0/0.tif?scheme=local&size=64",
      "/mesh/0/1/0.terrain?grid=17",
      "/mesh/0/0/0.glb?grid=17",
      "/mesh/0/0/0.drc?grid=17",
      "/program",
      "/layer.json",
      "/tilejson.json",
      "/sample?x=1&y=2"};
  for (const std::string& product : products) {
    SCOPED_TRACE(product);
    const std::string url = "/api/v1/scenes/butte@1" + product;
    const Response r = get(url, {{"Accept-Encoding", "gzip"}});
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    const std::string etag = header(r, http::field::etag);
    ASSERT_FALSE(etag.empty());
    EXPECT_FALSE(etag.starts_with("W/")) << etag;
    EXPECT_TRUE(etag.size() > 2 && etag.front() == '"' && etag.back() == '"') << etag;
    const Response again = get(url, {{"Accept-Encoding", "gzip"}, {"If-None-Match", etag}});
    EXPECT_EQ(again.result_int(), 304u);
    EXPECT_TRUE(again.body().empty());
    EXPECT_EQ(header(again, http::field::etag), etag);
    EXPECT_EQ(header(again, http::field::cache_control), kImmutable);
    const Response other =
        get(url, {{"Accept-Encoding", "gzip"}, {"If-None-Match", "\"something-else\""}});
    EXPECT_EQ(other.result_int(), 200u);
    EXPECT_EQ(other.body(), r.body());
  }
}

TEST_F(HttpApi, SecondIdenticalTileRequestIsAByteIdenticalCacheHit) {
  const std::string url = "/api/v1/scenes/winding-road@1/tiles/2/1/2.png?scheme=local&size=128";
  const Response first = get(url);
  ASSERT_EQ(first.result_int(), 200u) << first.body();
  const double hits = metric(port_, "terrain_cache_hits_total");
  ASSERT_GE(hits, 0.0);
  const Response second = get(url);
  ASSERT_EQ(second.result_int(), 200u);
  EXPECT_EQ(second.body(), first.body());
  EXPECT_EQ(header(second, http::field::etag), header(first, http::field::etag));
  EXPECT_GE(metric(port_, "terrain_cache_hits_total"), hits + 1);
}

// ---------------------------------------------------------------------------------------------
// Writes

TEST_F(HttpApi, WritesWithoutATokenAre401) {
  const Response r = fetch("POST", "/api/v1/scenes?id=no-token", {}, disc_scene(1));
  expect_problem(r, 401, "");
  EXPECT_EQ(header(r, http::field::www_authenticate), "Bearer");
  expect_problem(fetch("PUT", "/api/v1/scenes/hills-river", {}, disc_scene(1)), 401, "");
  expect_problem(fetch("POST", "/api/v1/images", {}, "x"), 401, "");
  EXPECT_EQ(get("/api/v1/scenes/no-token").result_int(), 404u);
}

TEST_F(HttpApi, WritesWithAWrongTokenAre403) {
  for (const char* auth : {"Bearer wrong", "Bearer integration-test-tokeN", "Basic abc",
                           "Bearer integration-test-token-and-more", "Bearer "}) {
    SCOPED_TRACE(auth);
    expect_problem(
        fetch("POST", "/api/v1/scenes?id=bad-token", {{"Authorization", auth}}, disc_scene(1)), 403,
        "");
  }
  EXPECT_EQ(get("/api/v1/scenes/bad-token").result_int(), 404u);
  EXPECT_EQ(version_count("hills-river"), 1u);
}

TEST_F(HttpApi, CreateAnswers201WithLocationAndTheNewVersion) {
  const Response r =
      fetch("POST", "/api/v1/scenes?id=created", with_token(), disc_scene(123, "Created"));
  ASSERT_EQ(r.result_int(), 201u) << r.body();
  EXPECT_EQ(header(r, http::field::location), "/api/v1/scenes/created");
  const json body = body_json(r);
  EXPECT_EQ(body["id"], "created");
  EXPECT_EQ(body["version"], 1);
  EXPECT_EQ(header(r, http::field::etag), etag_of(body["hash"]));
  const Response stored = get("/api/v1/scenes/created");
  ASSERT_EQ(stored.result_int(), 200u);
  EXPECT_EQ(header(stored, http::field::etag), etag_of(body["hash"]));
  EXPECT_EQ(body_json(stored)["name"], "Created");
  // The same id again is a conflict and changes nothing.
  const Response again =
      fetch("POST", "/api/v1/scenes?id=created", with_token(), disc_scene(5, "Other"));
  expect_problem(again, 409, "/id");
  EXPECT_EQ(version_count("created"), 1u);
  // Without ?id the id comes from the name.
  const Response named = fetch("POST", "/api/v1/scenes", with_token(), disc_scene(7, "My Hill!"));
  ASSERT_EQ(named.result_int(), 201u) << named.body();
  EXPECT_TRUE(header(named, http::field::location).starts_with("/api/v1/scenes/my-hill"));
}

TEST_F(HttpApi, PutWithAStaleIfMatchIs412AndStoresNothing) {
  create("stale");
  const std::string v1 = header(get("/api/v1/scenes/stale"), http::field::etag);
  const Response ok =
      fetch("PUT", "/api/v1/scenes/stale", with_token({{"If-Match", v1}}), disc_scene(200));
  ASSERT_EQ(ok.result_int(), 200u) << ok.body();
  const std::string v2 = header(ok, http::field::etag);
  const Response stale =
      fetch("PUT", "/api/v1/scenes/stale", with_token({{"If-Match", v1}}), disc_scene(300));
  expect_problem(stale, 412, "");
  EXPECT_EQ(header(stale, http::field::etag), v2);
  EXPECT_EQ(version_count("stale"), 2u);
  EXPECT_EQ(header(get("/api/v1/scenes/stale"), http::field::etag), v2);
  const Response garbage = fetch("PUT", "/api/v1/scenes/stale",
                                 with_token({{"If-Match", "\"sha256:0000\""}}), disc_scene(400));
  expect_problem(garbage, 412, "");
  EXPECT_EQ(version_count("stale"), 2u);
}

TEST_F(HttpApi, PutWithTheCurrentIfMatchStoresANewVersion) {
  create("current", 10);
  const Response before = get("/api/v1/scenes/current");
  const std::string v1 = header(before, http::field::etag);
  const Response r =
      fetch("PUT", "/api/v1/scenes/current", with_token({{"If-Match", v1}}), disc_scene(20));
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  const json body = body_json(r);
  EXPECT_EQ(body["version"], 2);
  EXPECT_EQ(body["url"], "/api/v1/scenes/current@2");
  EXPECT_EQ(header(r, http::field::etag), etag_of(body["hash"]));
  EXPECT_NE(header(r, http::field::etag), v1);
  EXPECT_EQ(header(get("/api/v1/scenes/current"), http::field::etag), etag_of(body["hash"]));
  EXPECT_EQ(header(get("/api/v1/scenes/current@1"), http::field::etag), v1);
  EXPECT_EQ(version_count("current"), 2u);
  // Products of the head follow the new version; pinned ones stay.
  const json sample = body_json(get("/api/v1/scenes/current/sample?x=0&y=0"));
  EXPECT_EQ(sample["version"], 2);
  EXPECT_NEAR(sample["elevation"].get<double>(), 20.0, 1e-3);
  EXPECT_NEAR(body_json(get("/api/v1/scenes/current@1/sample?x=0&y=0"))["elevation"].get<double>(),
              10.0, 1e-3);
  // Without If-Match (or with *) a PUT appends too.
  EXPECT_EQ(fetch("PUT", "/api/v1/scenes/current", with_token({{"If-Match", "*"}}), disc_scene(30))
                .result_int(),
            200u);
  EXPECT_EQ(version_count("current"), 3u);
  expect_problem(fetch("PUT", "/api/v1/scenes/never-created", with_token(), disc_scene(1)), 404,
                 "");
}

TEST_F(HttpApi, UploadedImagesAreStoredByHashAndUsableInScenes) {
  std::ifstream in(std::string(TERRAIN_SOURCE_DIR) + "/config/scenes/images/butte.png",
                   std::ios::binary);
  const std::string png((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(png.empty());
  const Response r =
      fetch("POST", "/api/v1/images", with_token({{"Content-Type", "image/png"}}), png);
  ASSERT_EQ(r.result_int(), 201u) << r.body();
  const json body = body_json(r);
  EXPECT_TRUE(body["hash"].get<std::string>().starts_with("sha256:"));
  EXPECT_EQ(body["media_type"], "image/png");
  EXPECT_GT(body["width"].get<int>(), 0);

  std::vector<float> heights(32 * 32);
  for (std::size_t i = 0; i < heights.size(); ++i) heights[i] = static_cast<float>(i % 32);
  const auto tiff = terrain::encode_float_tiff(32, 32, heights.data());
  ASSERT_TRUE(tiff.ok());
  const Response t = fetch("POST", "/api/v1/images", with_token({{"Content-Type", "image/tiff"}}),
                           std::string(tiff->begin(), tiff->end()));
  ASSERT_EQ(t.result_int(), 201u) << t.body();
  const json tb = body_json(t);
  EXPECT_EQ(tb["media_type"], "image/tiff");
  EXPECT_EQ(tb["width"], 32);
  EXPECT_EQ(tb["height"], 32);

  const json scene = {{"format", "terrain-scene/1"},
                      {"name", "Image"},
                      {"extent", {{"min", {-500, -500}}, {"max", {500, 500}}}},
                      {"root",
                       {{"type", "image"},
                        {"image", tb["hash"]},
                        {"corners", {{-400, 400}, {400, 400}, {400, -400}, {-400, -400}}},
                        {"elevation", 10},
                        {"height_scale", 2}}}};
  const Response created =
      fetch("POST", "/api/v1/scenes?id=from-image", with_token(), scene.dump());
  ASSERT_EQ(created.result_int(), 201u) << created.body();
  const Response tile = get("/api/v1/scenes/from-image@1/tiles/0/0/0.tif?scheme=local&size=64");
  ASSERT_EQ(tile.result_int(), 200u) << tile.body();

  expect_problem(fetch("POST", "/api/v1/images", with_token(), "definitely not an image"), 400,
                 "/image");
}

// ---------------------------------------------------------------------------------------------
// Malformed input: refused with problem+json naming the field, and nothing is stored.

TEST_F(HttpApi, MalformedScenesAre400ProblemsNamingTheFieldAndStoreNothing) {
  create("target", 1);
  std::string deep = R"({"type":"disc","center":[0,0],"radius":10})";
  for (int i = 0; i < 80; ++i) deep = R"({"type":"transform","children":[)" + deep + "]}";
  std::string arrays(200'000, '[');
  arrays += std::string(200'000, ']');
  json unknown = json::parse(disc_scene(1));
  unknown["root"]["type"] = "volcano";
  json bad_radius = json::parse(disc_scene(1));
  bad_radius["root"]["radius"] = "wide";
  json bad_format = json::parse(disc_scene(1));
  bad_format["format"] = "terrain-scene/99";
  json no_root = json::parse(disc_scene(1));
  no_root.erase("root");
  json bad_material = json::parse(disc_scene(1));
  bad_material["material"] = {{"rock_slope", {50, 40}}};
  struct Case {
    std::string name;
    std::string body;
    std::string pointer;  // "" = no particular field (the whole document)
  };
  const std::vector<Case> cases = {
      {"truncated JSON", R"({"format": "terrain-scene/1", "root": {)", ""},
      {"not JSON at all", "hello", ""},
      {"empty body", "", ""},
      {"unknown node type", unknown.dump(), "/root/type"},
      {"wrong field type", bad_radius.dump(), "/root/radius"},
      {"unknown format", bad_format.dump(), "/format"},
      {"missing root", no_root.dump(), "/root"},
      {"material band falling", bad_material.dump(), "/material/rock_slope/1"},
      {"deeply nested arrays", R"({"format":"terrain-scene/1","name":)" + arrays + "}", "/name"},
  };
  const std::size_t scenes_before = body_json(get("/api/v1/scenes"))["scenes"].size();
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    expect_problem(fetch("POST", "/api/v1/scenes?id=refused", with_token(), c.body), 400,
                   c.pointer);
    expect_problem(fetch("PUT", "/api/v1/scenes/target", with_token(), c.body), 400, c.pointer);
  }
  {
    SCOPED_TRACE("too deep nesting");
    const std::string body = R"({"format":"terrain-scene/1","root":)" + deep + "}";
    for (const Response& r : {fetch("POST", "/api/v1/scenes?id=refused", with_token(), body),
                              fetch("PUT", "/api/v1/scenes/target", with_token(), body)}) {
      expect_problem(r, 400, "");
      const std::string pointer = body_json(r).value("pointer", "");
      EXPECT_TRUE(pointer.starts_with("/root/children/0/children/0")) << pointer;
      EXPECT_NE(body_json(r)["detail"].get<std::string>().find("deeper"), std::string::npos);
    }
  }
  expect_problem(fetch("POST", "/api/v1/scenes?id=Bad%20Id", with_token(), disc_scene(1)), 400,
                 "/id");
  EXPECT_EQ(get("/api/v1/scenes/refused").result_int(), 404u);
  EXPECT_EQ(body_json(get("/api/v1/scenes"))["scenes"].size(), scenes_before);
  EXPECT_EQ(version_count("target"), 1u);
}

TEST_F(HttpApi, MalformedTileRequestsAre400Or404WithAPointer) {
  struct Case {
    std::string url;
    unsigned status;
    std::string pointer;
  };
  const std::string s = "/api/v1/scenes/hills-river@1";
  const std::vector<Case> cases = {
      {s + "/tiles/-1/0/0.png", 400, "/z"},
      {s + "/tiles/25/0/0.png", 400, "/z"},
      {s + "/tiles/99999999999/0/0.png", 400, "/z"},
      {s + "/tiles/0/-1/0.png", 400, "/x"},
      {s + "/tiles/0/0/-1.png", 400, "/y"},
      {s + "/tiles/3/8/0.png", 400, "/x"},
      {s + "/tiles/3/0/8.png", 400, "/y"},
      {s + "/tiles/0/99999999999999999999/0.png", 400, "/x"},
      {s + "/tiles/0/0/99999999999999999999.png", 400, "/y"},
      {s + "/tiles/1.5/0/0.png", 400, "/z"},
      {s + "/tiles/0/0x1/0.png", 400, "/x"},
      {s + "/tiles/0/0/0.webp", 404, "/format"},
      {s + "/tiles/0/0/0", 404, "/format"},
      {s + "/tiles/0/0/0.terrain", 404, "/format"},
      {s + "/mesh/0/0/0.png", 404, "/format"},
      {s + "/tiles/0/0/0.png?encoding=jpeg", 400, "/encoding"},
      {s + "/tiles/0/0/0.tif?encoding=terrarium", 400, "/encoding"},
      {s + "/tiles/0/0/0.png?scheme=mars", 400, "/scheme"},
      {s + "/tiles/0/0/0.png?size=abc", 400, "/size"},
      {s + "/tiles/0/0/0.png?size=99999999999", 400, "/size"},
      {s + "/tiles/0/0/0.png?size=100", 400, "/size"},
      {s + "/tiles/0/0/0.png?border=2", 400, "/border"},
      {s + "/mesh/0/0/0.glb?grid=abc", 400, "/grid"},
      {s + "/mesh/0/0/0.glb?grid=66", 400, "/grid"},
      {s + "/mesh/0/0/0.glb?max_error=nan", 400, "/max_error"},
      {s + "/mesh/0/0/0.glb?max_error=1e999", 400, "/max_error"},
      // Samples closer than the glTF/Draco position lattice (a 500 before 2026-12-07).
      {s + "/mesh/24/0/0.glb", 400, "/z"},
      {s + "/mesh/24/0/0.drc?grid=3", 400, "/z"},
      {s + "/mesh/0/0/0.glb?scheme=webmercator", 400, "/z"},  // wider than the lattice
      {s + "/mesh/24/0/0.terrain", 400, "/z"},
      {s + "/mesh/0/2/0.terrain", 400, "/x"},
      {s + "/sample?x=abc&y=0", 400, "/x"},
      {s + "/sample?x=0", 400, "/y"},
      {s + "/sample?x=0&y=1e999", 400, "/y"},
      {s + "/sample?x=0&y=0&lod=-1", 400, "/lod"},
      {s + "/tilejson.json?scheme=polar", 400, "/scheme"},
      {s + "/tilejson.json?encoding=gray16", 400, "/encoding"},
      {s + "/tilejson.json?encoding=color&format=gif", 400, "/format"},
      {s + "/tilejson.json?format=jpg", 400, "/format"},
      {s + "/tiles/0/0/0.jpg?encoding=terrarium", 400, "/encoding"},
      {"/api/v1/scenes/Hills-River/program", 400, "/id"},
      {"/api/v1/scenes/hills-river@0/program", 400, "/version"},
      {"/api/v1/scenes/hills-river@x/program", 400, "/version"},
      {"/api/v1/scenes/hills-river@99999999999999999999/program", 400, "/version"},
      {"/api/v1/scenes/" + std::string(65, 'a') + "/program", 400, "/id"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.url);
    expect_problem(get(c.url), c.status, c.pointer);
  }
}

TEST_F(HttpApi, PathTraversalIsRefusedWithoutReadingAFile) {
  for (const char* url :
       {"/api/v1/scenes/..%2f..%2fetc/tiles/0/0/0.png",
        "/api/v1/scenes/..%2F..%2Fetc%2Fpasswd/program", "/api/v1/scenes/%2e%2e/tiles/0/0/0.png",
        "/api/v1/scenes/../../etc/passwd", "/../../../../etc/passwd",
        "/api/v1/scenes/hills-river%00/program",
        "/api/v1/scenes/hills-river/tiles/0/0/0.png%00.txt",
        "/api/v1/scenes/hills-river/sample?x=0%00&y=0", "/api/v1/scenes/%zz",
        "/api/v1/scenes/hills-river%2fprogram", "/%2e%2e/%2e%2e/etc/passwd"}) {
    SCOPED_TRACE(url);
    const Response r = get(url);
    EXPECT_TRUE(r.result_int() == 400u || r.result_int() == 404u) << r.result_int();
    EXPECT_EQ(header(r, http::field::content_type), "application/problem+json");
    EXPECT_EQ(r.body().find("root:"), std::string::npos);
  }
}

// ---------------------------------------------------------------------------------------------
// CORS

TEST_F(HttpApi, CorsAllowsOnlyTheConfiguredOrigin) {
  for (const char* url : {"/healthz", "/api/v1/scenes/hills-river@1/program",
                          "/api/v1/scenes/hills-river@1/mesh/0/1/0.terrain?grid=9",
                          "/api/v1/scenes/hills-river@1/mesh/0/1/0.terrain?grid=9"}) {
    SCOPED_TRACE(url);  // the tile twice: generated, then from the cache
    const Response allowed =
        get(url, {{"Origin", "https://a.example"}, {"Accept-Encoding", "gzip"}});
    ASSERT_EQ(allowed.result_int(), 200u);
    EXPECT_EQ(header(allowed, http::field::access_control_allow_origin), "https://a.example");
    EXPECT_NE(header(allowed, http::field::access_control_expose_headers).find("ETag"),
              std::string::npos);
    // Responses differ by origin and by encoding: caches must key on both.
    const std::string vary = header(allowed, http::field::vary);
    EXPECT_NE(vary.find("Origin"), std::string::npos) << vary;
    if (std::string_view(url) != "/healthz") {
      EXPECT_NE(vary.find("Accept-Encoding"), std::string::npos) << vary;
    }
    const Response other = get(url, {{"Origin", "https://b.example"}});
    EXPECT_EQ(other.result_int(), 200u);
    EXPECT_FALSE(has_header(other, http::field::access_control_allow_origin));
    EXPECT_FALSE(has_header(get(url), http::field::access_control_allow_origin));
  }
}

TEST_F(HttpApi, CorsReachesErrorsAndRefusalsToo) {
  // Errors are answers a browser must be able to read: the unknown scene (answered on the I/O
  // thread), the bad tile address (after loading the version on the pool) and the body sent to
  // a route that takes none (refused before the body is read).
  const std::vector<std::pair<std::string, unsigned>> cases = {
      {"/api/v1/scenes/no-such-scene/program", 404u},
      {"/api/v1/scenes/hills-river@1/tiles/40/0/0.png", 400u}};
  for (const auto& [url, status] : cases) {
    SCOPED_TRACE(url);
    const Response r = get(url, {{"Origin", "https://a.example"}});
    EXPECT_EQ(r.result_int(), status);
    EXPECT_EQ(header(r, http::field::access_control_allow_origin), "https://a.example");
  }
  const Response refused = fetch("POST", "/healthz", {{"Origin", "https://a.example"}}, "{}");
  EXPECT_GE(refused.result_int(), 400u);
  EXPECT_EQ(header(refused, http::field::access_control_allow_origin), "https://a.example");
}

TEST_F(HttpApi, TheMaterialModelIsServedAloneAndInsideTheTracer) {
  const Response material = get("/api/v1/glsl/material.glsl");
  ASSERT_EQ(material.result_int(), 200u);
  EXPECT_NE(material.body().find("vec3 material_albedo("), std::string::npos);
  const Response trace = get("/api/v1/glsl/trace.glsl");
  ASSERT_EQ(trace.result_int(), 200u);
  // The same text: the planet view colours land with what the scene tracer shades with.
  EXPECT_NE(trace.body().find(material.body()), std::string::npos);
}

TEST_F(HttpApi, NotModifiedKeepsTheHeadersOfItsOk) {
  // RFC 9110 §15.4.5: a 304 carries the ETag, Cache-Control and Vary its 200 would.
  for (const char* url : {"/api/v1/scenes/hills-river@1", "/api/v1/scenes/hills-river@1/program",
                          "/api/v1/scenes/hills-river@1/tiles/0/0/0.png", "/api/v1/glsl/trace.glsl",
                          "/api/v1/glsl/material.glsl", "/api/v1/node-types"}) {
    SCOPED_TRACE(url);
    const Response ok = get(url);
    ASSERT_EQ(ok.result_int(), 200u);
    const std::string etag = header(ok, http::field::etag);
    ASSERT_FALSE(etag.empty());
    const Response again = get(url, {{"If-None-Match", etag}});
    EXPECT_EQ(again.result_int(), 304u);
    EXPECT_TRUE(again.body().empty());
    EXPECT_EQ(header(again, http::field::etag), etag);
    EXPECT_EQ(header(again, http::field::cache_control), header(ok, http::field::cache_control));
    EXPECT_EQ(header(again, http::field::vary), header(ok, http::field::vary));
  }
}

TEST_F(HttpApi, CorsPreflightIs204WithAllowedMethods) {
  const Response r = fetch("OPTIONS", "/api/v1/scenes/hills-river",
                           {{"Origin", "https://a.example"},
                            {"Access-Control-Request-Method", "PUT"},
                            {"Access-Control-Request-Headers", "authorization, if-match"}});
  EXPECT_EQ(r.result_int(), 204u);
  EXPECT_TRUE(r.body().empty());
  EXPECT_EQ(header(r, http::field::access_control_allow_origin), "https://a.example");
  const std::string methods = header(r, http::field::access_control_allow_methods);
  for (const char* m : {"GET", "PUT", "POST", "OPTIONS"}) {
    EXPECT_NE(methods.find(m), std::string::npos) << methods;
  }
  const std::string allowed_headers = header(r, http::field::access_control_allow_headers);
  EXPECT_NE(allowed_headers.find("Authorization"), std::string::npos);
  EXPECT_NE(allowed_headers.find("If-Match"), std::string::npos);
  const Response foreign =
      fetch("OPTIONS", "/api/v1/scenes/hills-river",
            {{"Origin", "https://b.example"}, {"Access-Control-Request-Method", "PUT"}});
  EXPECT_FALSE(has_header(foreign, http::field::access_control_allow_origin));
}

}  // namespace
}  // namespace http_test
