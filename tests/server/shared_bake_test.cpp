// Baked grids (erosion, drainage) shared through the disk cache and the store: a second server —
// a replica, or the same one restarted — finds the grids the first computed instead of computing
// them again.
#include <gtest/gtest.h>

#include "http_harness.hpp"
#include "postgres_cluster.hpp"

namespace server {
namespace {

using namespace http_test;

TEST(SharedBakes, AReplicaFindsTheGridsAnotherComputedInTheDiskCache) {
  TempDir dir("shared-bakes");
  const std::string disk = (dir.path() / "disk").string();
  // /sample is never cached as a product: answering it needs the scene's grids.
  const std::string target = "/api/v1/scenes/river-lake/sample?x=1500&y=100";
  json first_sample;
  {
    ServerProcess first(dir.path() / "data-a", {"--disk-cache-dir", disk});
    const Response r = get(first.port(), target);
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    first_sample = body_json(r);
    EXPECT_GE(metric(first.port(), "terrain_bake_made_total"), 2.0);  // erosion and drainage
    EXPECT_EQ(metric(first.port(), "terrain_bake_shared_hits_total"), 0.0);
    first.stop();
  }
  ServerProcess replica(dir.path() / "data-b", {"--disk-cache-dir", disk});
  const Response r = get(replica.port(), target);
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(body_json(r), first_sample);
  // The erosion's and the drainage's grids both come from the disk.
  EXPECT_EQ(metric(replica.port(), "terrain_bake_made_total"), 0.0);
  EXPECT_GE(metric(replica.port(), "terrain_bake_shared_hits_total"), 1.0);
  replica.stop();
}

TEST(SharedBakes, ARestartedServerFindsTheGridsItComputedInItsStore) {
  TempDir dir("stored-bakes");
  const std::vector<std::string> flags = {"--write-token", http_test::kToken};
  const std::string target = "/api/v1/scenes/drained/sample?x=0&y=0";
  json first_sample;
  {
    ServerProcess first(dir.path() / "data", flags);
    const Response created = fetch(first.port(), "POST", "/api/v1/scenes?id=drained", with_token(),
                                   drained_dome_scene(/*eroded=*/true));
    ASSERT_EQ(created.result_int(), 201u) << created.body();
    const Response r = get(first.port(), target);
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    first_sample = body_json(r);
    EXPECT_GE(metric(first.port(), "terrain_bake_made_total"), 2.0);  // erosion and drainage
    first.stop();
  }
  // No disk cache, no Redis: the grids come from the SQLite store.
  ServerProcess restarted(dir.path() / "data", flags);
  const Response r = get(restarted.port(), target);
  ASSERT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(body_json(r), first_sample);
  EXPECT_EQ(metric(restarted.port(), "terrain_bake_made_total"), 0.0);
  EXPECT_GE(metric(restarted.port(), "terrain_bake_shared_hits_total"), 1.0);
  restarted.stop();
}

TEST(SharedBakes, AReplicaOnTheSamePostgresFindsTheGridsAnotherComputed) {
  const std::string url = pg_test::shared_cluster().create_database();
  TempDir dir("pg-bakes");
  const std::vector<std::string> flags = {"--write-token", http_test::kToken, "--store-backend",
                                          "postgres",      "--postgres-url",  url};
  ServerProcess a(dir.path() / "a", flags);
  const Response created = fetch(a.port(), "POST", "/api/v1/scenes?id=drained", with_token(),
                                 drained_dome_scene(/*eroded=*/true));
  ASSERT_EQ(created.result_int(), 201u) << created.body();
  const std::string target = "/api/v1/scenes/drained/sample?x=0&y=0";
  const Response from_a = get(a.port(), target);
  ASSERT_EQ(from_a.result_int(), 200u) << from_a.body();
  EXPECT_GE(metric(a.port(), "terrain_bake_made_total"), 2.0);

  ServerProcess b(dir.path() / "b", flags);
  const Response from_b = get(b.port(), target);
  ASSERT_EQ(from_b.result_int(), 200u) << from_b.body();
  EXPECT_EQ(body_json(from_b), body_json(from_a));
  EXPECT_EQ(metric(b.port(), "terrain_bake_made_total"), 0.0);
  EXPECT_GE(metric(b.port(), "terrain_bake_shared_hits_total"), 1.0);
}

}  // namespace
}  // namespace server
