// The request handler as a function, without sockets: the OpenAPI document and the router agree,
// and deferred (generated) products are deterministic.
#include <gtest/gtest.h>

#include <filesystem>

#include <nlohmann/json.hpp>

#include "planet/definition.hpp"
#include "server/app.hpp"
#include "terrain/material.hpp"
#include "terrain/node.hpp"

namespace server {

std::string_view openapi_document();

namespace {

namespace fs = std::filesystem;

class AppTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("terrain-app-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    const Config config = test_config();
    auto store = open_sqlite_store(config.data_dir);
    ASSERT_TRUE(store.ok());
    app_ = new App(config, std::move(store).value());
    ASSERT_TRUE(app_->seed_examples().ok());
  }
  static Config test_config() {
    Config config;
    config.data_dir = dir_.string();
    config.scenes_dir = std::string(TERRAIN_SOURCE_DIR) + "/config/scenes";
    config.planets_dir = std::string(TERRAIN_SOURCE_DIR) + "/config/planets";
    config.cors_origins = {"https://a.example"};
    config.client_dir = std::string(TERRAIN_SOURCE_DIR) + "/client_web";
    config.write_token = "app-test-token";
    return config;
  }
  static void TearDownTestSuite() {
    delete app_;
    fs::remove_all(dir_);
  }

  static Response get(const std::string& target) {
    Request request{http::verb::get, target, 11};
    return settle(*app_, request);
  }

  static inline fs::path dir_;
  static inline App* app_ = nullptr;
};

TEST(ErrorKinds, EachKindHasItsStatusAndAnInternalErrorIsNotTheCallersFault) {
  EXPECT_EQ(status_of(terrain::ErrorKind::invalid), http::status::bad_request);
  EXPECT_EQ(status_of(terrain::ErrorKind::not_found), http::status::not_found);
  EXPECT_EQ(status_of(terrain::ErrorKind::unsupported), http::status::unprocessable_entity);
  EXPECT_EQ(status_of(terrain::ErrorKind::internal), http::status::internal_server_error);
  const Request request{http::verb::get, "/x", 11};
  const Response fault = problem(request, "Bad tile request",
                                 terrain::internal_error({"cannot encode GeoTIFF", "/bounds"}));
  EXPECT_EQ(fault.result(), http::status::internal_server_error);
  const auto body = nlohmann::json::parse(fault.body().view());
  EXPECT_EQ(body["title"], "Internal error");
  EXPECT_EQ(body["pointer"], "/bounds");
  const Response refusal = problem(
      request, "Unknown format", {"unknown tile format", "/format", terrain::ErrorKind::not_found});
  EXPECT_EQ(refusal.result(), http::status::not_found);
}

TEST_F(AppTest, AnUnknownTileFormatIs404AndAnUnknownEncoding400) {
  EXPECT_EQ(get("/api/v1/scenes/craters@1/tiles/0/0/0.webp").result(), http::status::not_found);
  EXPECT_EQ(get("/api/v1/scenes/craters@1/tiles/0/0/0.png?encoding=rainbow").result(),
            http::status::bad_request);
}

TEST_F(AppTest, NodeTypesAreTheRegistrysOwn) {
  const Response r = get("/api/v1/node-types");
  ASSERT_EQ(r.result(), http::status::ok) << r.body().view();
  const auto listed = nlohmann::json::parse(r.body().view()).at("node_types");
  ASSERT_EQ(listed.size(), terrain::node_types().size());
  for (std::size_t i = 0; i < listed.size(); ++i) {
    const terrain::NodeType& type = *terrain::node_types()[i];
    EXPECT_EQ(listed[i]["name"], type.name);
    EXPECT_EQ(listed[i]["id"], type.id);
    EXPECT_EQ(listed[i]["category"] == "primitive",
              type.category == terrain::NodeCategory::primitive);
    EXPECT_EQ(listed[i]["example"], nlohmann::json::parse(type.example_json));
  }
}

// The example pages for standard clients sit in a folder of the client: its address, with or
// without the slash, reaches its index page, whose links are relative.
TEST_F(AppTest, ExamplesFolderServesItsIndexPage) {
  const Response index = get("/examples/");
  ASSERT_EQ(index.result(), http::status::ok);
  EXPECT_EQ(index[http::field::content_type], "text/html; charset=utf-8");
  EXPECT_NE(index.body().view().find("cesium.html"), std::string::npos);
  const Response bare = get("/examples");
  EXPECT_EQ(bare.result(), http::status::moved_permanently);
  EXPECT_EQ(bare[http::field::location], "/examples/");
  EXPECT_EQ(get("/examples/cesium.html").result(), http::status::ok);
  EXPECT_EQ(get("/examples/maplibre.html").result(), http::status::ok);
  EXPECT_EQ(get("/").result(), http::status::ok);
  EXPECT_EQ(get("/examples/nothing.html").result(), http::status::not_found);
}

TEST_F(AppTest, OpenApiDocumentIsValidJsonServedAsIs) {
  const auto doc = nlohmann::json::parse(openapi_document());
  EXPECT_EQ(doc["openapi"], "3.1.0");
  const Response r = get("/api/v1/openapi.json");
  EXPECT_EQ(r.result(), http::status::ok);
  EXPECT_EQ(nlohmann::json::parse(r.body().view()), doc);
}

// Every documented GET path, with its parameters filled in, reaches a handler (no "no route").
TEST_F(AppTest, EveryDocumentedPathIsRouted) {
  const auto doc = nlohmann::json::parse(openapi_document());
  int checked = 0;
  for (const auto& [path, item] : doc["paths"].items()) {
    if (!item.contains("get")) continue;
    std::string target = path;
    auto fill = [&](const std::string& name, const std::string& value) {
      const std::size_t at = target.find("{" + name + "}");
      if (at != std::string::npos) target.replace(at, name.size() + 2, value);
    };
    const bool planet = path.starts_with("/api/v1/planets/");
    fill("ref", "hills-river@1");
    fill("id", planet ? "default" : "hills-river");
    fill("z", "0");
    fill("x", "0");
    fill("y", "0");
    if (target.find(".terrain") != std::string::npos) target += "?scheme=geographic";
    if (planet && target.ends_with("/sample")) {
      target += "?lat=20&lon=20";
    } else if (target.ends_with("/sample")) {
      target += "?x=1&y=2";
    }
    if (planet && target.find("/mesh/") != std::string::npos) {
      target += target.find('?') == std::string::npos ? "?grid=17" : "&grid=17";
    }
    if (target.ends_with("/render.png") || target.ends_with("/depth.bin")) {
      target += "?width=64&height=48";
    }
    if (target.ends_with("/changes")) target += "?from=1&to=1&z=0";
    const Response r = get(target);
    // The live channel is a WebSocket: a plain GET is told to upgrade (tests/server/live_test.cpp
    // covers the channel itself).
    const http::status expected =
        target.ends_with("/live") ? http::status::upgrade_required : http::status::ok;
    EXPECT_EQ(r.result(), expected) << target << ": " << r.body().view();
    ++checked;
  }
  EXPECT_GE(checked, 22);
}

// /metrics keeps planet routes apart from the scene routes of the same shape.
TEST_F(AppTest, PlanetRoutesHaveMetricLabelsOfTheirOwn) {
  auto label = [](const std::string& target) {
    return std::string(App::route_label(Request{http::verb::get, target, 11}));
  };
  EXPECT_EQ(label("/api/v1/planets"), "planets");
  EXPECT_EQ(label("/api/v1/planets/default"), "planet");
  EXPECT_EQ(label("/api/v1/planets/default/tiles/1/2/0.png?encoding=terrarium"), "planet_tiles");
  EXPECT_EQ(label("/api/v1/planets/default/mesh/1/2/0.terrain"), "planet_mesh");
  EXPECT_EQ(label("/api/v1/planets/default/sample?lat=1&lon=2"), "planet_sample");
  EXPECT_EQ(label("/api/v1/planets/default/layer.json"), "planet_layer.json");
  EXPECT_EQ(label("/api/v1/planets/default/tilejson.json"), "planet_tilejson.json");
  EXPECT_EQ(label("/api/v1/planets/default/material.json"), "planet_material.json");
  EXPECT_EQ(label("/api/v1/scenes/craters/tiles/1/1/0.png"), "tiles");
}

// Labels come from where a segment stands, never from a search of the path: scenes named like a
// product are scenes, and their products are counted as such.
TEST_F(AppTest, RouteLabelsFollowSegmentPositionsNotSubstrings) {
  auto label = [](const std::string& target) {
    return std::string(App::route_label(Request{http::verb::get, target, 11}));
  };
  EXPECT_EQ(label("/api/v1/scenes/sample"), "scene");
  EXPECT_EQ(label("/api/v1/scenes/live-demo"), "scene");
  EXPECT_EQ(label("/api/v1/scenes/tiles@2"), "scene");
  EXPECT_EQ(label("/api/v1/scenes/sample/sample?x=1&y=2"), "sample");
  EXPECT_EQ(label("/api/v1/scenes/live-demo/live"), "live");
  EXPECT_EQ(label("/api/v1/scenes/mesh/tiles/1/0/0.png"), "tiles");
  EXPECT_EQ(label("/api/v1/scenes/a/render.png?width=4"), "render");
  EXPECT_EQ(label("/api/v1/scenes/a/depth.bin"), "depth");
  EXPECT_EQ(label("/api/v1/scenes/a/versions"), "versions");
  EXPECT_EQ(label("/api/v1/scenes"), "scenes");
  EXPECT_EQ(label("/api/v1/planets/layer.json"), "planet");
  EXPECT_EQ(label("/api/v1/images"), "images");
  EXPECT_EQ(label("/api/v1/node-types"), "node_types");
  EXPECT_EQ(label("/js/main.js"), "client");
  EXPECT_EQ(label("/healthz"), "healthz");
}

// The built-in default planet is stored at start and "default" names it.
TEST_F(AppTest, DefaultPlanetIsSeededAndAliased) {
  auto definition =
      planet::load_planet_file(std::string(TERRAIN_SOURCE_DIR) + "/config/planets/default.json");
  ASSERT_TRUE(definition.ok());
  EXPECT_EQ(app_->default_planet_id(), planet::planet_id(*definition));
  const Response r = get("/api/v1/planets/default");
  ASSERT_EQ(r.result(), http::status::ok) << r.body().view();
  EXPECT_EQ(r.body().view(), planet::canonical_text(*definition));
}

TEST_F(AppTest, GeneratedTilesAreCachedAndIdentical) {
  const Response first = get("/api/v1/scenes/craters@1/tiles/1/1/0.png?scheme=local");
  const Response second = get("/api/v1/scenes/craters@1/tiles/1/1/0.png?scheme=local");
  ASSERT_EQ(first.result(), http::status::ok);
  EXPECT_EQ(first.body().view(), second.body().view());
  EXPECT_EQ(first[http::field::etag], second[http::field::etag]);
  EXPECT_GE(app_->cache().hits(), 1);
}

// The trace bundle carries what the browser builds its tracer from: the node types the program
// uses and the program unrolled into GLSL (gpu/program_glsl.hpp).
TEST_F(AppTest, TraceBundleNamesTheProgramsNodeTypesAndItsUnrolledGlsl) {
  const Response r = get("/api/v1/scenes/craters@1/trace.json");
  ASSERT_EQ(r.result(), http::status::ok) << r.body().view();
  const auto bundle = nlohmann::json::parse(r.body().view());
  const std::string defines = bundle.at("glsl_defines");
  EXPECT_NE(defines.find("#define TERRAIN_USES_CONTOUR 1"), std::string::npos) << defines;
  EXPECT_NE(defines.find("#define TERRAIN_USES_CURVE 0"), std::string::npos) << defines;
  const std::string unrolled = bundle.at("program_glsl");
  EXPECT_NE(unrolled.find("Field evaluate_program(vec2 p0, float s0)"), std::string::npos);
  EXPECT_NE(unrolled.find("contour_leaf("), std::string::npos);
  EXPECT_EQ(bundle.at("unroll_pays"), true);  // 15 leaves
  const Response large = get("/api/v1/scenes/winding-road@1/trace.json");
  ASSERT_EQ(large.result(), http::status::ok);
  EXPECT_EQ(nlohmann::json::parse(large.body().view()).at("unroll_pays"), false);  // 106 leaves
}

// The bundle and a planet's material.json carry the material packed as the tracers read it:
// butte's own colours, the defaults elsewhere.
TEST_F(AppTest, TraceBundleAndPlanetMaterialCarryThePackedMaterial) {
  auto packed_of = [&](const std::string& url) {
    const Response r = get(url);
    EXPECT_EQ(r.result(), http::status::ok) << url << ": " << r.body().view();
    const auto floats = nlohmann::json::parse(r.body().view()).at("material");
    std::vector<float> out;
    for (const auto& v : floats) out.push_back(v.get<float>());
    return out;
  };
  const terrain::PackedMaterial defaults = terrain::pack_material({});
  const std::vector<float> default_floats(defaults.begin(), defaults.end());
  EXPECT_EQ(packed_of("/api/v1/scenes/craters@1/trace.json"), default_floats);
  const std::vector<float> butte = packed_of("/api/v1/scenes/butte@1/trace.json");
  ASSERT_EQ(butte.size(), terrain::kMaterialFloats);
  EXPECT_NE(butte, default_floats);
  EXPECT_EQ(butte[terrain::material_offset("snow_line")], 2.0f);
  EXPECT_EQ(packed_of("/api/v1/planets/default/material.json"), default_floats);
  const auto body =
      nlohmann::json::parse(get("/api/v1/planets/default/material.json").body().view());
  EXPECT_EQ(body.at("relief").at(0), 0.0);
  EXPECT_GT(body.at("relief").at(1).get<double>(), 5000.0);
  EXPECT_EQ(body.at("shore_band"), 15.0);
}

// A tile of an immutable URL asked for again is answered by a remembered route, without parsing,
// resolving or building its key: with the very status, fields and bytes of the full route, for
// GET and HEAD, HTTP/1.0 and 1.1, revalidation, gzip and CORS, and one cache hit counted per
// request (a scene version's and a planet id's tiles alike).
TEST_F(AppTest, RememberedTileRoutesAnswerAsTheFullRoute) {
  const std::string planet = "/api/v1/planets/" + app_->default_planet_id();
  for (const std::string& url :
       {std::string("/api/v1/scenes/hills-river@1/tiles/0/0/0.png?scheme=local&encoding=gray16"),
        std::string("/api/v1/scenes/hills-river@1/mesh/0/0/0.glb?grid=9"),
        planet + "/tiles/1/1/0.png?encoding=terrarium"}) {
    SCOPED_TRACE(url);
    const Response first = get(url);  // generated and cached; the route is remembered
    ASSERT_EQ(first.result(), http::status::ok) << first.body().view();
    const std::string etag(first[http::field::etag]);
    const std::vector<std::vector<std::pair<http::field, std::string>>> variants = {
        {},
        {{http::field::if_none_match, etag}},
        {{http::field::if_none_match, "\"other\", " + etag}},
        {{http::field::accept_encoding, "gzip"}},
        {{http::field::origin, "https://a.example"}},
        {{http::field::origin, "https://b.example"}},
        {{http::field::connection, "close"}},
    };
    int spelling = 0;
    for (const http::verb method : {http::verb::get, http::verb::head}) {
      for (const unsigned version : {11u, 10u}) {
        for (const auto& headers : variants) {
          // The same product under a URL not seen before takes the full route.
          Request full{method, url + "&spelling=" + std::to_string(++spelling), version};
          Request remembered{method, url, version};
          for (const auto& [field, value] : headers) {
            full.set(field, value);
            remembered.set(field, value);
          }
          const Outcome expected = app_->handle(full);
          const std::int64_t hits = app_->cache().hits(), misses = app_->cache().misses();
          const Outcome answered = app_->handle(remembered);
          EXPECT_EQ(app_->cache().hits(), hits + 1);
          EXPECT_EQ(app_->cache().misses(), misses);
          ASSERT_TRUE(std::holds_alternative<Response>(expected));
          ASSERT_TRUE(std::holds_alternative<Response>(answered));
          const Response& a = std::get<Response>(expected);
          const Response& b = std::get<Response>(answered);
          EXPECT_EQ(a.result(), b.result());
          EXPECT_EQ(a.version(), b.version());
          EXPECT_EQ(a.body().view(), b.body().view());
          std::vector<std::pair<std::string, std::string>> fields_a, fields_b;
          for (const auto& f : a) fields_a.emplace_back(f.name_string(), f.value());
          for (const auto& f : b) fields_b.emplace_back(f.name_string(), f.value());
          EXPECT_EQ(fields_a, fields_b);
        }
      }
    }
  }
}

// A head ref names whatever version is newest: its tiles are never answered by a remembered
// route, so a new version's tile shows at once.
TEST_F(AppTest, HeadRefTilesFollowNewVersions) {
  auto scene = [](double elevation) {
    return nlohmann::json{
        {"format", "terrain-scene/1"},
        {"name", "Remembered"},
        {"seed", 1},
        {"extent", {{"min", {-1000, -1000}}, {"max", {1000, 1000}}}},
        {"root", {{"type", "disc"}, {"center", {0, 0}}, {"radius", 800}, {"elevation", elevation}}}}
        .dump();
  };
  auto write = [](http::verb method, const std::string& target, const std::string& body) {
    Request request{method, target, 11};
    request.set(http::field::authorization, "Bearer app-test-token");
    request.body() = body;
    request.prepare_payload();
    return settle(*app_, request);
  };
  ASSERT_EQ(write(http::verb::post, "/api/v1/scenes?id=remembered", scene(100)).result(),
            http::status::created);
  const std::string head = "/api/v1/scenes/remembered/tiles/0/0/0.png?scheme=local";
  const Response v1 = get(head);
  ASSERT_EQ(v1.result(), http::status::ok) << v1.body().view();
  EXPECT_EQ(get(head)[http::field::etag], v1[http::field::etag]);  // from the cache
  ASSERT_EQ(write(http::verb::put, "/api/v1/scenes/remembered", scene(300)).result(),
            http::status::ok);
  const Response v2 = get(head);
  ASSERT_EQ(v2.result(), http::status::ok);
  EXPECT_NE(v2[http::field::etag], v1[http::field::etag]);
  EXPECT_EQ(get("/api/v1/scenes/remembered@1/tiles/0/0/0.png?scheme=local")[http::field::etag],
            v1[http::field::etag]);
}

// The documented minimum scale is stored as the float nearest 1e-4, just below it in double: the
// stored scene must read back, or every later GET of it and its products would fail.
TEST_F(AppTest, SceneAtTheMinimumScaleIsStoredAndReadsBack) {
  const nlohmann::json scene{
      {"format", "terrain-scene/1"},
      {"name", "Tiny scale"},
      {"extent", {{"min", {-1000, -1000}}, {"max", {1000, 1000}}}},
      {"root",
       {{"type", "blend"},
        {"children",
         {{{"type", "transform"},
           {"scale", 1e-4},
           {"children",
            {{{"type", "disc"}, {"center", {0, 0}}, {"radius", 5e6}, {"elevation", 100}}}}}}}}}};
  Request post{http::verb::post, "/api/v1/scenes?id=tiny-scale", 11};
  post.set(http::field::authorization, "Bearer app-test-token");
  post.body() = scene.dump();
  post.prepare_payload();
  const Response created = settle(*app_, post);
  ASSERT_EQ(created.result(), http::status::created) << created.body().view();
  // A second server on the same store has nothing in memory: it reads the stored text.
  auto store = open_sqlite_store(dir_.string());
  ASSERT_TRUE(store.ok());
  App restarted(test_config(), std::move(store).value());
  Request get_scene{http::verb::get, "/api/v1/scenes/tiny-scale", 11};
  const Response stored = settle(restarted, get_scene);
  ASSERT_EQ(stored.result(), http::status::ok) << stored.body().view();
  Request get_tile{http::verb::get, "/api/v1/scenes/tiny-scale@1/tiles/0/0/0.png?scheme=local", 11};
  const Response tile = settle(restarted, get_tile);
  EXPECT_EQ(tile.result(), http::status::ok) << tile.body().view();
}

// What a live connection is sent, kept for the test to read.
class CollectedReplies final : public LiveSubscriber {
 public:
  void deliver(std::shared_ptr<const std::string> message) override {
    messages.push_back(std::move(message));
  }
  std::vector<std::shared_ptr<const std::string>> messages;
};

// Found by live_message_fuzz: a parser's message quoting bytes that are not UTF-8 made the
// error reply's serialisation throw, ending the process.
TEST_F(AppTest, LiveMessagesThatAreNotUtf8AreAnsweredWithTheBytesEscaped) {
  Request upgrade{http::verb::get, "/api/v1/scenes/hills-river/live", 11};
  auto connection = app_->live_open(upgrade);
  ASSERT_TRUE(connection);
  auto replies = std::make_shared<CollectedReplies>();
  connection->self = replies;
  EXPECT_NO_THROW(app_->live_message(*connection, "{\"\x8c\x86\": 1"));
  ASSERT_EQ(replies->messages.size(), 1u);
  const nlohmann::json reply = nlohmann::json::parse(*replies->messages[0]);
  EXPECT_EQ(reply["type"], "error");
  EXPECT_NE(reply["detail"].get<std::string>().find("\\x8C"), std::string::npos) << reply.dump();
  app_->live_close(*connection);
}

}  // namespace
}  // namespace server
