// Baked grids (erosion, drainage) shared through the disk cache and the store: a second server —
// a replica, or the same one restarted — finds the grids the first computed instead of computing
// them again.
#include <gtest/gtest.h>

#include "http_harness.hpp"
#include "postgres_cluster.hpp"

namespace server {
namespace {

using namespace http_test;

// /sample is never cached as a product: answering it needs the scene's grids.

/// `target`'s answer from a server that bakes its grids (an erosion's and a drainage's).
void sample_baking(int port, const std::string& target, json& answer) {
  const Response r = get(port, target);
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  answer = body_json(r);
  EXPECT_GE(metric(port, "terrain_bake_made_total"), 2.0);  // erosion and drainage
}

/// The same answer from a server that found every grid in a shared store and made none.
void expect_sample_from_shared_grids(int port, const std::string& target, const json& expected) {
  const Response r = get(port, target);
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(body_json(r), expected);
  EXPECT_EQ(metric(port, "terrain_bake_made_total"), 0.0);
  EXPECT_GE(metric(port, "terrain_bake_shared_hits_total"), 1.0);
}

/// Posts the eroded, drained dome as scene "drained".
void post_drained_dome(int port) {
  const Response created = fetch(port, "POST", "/api/v1/scenes?id=drained", with_token(),
                                 drained_dome_scene(/*eroded=*/true));
  ASSERT_EQ(created.result_int(), 201u) << created.body();
}

TEST(SharedBakes, AReplicaFindsTheGridsAnotherComputedInTheDiskCache) {
  TempDir dir("shared-bakes");
  const std::string disk = (dir.path() / "disk").string();
  const std::string target = "/api/v1/scenes/river-lake/sample?x=-300&y=-1800";
  json first_sample;
  {
    ServerProcess first(dir.path() / "data-a", {"--disk-cache-dir", disk});
    ASSERT_NO_FATAL_FAILURE(sample_baking(first.port(), target, first_sample));
    EXPECT_EQ(metric(first.port(), "terrain_bake_shared_hits_total"), 0.0);
    first.stop();
  }
  // The erosion's and the drainage's grids both come from the disk.
  ServerProcess replica(dir.path() / "data-b", {"--disk-cache-dir", disk});
  expect_sample_from_shared_grids(replica.port(), target, first_sample);
  replica.stop();
}

TEST(SharedBakes, ARestartedServerFindsTheGridsItComputedInItsStore) {
  TempDir dir("stored-bakes");
  const std::vector<std::string> flags = {"--write-token", http_test::kToken};
  const std::string target = "/api/v1/scenes/drained/sample?x=0&y=0";
  json first_sample;
  {
    ServerProcess first(dir.path() / "data", flags);
    ASSERT_NO_FATAL_FAILURE(post_drained_dome(first.port()));
    ASSERT_NO_FATAL_FAILURE(sample_baking(first.port(), target, first_sample));
    first.stop();
  }
  // No disk cache, no Redis: the grids come from the SQLite store.
  ServerProcess restarted(dir.path() / "data", flags);
  expect_sample_from_shared_grids(restarted.port(), target, first_sample);
  restarted.stop();
}

TEST(SharedBakes, AReplicaOnTheSamePostgresFindsTheGridsAnotherComputed) {
  const std::string url = pg_test::shared_cluster().create_database();
  TempDir dir("pg-bakes");
  const std::vector<std::string> flags = {"--write-token", http_test::kToken, "--store-backend",
                                          "postgres",      "--postgres-url",  url};
  const std::string target = "/api/v1/scenes/drained/sample?x=0&y=0";
  ServerProcess a(dir.path() / "a", flags);
  ASSERT_NO_FATAL_FAILURE(post_drained_dome(a.port()));
  json from_a;
  ASSERT_NO_FATAL_FAILURE(sample_baking(a.port(), target, from_a));
  ServerProcess b(dir.path() / "b", flags);
  expect_sample_from_shared_grids(b.port(), target, from_a);
}

}  // namespace
}  // namespace server
