// GET /api/v1/scenes/{ref}/analysis.json and scenes with erosion nodes over HTTP: the figures
// of `terrain analyze`, cached like every product; eroded scenes stored and analysed; their
// cost refused before anything is stored; malformed queries named.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "http_harness.hpp"

namespace http_test {
namespace {

class HttpAnalysis : public SharedServerTest<HttpAnalysis> {
 public:
  static constexpr const char* kFolder = "analysis";
  static std::vector<std::string> server_arguments() { return {"--write-token", kToken}; }
};

std::string eroded_scene(int resolution, int iterations) {
  return R"({"format": "terrain-scene/1", "name": "Eroded", "seed": 4,
    "extent": {"min": [-1000, -1000], "max": [1000, 1000]},
    "root": {"type": "erosion", "resolution": )" +
         std::to_string(resolution) + R"(, "iterations": )" + std::to_string(iterations) +
         R"(, "center": [0, 0], "size": 2000,
      "children": [{"type": "disc", "center": [0, 0], "radius": 1400, "elevation": 400,
        "noise": {"kind": "ridged", "amplitude": 500, "wavelength": 900, "octaves": 6}}]}})";
}

void expect_problem_at(const Response& r, unsigned status, const std::string& pointer) {
  EXPECT_EQ(r.result_int(), status) << r.body();
  EXPECT_EQ(header(r, http::field::content_type), "application/problem+json");
  EXPECT_EQ(body_json(r).value("pointer", std::string("(none)")), pointer) << r.body();
}

TEST_F(HttpAnalysis, ABuiltInSceneHasItsGeomorphometry) {
  const Response r = get("/api/v1/scenes/craters/analysis.json?size=64");
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(header(r, http::field::content_type), "application/json");
  const json body = body_json(r);
  EXPECT_EQ(body["grid"]["width"], 64);
  EXPECT_GT(body["land_cells"].get<std::int64_t>(), 0);
  EXPECT_TRUE(body["pits"].contains("share"));
  EXPECT_TRUE(body.contains("flint") && body.contains("strahler"));
  ASSERT_TRUE(body["slope_area"].is_array() && !body["slope_area"].empty());
  EXPECT_GT(body["slope_area"][0]["cells"].get<std::int64_t>(), 0);
  std::string craters_hash;
  const json list = body_json(get("/api/v1/scenes"));
  for (const json& s : list["scenes"]) {
    if (s["id"] == "craters") craters_hash = s["hash"];
  }
  EXPECT_EQ(body["input"]["scene_hash"], craters_hash);
  // A product like the others: a strong ETag, and 304 for a client that has it.
  const std::string etag = header(r, http::field::etag);
  ASSERT_FALSE(etag.empty());
  EXPECT_EQ(
      get("/api/v1/scenes/craters/analysis.json?size=64", {{"If-None-Match", etag}}).result_int(),
      304u);
}

TEST_F(HttpAnalysis, AnErodedSceneIsStoredAndDrains) {
  const Response created =
      fetch("POST", "/api/v1/scenes?id=eroded", with_token(), eroded_scene(128, 12));
  ASSERT_EQ(created.result_int(), 201u) << created.body();
  // The analysis grid is the erosion grid: every sample of it drains.
  const Response r = get("/api/v1/scenes/eroded/analysis.json?size=128");
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  const json body = body_json(r);
  EXPECT_EQ(body["pits"]["count"], 0) << body.dump();
  EXPECT_EQ(body["closed_depressions"]["cells"], 0) << body.dump();
  // Its tiles are served like any scene's.
  EXPECT_EQ(get("/api/v1/scenes/eroded/tiles/0/0/0.png?scheme=local").result_int(), 200u);
}

// Malformed input, together.

TEST_F(HttpAnalysis, BadQueriesAreProblemsNamingTheParameter) {
  expect_problem_at(get("/api/v1/scenes/craters/analysis.json?size=1"), 400, "/size");
  expect_problem_at(get("/api/v1/scenes/craters/analysis.json?size=abc"), 400, "/size");
  expect_problem_at(get("/api/v1/scenes/craters/analysis.json?size=5000"), 400, "/size");
  expect_problem_at(get("/api/v1/scenes/craters/analysis.json?sea_level=high"), 400, "/sea_level");
  expect_problem_at(get("/api/v1/scenes/craters/analysis.json?channel_area=-4"), 400,
                    "/channel_area");
  EXPECT_EQ(get("/api/v1/scenes/no-such-scene/analysis.json").result_int(), 404u);
}

TEST_F(HttpAnalysis, ErosionBeyondTheLimitsIsRefusedAndNothingIsStored) {
  const Response r =
      fetch("PUT", "/api/v1/scenes/too-eroded", with_token(), eroded_scene(2048, 400));
  expect_problem_at(r, 422, "/root/resolution");
  EXPECT_EQ(get("/api/v1/scenes/too-eroded").result_int(), 404u);
  expect_problem_at(fetch("PUT", "/api/v1/scenes/bad-erosion", with_token(), eroded_scene(8, 10)),
                    400, "/root/resolution");
}

}  // namespace
}  // namespace http_test
