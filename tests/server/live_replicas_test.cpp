// Live editing across replicas: two terrain-server processes on one store (SQLite in WAL mode
// serialises their versions, as PostgreSQL would) and one Redis carrying version events between
// them. A viewer on one replica sees edits made through the other, in the one order the store
// gave the versions; with Redis gone, the store sweep still delivers them.
#include <gtest/gtest.h>

#include <thread>

#include "live_client.hpp"
#include "redis_harness.hpp"

namespace {

using namespace http_test;

std::string two_disc_scene() {
  return json{{"format", "terrain-scene/1"},
              {"name", "Replicas"},
              {"extent", {{"min", {-2000, -2000}}, {"max", {2000, 2000}}}},
              {"root",
               {{"type", "blend"},
                {"children",
                 {{{"type", "disc"}, {"center", {-800, 0}}, {"radius", 500}, {"elevation", 90}},
                  {{"type", "disc"}, {"center", {800, 0}}, {"radius", 500}, {"elevation", 90}}}}}}}
      .dump();
}

json append_disc(std::int64_t base, int i) {
  return {{"type", "edit"},
          {"base", base},
          {"ops",
           {{{"op", "add"},
             {"path", "/root/children/-"},
             {"value", {{"type", "disc"}, {"center", {-1500 + 100 * i, 1200}}, {"radius", 60}}}}}}};
}

class LiveReplicas : public ::testing::Test {
 protected:
  void SetUp() override {
    redis_ = std::make_unique<RedisProcess>(free_port());
    const std::vector<std::string> flags = {
        "--write-token", kToken, "--live-redis-url", redis_->url(), "--live-sweep-ms", "300"};
    // One store for both: the first replica creates and seeds it, then the second opens it.
    a_ = std::make_unique<ServerProcess>(dir_.path() / "data", flags);
    b_ = std::make_unique<ServerProcess>(dir_.path() / "data", flags);
    const Response created =
        fetch(a_->port(), "POST", "/api/v1/scenes?id=shared", with_token(), two_disc_scene());
    ASSERT_EQ(created.result_int(), 201u) << created.body();
  }
  void TearDown() override {
    a_.reset();
    b_.reset();
    redis_.reset();
  }

  TempDir dir_{"live-replicas"};
  std::unique_ptr<RedisProcess> redis_;
  std::unique_ptr<ServerProcess> a_, b_;
};

TEST_F(LiveReplicas, AnEditThroughOneReplicaReachesAViewerOnTheOther) {
  LiveClient viewer_on_b(b_->port(), "shared");
  EXPECT_EQ(viewer_on_b.subscribe(false)["head"], 1);
  LiveClient author_on_a(a_->port(), "shared");
  author_on_a.subscribe(true, std::nullopt, "alice");
  author_on_a.send(append_disc(1, 0));
  const json ack = author_on_a.next_of("ack");
  const json seen = viewer_on_b.next_of("version", Millis(5000));
  EXPECT_EQ(seen["version"], 2);
  EXPECT_EQ(seen["hash"], ack["hash"]);
  EXPECT_EQ(seen["author"], "alice");
  EXPECT_EQ(seen["changed"]["everything"], false);
  // And back: a PUT through B reaches a viewer on A.
  LiveClient viewer_on_a(a_->port(), "shared");
  viewer_on_a.subscribe(false, 2);
  const Response put =
      fetch(b_->port(), "PUT", "/api/v1/scenes/shared", with_token(), two_disc_scene());
  ASSERT_EQ(put.result_int(), 200u) << put.body();
  EXPECT_EQ(viewer_on_a.next_of("version", Millis(5000))["version"], 3);
  EXPECT_EQ(viewer_on_b.next_of("version", Millis(5000))["version"], 3);
}

TEST_F(LiveReplicas, ConcurrentEditsOnTwoReplicasArriveInOneOrderEverywhere) {
  LiveClient observer_a(a_->port(), "shared"), observer_b(b_->port(), "shared");
  observer_a.subscribe(false);
  observer_b.subscribe(false);
  LiveClient author_a(a_->port(), "shared"), author_b(b_->port(), "shared");
  author_a.subscribe(true, std::nullopt, "a");
  author_b.subscribe(true, std::nullopt, "b");
  constexpr int kEdits = 8;
  std::thread ta([&] {
    for (int i = 0; i < kEdits; ++i) author_a.send(append_disc(1, i));
  });
  std::thread tb([&] {
    for (int i = 0; i < kEdits; ++i) author_b.send(append_disc(1, kEdits + i));
  });
  ta.join();
  tb.join();
  for (auto* author : {&author_a, &author_b}) {
    for (int answers = 0; answers < kEdits;) {
      const json m = author->next(Millis(10000));
      if (m["type"] == "ack") ++answers;
      if (m["type"] == "reject") {
        ADD_FAILURE() << m.dump();
        ++answers;
      }
    }
  }
  auto sequence = [](LiveClient& client) {
    std::vector<std::pair<std::int64_t, std::string>> seen;
    while (seen.size() < 2 * kEdits) {
      const json m = client.next_of("version", Millis(10000));
      seen.emplace_back(m["version"], m["hash"]);
    }
    return seen;
  };
  const auto at_a = sequence(observer_a);
  const auto at_b = sequence(observer_b);
  EXPECT_EQ(at_a, at_b);
  for (std::size_t i = 0; i < at_a.size(); ++i) {
    EXPECT_EQ(at_a[i].first, static_cast<std::int64_t>(i) + 2);
  }
  EXPECT_EQ(body_json(get(b_->port(), "/api/v1/scenes/shared"))["root"]["children"].size(),
            2u + 2 * kEdits);
}

TEST_F(LiveReplicas, WithRedisGoneTheStoreSweepStillDelivers) {
  LiveClient viewer_on_b(b_->port(), "shared");
  viewer_on_b.subscribe(false);
  redis_->stop();
  LiveClient author_on_a(a_->port(), "shared");
  author_on_a.subscribe(true);
  author_on_a.send(append_disc(1, 0));
  EXPECT_EQ(author_on_a.next_of("ack")["version"], 2);
  EXPECT_EQ(viewer_on_b.next_of("version", Millis(5000))["version"], 2);
}

}  // namespace
