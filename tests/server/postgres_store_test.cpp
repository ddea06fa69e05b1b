// What only the PostgreSQL store has to show: several stores (as several server processes would)
// writing one scene get distinct consecutive versions and one winner per If-Match race;
// PostgreSQL going away makes calls fail promptly with `unavailable` and coming back makes them
// work again; replicas starting together migrate once; no call waits on a lock without bound.
// The shared contract runs in store_test.cpp against both backends.
#include <gtest/gtest.h>

#include <latch>
#include <set>
#include <thread>

#include "postgres_cluster.hpp"
#include "server/postgres_store.hpp"
#include "store_fixtures.hpp"

namespace server {
namespace {

using Clock = std::chrono::steady_clock;
using Millis = std::chrono::milliseconds;

PostgresOptions at(const std::string& url) {
  PostgresOptions options;
  options.conninfo = url;
  return options;
}

std::unique_ptr<Store> open_or_die(const PostgresOptions& options) {
  StoreResult<std::unique_ptr<Store>> s = open_postgres_store(options);
  if (!s) throw std::runtime_error(s.error().message);
  return std::move(s).value();
}

using store_fixtures::body;

TEST(PostgresStore, WritersInTwoStoresGetDistinctConsecutiveVersions) {
  const std::string url = pg_test::shared_cluster().create_database();
  std::unique_ptr<Store> stores[2] = {open_or_die(at(url)), open_or_die(at(url))};
  ASSERT_TRUE(stores[0]->create_scene("a", body("{}")).ok());
  constexpr int kThreads = 4;
  constexpr int kEach = 10;
  std::latch go(kThreads);
  std::vector<std::thread> writers;
  for (int t = 0; t < kThreads; ++t) {
    writers.emplace_back([&, t] {
      go.arrive_and_wait();
      for (int i = 0; i < kEach; ++i) {
        const auto v = stores[t % 2]->add_version(
            "a", body("{\"t\":" + std::to_string(t * 100 + i) + "}"), std::nullopt);
        EXPECT_TRUE(v.ok()) << v.error().message;
      }
    });
  }
  for (std::thread& w : writers) w.join();
  const auto all = stores[1]->versions_after("a", 0, -1);
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), std::size_t{kThreads * kEach + 1});
  std::set<std::string> bodies;
  for (std::size_t i = 0; i < all->size(); ++i) {
    EXPECT_EQ((*all)[i].version, std::int64_t(i) + 1);
    bodies.insert((*all)[i].canonical_json);
  }
  EXPECT_EQ(bodies.size(), all->size());  // every write stored once
  EXPECT_EQ(stores[0]->head("a")->version, kThreads * kEach + 1);
}

// Two stores racing with the same If-Match: one version is stored, the other is a conflict.
TEST(PostgresStore, OneWinnerPerIfMatchRace) {
  const std::string url = pg_test::shared_cluster().create_database();
  std::unique_ptr<Store> stores[2] = {open_or_die(at(url)), open_or_die(at(url))};
  ASSERT_TRUE(stores[0]->create_scene("a", body("{}")).ok());
  for (int round = 1; round <= 5; ++round) {
    std::latch go(2);
    StoreError::Kind kinds[2]{};
    bool stored[2]{};
    std::vector<std::thread> racers;
    for (int s = 0; s < 2; ++s) {
      racers.emplace_back([&, s] {
        go.arrive_and_wait();
        const auto v = stores[s]->add_version(
            "a", body("{\"r\":" + std::to_string(round * 10 + s) + "}"), round);
        stored[s] = v.ok();
        if (!v.ok()) kinds[s] = v.error().kind;
      });
    }
    for (std::thread& r : racers) r.join();
    ASSERT_NE(stored[0], stored[1]) << "round " << round;
    EXPECT_EQ(kinds[stored[0] ? 1 : 0], StoreError::Kind::conflict);
    EXPECT_EQ(stores[1]->head("a")->version, round + 1);
  }
}

// While PostgreSQL is down every call fails promptly as unavailable and writes nothing; once it
// is back, calls work again, and a restart between two calls is not even noticed (the dead
// pooled connections are replaced).
TEST(PostgresStore, RestartFailsCallsAsUnavailableThenRecovers) {
  pg_test::Cluster& cluster = pg_test::shared_cluster();
  const std::string url = cluster.create_database();
  std::unique_ptr<Store> store = open_or_die(at(url));
  ASSERT_TRUE(store->create_scene("a", body("{\"v\":1}")).ok());
  ASSERT_TRUE(store->put_planet({std::string(64, 'a'), "{\"seed\":1}", 0}).ok());

  cluster.stop();
  const auto started = Clock::now();
  const auto read = store->head("a");
  const auto write = store->add_version("a", body("{\"v\":2}"), std::nullopt);
  const auto create = store->create_scene("b", body("{}"));
  const auto planet = store->get_planet(std::string(64, 'a'));
  cluster.start();
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().kind, StoreError::Kind::unavailable);
  ASSERT_FALSE(write.ok());
  EXPECT_EQ(write.error().kind, StoreError::Kind::unavailable) << write.error().message;
  ASSERT_FALSE(create.ok());
  EXPECT_EQ(create.error().kind, StoreError::Kind::unavailable);
  ASSERT_FALSE(planet.ok());
  EXPECT_EQ(planet.error().kind, StoreError::Kind::unavailable);
  EXPECT_LT(Clock::now() - started, Millis(5'000));

  // Back: within a moment (a failed connect is not retried for a quarter of a second).
  const auto deadline = Clock::now() + Millis(10'000);
  StoreResult<SceneVersion> head = store->head("a");
  while (!head.ok() && Clock::now() < deadline) {
    std::this_thread::sleep_for(Millis(50));
    head = store->head("a");
  }
  ASSERT_TRUE(head.ok()) << head.error().message;
  EXPECT_EQ(head->version, 1);  // the refused write stored nothing
  EXPECT_EQ(store->head("b").error().kind, StoreError::Kind::not_found);
  ASSERT_TRUE(store->add_version("a", body("{\"v\":2}"), 1).ok());

  // A restart while idle: the first call afterwards already succeeds.
  cluster.stop();
  cluster.start();
  const auto after = store->add_version("a", body("{\"v\":3}"), 2);
  ASSERT_TRUE(after.ok()) << after.error().message;
  EXPECT_EQ(after->version, 3);
  EXPECT_EQ(store->get_planet(std::string(64, 'a'))->canonical_json, "{\"seed\":1}");
}

TEST(PostgresStore, ConcurrentOpensMigrateOnce) {
  pg_test::Cluster& cluster = pg_test::shared_cluster();
  const std::string url = cluster.create_database();
  constexpr int kReplicas = 4;
  std::latch go(kReplicas);
  std::vector<std::unique_ptr<Store>> stores(kReplicas);
  std::vector<std::string> errors(kReplicas);
  std::vector<std::thread> openers;
  for (int i = 0; i < kReplicas; ++i) {
    openers.emplace_back([&, i] {
      go.arrive_and_wait();
      StoreResult<std::unique_ptr<Store>> s = open_postgres_store(at(url));
      if (s) {
        stores[static_cast<std::size_t>(i)] = std::move(s).value();
      } else {
        errors[static_cast<std::size_t>(i)] = s.error().message;
      }
    });
  }
  for (std::thread& t : openers) t.join();
  for (int i = 0; i < kReplicas; ++i) {
    ASSERT_TRUE(stores[static_cast<std::size_t>(i)]) << errors[static_cast<std::size_t>(i)];
  }
  const std::string db = url.substr(url.rfind('/') + 1);
  EXPECT_EQ(cluster.exec(db,
                         "SELECT version, COUNT(*) FROM schema_migrations "
                         "GROUP BY version ORDER BY version"),
            (std::vector<std::string>{"1", "1", "2", "1", "3", "1", "4", "1"}));
  ASSERT_TRUE(stores[0]->create_scene("a", body("{}")).ok());
  EXPECT_EQ(stores[kReplicas - 1]->head("a")->version, 1);
  // Opening again applies nothing.
  open_or_die(at(url));
  EXPECT_EQ(cluster.exec(db, "SELECT COUNT(*) FROM schema_migrations"),
            std::vector<std::string>{"4"});
}

TEST(PostgresStore, ASchemaFromANewerServerIsRefused) {
  pg_test::Cluster& cluster = pg_test::shared_cluster();
  const std::string url = cluster.create_database();
  open_or_die(at(url));
  const std::string db = url.substr(url.rfind('/') + 1);
  cluster.exec(db, "INSERT INTO schema_migrations VALUES (99, 0)");
  const auto s = open_postgres_store(at(url));
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().kind, StoreError::Kind::unavailable);
  EXPECT_NE(s.error().message.find("newer"), std::string::npos) << s.error().message;
}

// No server there, or a malformed URL: a prompt error naming the problem, never a hang.
TEST(PostgresStore, UnreachableOrMalformedUrlsFailPromptly) {
  const auto started = Clock::now();
  const auto nobody = open_postgres_store(
      at("postgresql://terrain@127.0.0.1:" + std::to_string(pg_test::free_port()) + "/x"));
  ASSERT_FALSE(nobody.ok());
  EXPECT_EQ(nobody.error().kind, StoreError::Kind::unavailable);
  EXPECT_NE(nobody.error().message.find("cannot connect"), std::string::npos);
  EXPECT_LT(Clock::now() - started, Millis(5'000));
  const auto malformed = open_postgres_store(at("postgresql://[::1"));
  ASSERT_FALSE(malformed.ok());
  EXPECT_EQ(malformed.error().message.rfind("store.postgres_url: ", 0), 0u)
      << malformed.error().message;
  EXPECT_FALSE(open_postgres_store(at("host=127.0.0.1 bogus_option=1")).ok());
}

// A scene row held by another transaction (a stuck writer) delays a version by lock_timeout at
// most, then fails as unavailable and writes nothing.
TEST(PostgresStore, ALockedSceneTimesOutInsteadOfHanging) {
  pg_test::Cluster& cluster = pg_test::shared_cluster();
  const std::string url = cluster.create_database();
  PostgresOptions options = at(url);
  options.lock_timeout_ms = 300;
  std::unique_ptr<Store> store = open_or_die(options);
  ASSERT_TRUE(store->create_scene("a", body("{}")).ok());
  PGconn* holder = PQconnectdb(url.c_str());
  ASSERT_EQ(PQstatus(holder), CONNECTION_OK);
  PQclear(PQexec(holder, "BEGIN"));
  PGresult* locked = PQexec(holder, "SELECT head FROM scenes WHERE id = 'a' FOR UPDATE");
  EXPECT_EQ(PQresultStatus(locked), PGRES_TUPLES_OK);
  PQclear(locked);
  const auto started = Clock::now();
  const auto v = store->add_version("a", body("{\"x\":1}"), std::nullopt);
  const auto waited = Clock::now() - started;
  PQclear(PQexec(holder, "ROLLBACK"));
  PQfinish(holder);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.error().kind, StoreError::Kind::unavailable);
  EXPECT_GE(waited, Millis(250));
  EXPECT_LT(waited, Millis(5'000));
  EXPECT_EQ(store->head("a")->version, 1);
  EXPECT_EQ(store->add_version("a", body("{\"x\":1}"), 1)->version, 2);  // the pool recovered
}

}  // namespace
}  // namespace server
