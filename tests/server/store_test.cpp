// Both stores, one contract: versions are immutable and ordered, If-Match conflicts write
// nothing, data survives reopening, blobs are content-addressed. Every test runs against SQLite
// and against PostgreSQL (a throwaway cluster, postgres_cluster.hpp; a database per test).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <thread>

#include "postgres_cluster.hpp"
#include "server/config.hpp"
#include "server/store.hpp"
#include "store_fixtures.hpp"

namespace server {
namespace {

namespace fs = std::filesystem;
using store_fixtures::body;

class StoreTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (GetParam() == "postgres") {
      config_.store_backend = StoreBackend::postgres;
      config_.postgres_url = pg_test::shared_cluster().create_database();
    } else {
      std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
      std::replace(name.begin(), name.end(), '/', '-');
      dir_ =
          fs::temp_directory_path() / ("terrain-store-" + std::to_string(::getpid()) + "-" + name);
      fs::remove_all(dir_);
      config_.data_dir = dir_.string();
    }
    store_ = open_or_die();
  }
  void TearDown() override {
    store_.reset();
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  std::unique_ptr<Store> open_or_die() {
    StoreResult<std::unique_ptr<Store>> s = open_store(config_);
    if (!s) throw std::runtime_error(s.error().message);
    return std::move(s).value();
  }

  Config config_;
  fs::path dir_;
  std::unique_ptr<Store> store_;
};

INSTANTIATE_TEST_SUITE_P(Backends, StoreTest, ::testing::Values("sqlite", "postgres"),
                         [](const ::testing::TestParamInfo<std::string>& param) {
                           return param.param;
                         });

TEST_P(StoreTest, NewStoreIsEmpty) {
  EXPECT_TRUE(*store_->empty());
  EXPECT_TRUE(store_->list_scenes()->empty());
}

TEST_P(StoreTest, VersionsCountUpAndStayImmutable) {
  ASSERT_TRUE(store_->create_scene("a", body("{\"v\":1}")).ok());
  StoreResult<SceneVersion> v2 = store_->add_version("a", body("{\"v\":2}"), std::nullopt);
  ASSERT_TRUE(v2.ok());
  EXPECT_EQ(v2->version, 2);
  EXPECT_EQ(store_->head("a")->canonical_json, "{\"v\":2}");
  EXPECT_EQ(store_->version("a", 1)->canonical_json, "{\"v\":1}");
  EXPECT_EQ(store_->version_by_hash("a", v2->hash)->version, 2);
  const auto all = store_->versions("a");
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].version, 1);
  EXPECT_TRUE((*all)[0].canonical_json.empty());  // metadata only
  const auto list = store_->list_scenes();
  ASSERT_EQ(list->size(), 1u);
  EXPECT_EQ((*list)[0].head_version, 2);
  EXPECT_EQ((*list)[0].head_hash, v2->hash);
}

TEST_P(StoreTest, StaleIfMatchIsAConflictAndWritesNothing) {
  ASSERT_TRUE(store_->create_scene("a", body("{}")).ok());
  ASSERT_TRUE(store_->add_version("a", body("{\"x\":1}"), 1).ok());
  StoreResult<SceneVersion> stale = store_->add_version("a", body("{\"x\":2}"), 1);
  ASSERT_FALSE(stale.ok());
  EXPECT_EQ(stale.error().kind, StoreError::Kind::conflict);
  EXPECT_EQ(store_->head("a")->version, 2);
  EXPECT_EQ(store_->versions("a")->size(), 2u);
}

TEST_P(StoreTest, ConcurrentWritersGetDistinctVersions) {
  ASSERT_TRUE(store_->create_scene("a", body("{}")).ok());
  std::vector<std::thread> writers;
  for (int t = 0; t < 4; ++t) {
    writers.emplace_back([&, t] {
      for (int i = 0; i < 10; ++i) {
        ASSERT_TRUE(store_
                        ->add_version("a", body("{\"t\":" + std::to_string(t * 100 + i) + "}"),
                                      std::nullopt)
                        .ok());
      }
    });
  }
  for (std::thread& w : writers) w.join();
  const auto all = store_->versions("a");
  ASSERT_EQ(all->size(), 41u);
  for (std::size_t i = 0; i < all->size(); ++i) EXPECT_EQ((*all)[i].version, std::int64_t(i) + 1);
}

TEST_P(StoreTest, SurvivesReopening) {
  ASSERT_TRUE(store_->create_scene("a", body("{\"k\":1}")).ok());
  const std::vector<std::uint8_t> bytes{1, 2, 3};
  const Blob blob{content_hash(bytes.data(), bytes.size()), "image/png", bytes};
  ASSERT_TRUE(store_->put_blob(blob).ok());
  store_ = open_or_die();
  EXPECT_EQ(store_->head("a")->canonical_json, "{\"k\":1}");
  EXPECT_EQ(store_->blob(blob.hash)->bytes, bytes);
  EXPECT_FALSE(*store_->empty());
}

TEST_P(StoreTest, BlobsAreIdempotent) {
  const std::vector<std::uint8_t> bytes{9, 9};
  const Blob blob{content_hash(bytes.data(), bytes.size()), "image/png", bytes};
  ASSERT_TRUE(store_->put_blob(blob).ok());
  ASSERT_TRUE(store_->put_blob(blob).ok());
  EXPECT_EQ(store_->blob(blob.hash)->media_type, "image/png");
}

// Missing things and conflicts, together.
TEST_P(StoreTest, MissingAndDuplicateAreClassified) {
  EXPECT_EQ(store_->head("nope").error().kind, StoreError::Kind::not_found);
  EXPECT_EQ(store_->version("nope", 1).error().kind, StoreError::Kind::not_found);
  EXPECT_EQ(store_->versions("nope").error().kind, StoreError::Kind::not_found);
  EXPECT_EQ(store_->add_version("nope", body("{}"), std::nullopt).error().kind,
            StoreError::Kind::not_found);
  EXPECT_EQ(store_->blob("sha256:00").error().kind, StoreError::Kind::not_found);
  ASSERT_TRUE(store_->create_scene("a", body("{}")).ok());
  EXPECT_EQ(store_->create_scene("a", body("{}")).error().kind, StoreError::Kind::conflict);
  EXPECT_EQ(store_->version("a", 2).error().kind, StoreError::Kind::not_found);
}

TEST_P(StoreTest, PlanetsAreStoredOnceByIdAndSurviveReopening) {
  EXPECT_TRUE(store_->list_planets()->empty());
  const StoredPlanet a{std::string(64, 'a'), "{\"seed\":1}", 0};
  const StoredPlanet b{std::string(64, 'b'), "{\"seed\":2}", 0};
  StoreResult<PlanetPut> first = store_->put_planet(a);
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_TRUE(first->created);
  EXPECT_GT(first->planet.created_ms, 0);
  // The same planet again is no error and changes nothing: the stored one comes back.
  StoreResult<PlanetPut> again = store_->put_planet(a);
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->created);
  EXPECT_EQ(again->planet.created_ms, first->planet.created_ms);
  ASSERT_TRUE(store_->put_planet(b).ok());
  store_ = open_or_die();
  EXPECT_EQ(store_->get_planet(a.id)->canonical_json, a.canonical_json);
  const auto all = store_->list_planets();
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].id, a.id);  // oldest first
  EXPECT_EQ((*all)[1].id, b.id);
  EXPECT_TRUE(*store_->empty());  // planets are not scenes: the example scenes still load
}

// An id names one body (it is that body's hash): another body under it is refused, and so is a
// planet without an id or body; neither writes anything.
TEST_P(StoreTest, RefusedPlanetWritesStoreNothing) {
  const StoredPlanet a{std::string(64, 'a'), "{\"seed\":1}", 0};
  ASSERT_TRUE(store_->put_planet(a).ok());
  StoreResult<PlanetPut> other = store_->put_planet({a.id, "{\"seed\":2}", 0});
  ASSERT_FALSE(other.ok());
  EXPECT_EQ(other.error().kind, StoreError::Kind::conflict);
  EXPECT_EQ(store_->get_planet(a.id)->canonical_json, a.canonical_json);
  EXPECT_FALSE(store_->put_planet({"", "{}", 0}).ok());
  EXPECT_FALSE(store_->put_planet({std::string(64, 'c'), "", 0}).ok());
  EXPECT_EQ(store_->list_planets()->size(), 1u);
  EXPECT_EQ(store_->get_planet(std::string(64, 'c')).error().kind, StoreError::Kind::not_found);
}

// What live catch-up reads: whole versions above a number, with the ops of edits, in order.
TEST_P(StoreTest, VersionsAfterCarryBodiesAndOps) {
  SceneVersion first = body("{\"v\":1}");
  first.name = "Ma\u00f1ana \u26f0";  // UTF-8 survives both stores
  ASSERT_TRUE(store_->create_scene("a", first).ok());
  SceneVersion edit = body("{\"v\":2}");
  edit.ops_json = "[{\"op\":\"replace\",\"path\":\"/v\",\"value\":2}]";
  ASSERT_TRUE(store_->add_version("a", edit, 1).ok());
  ASSERT_TRUE(store_->add_version("a", body("{\"v\":3}"), 2).ok());
  const auto after1 = store_->versions_after("a", 1, 10);
  ASSERT_TRUE(after1.ok()) << after1.error().message;
  ASSERT_EQ(after1->size(), 2u);
  EXPECT_EQ((*after1)[0].version, 2);
  EXPECT_EQ((*after1)[0].canonical_json, "{\"v\":2}");
  EXPECT_EQ((*after1)[0].ops_json, edit.ops_json);
  EXPECT_EQ((*after1)[1].ops_json, "");  // a whole body
  EXPECT_EQ(store_->versions_after("a", 0, 1)->front().name, first.name);
  EXPECT_EQ(store_->versions_after("a", 0, -1)->size(), 3u);  // a negative limit is none
  EXPECT_TRUE(store_->versions_after("a", 3, 10)->empty());
  EXPECT_TRUE(store_->versions_after("nope", 0, 10)->empty());
  EXPECT_EQ(store_->version("a", 2)->ops_json, edit.ops_json);
}

// Ids list bytewise, whatever a database's collation would say about punctuation.
TEST_P(StoreTest, ScenesListInBytewiseIdOrder) {
  for (const char* id : {"a_1", "a1", "b", "a-2"}) {
    ASSERT_TRUE(store_->create_scene(id, body("{}")).ok());
  }
  const auto list = store_->list_scenes();
  ASSERT_EQ(list->size(), 4u);
  EXPECT_EQ((*list)[0].id, "a-2");
  EXPECT_EQ((*list)[1].id, "a1");
  EXPECT_EQ((*list)[2].id, "a_1");
  EXPECT_EQ((*list)[3].id, "b");
}

TEST_P(StoreTest, BlobBytesRoundTripExactly) {
  const std::vector<std::uint8_t> bytes{0, 255, 0, 92, 120, 0};  // NULs, "\x"
  const Blob blob{content_hash(bytes.data(), bytes.size()), "image/png", bytes};
  ASSERT_TRUE(store_->put_blob(blob).ok());
  EXPECT_EQ(store_->blob(blob.hash)->bytes, bytes);
  const Blob none{content_hash(nullptr, 0), "image/png", {}};
  ASSERT_TRUE(store_->put_blob(none).ok());
  EXPECT_TRUE(store_->blob(none.hash)->bytes.empty());
}

TEST_P(StoreTest, BakedGridsRoundTripExactlyAndSurviveReopening) {
  const std::vector<std::uint8_t> grid{0, 255, 0, 92, 120, 0, 7};
  ASSERT_TRUE(*store_->put_baked_grid("bake-a", grid, 1 << 20));
  ASSERT_TRUE(*store_->put_baked_grid("bake-a", grid, 1 << 20));  // idempotent
  store_ = open_or_die();
  EXPECT_EQ(*store_->baked_grid("bake-a"), grid);
  EXPECT_EQ(store_->baked_grid("bake-b").error().kind, StoreError::Kind::not_found);
}

TEST_P(StoreTest, BakedGridsStayWithinTheirBoundTheOldestGoingFirst) {
  const std::vector<std::uint8_t> kilobyte(1000, 7);
  // Keys against their age order, so that the test sees the age and not the tie break.
  for (const char* key : {"z", "y", "x"}) {
    ASSERT_TRUE(*store_->put_baked_grid(key, kilobyte, 2500)) << key;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // distinct creation times
  }
  EXPECT_EQ(store_->baked_grid("z").error().kind, StoreError::Kind::not_found);
  EXPECT_EQ(*store_->baked_grid("y"), kilobyte);
  EXPECT_EQ(*store_->baked_grid("x"), kilobyte);
  // A grid larger than the bound is not kept, and drops nothing.
  EXPECT_FALSE(*store_->put_baked_grid("huge", std::vector<std::uint8_t>(3000, 1), 2500));
  EXPECT_EQ(store_->baked_grid("huge").error().kind, StoreError::Kind::not_found);
  EXPECT_TRUE(store_->baked_grid("y").ok());
}

}  // namespace
}  // namespace server
