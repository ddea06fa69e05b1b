// Baked grids (erosion, drainage) shared through the disk cache: a second server — a replica, or
// the same one restarted — finds the grids the first computed instead of computing them again.
#include <gtest/gtest.h>

#include "http_harness.hpp"

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

}  // namespace
}  // namespace server
