// /metrics counts every request once, whichever thread answered it: each thread counts in a
// shard of its own, and the exposition adds them up in label order.
#include <gtest/gtest.h>

#include <string>
#include <thread>
#include <vector>

#include "server/cache.hpp"
#include "server/metrics.hpp"

namespace server {
namespace {

TEST(Metrics, RequestsFromManyThreadsAddUpPerRouteAndStatus) {
  Metrics metrics;
  const ProductCache cache(1 << 20);
  constexpr int kThreads = 4;
  constexpr int kEach = 1000;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&metrics, t] {
      for (int i = 0; i < kEach; ++i) {
        metrics.request("tiles", i % 4 == 0 ? 304 : 200, 0.0002);
        if (t == 0) metrics.request(std::string("health") + "z", 200, 0.002);
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  metrics.request("tiles", 200, 3.0);  // and one from this thread

  const std::string text = metrics.prometheus(cache);
  auto has = [&](const std::string& line) { return text.find(line + "\n") != std::string::npos; };
  EXPECT_TRUE(has("terrain_requests_total{route=\"healthz\",status=\"200\"} 1000")) << text;
  EXPECT_TRUE(has("terrain_requests_total{route=\"tiles\",status=\"200\"} 3001")) << text;
  EXPECT_TRUE(has("terrain_requests_total{route=\"tiles\",status=\"304\"} 1000")) << text;
  EXPECT_TRUE(has("terrain_request_seconds_bucket{route=\"tiles\",le=\"0.0005\"} 4000")) << text;
  EXPECT_TRUE(has("terrain_request_seconds_bucket{route=\"tiles\",le=\"5\"} 4001")) << text;
  EXPECT_TRUE(has("terrain_request_seconds_bucket{route=\"tiles\",le=\"+Inf\"} 4001")) << text;
  EXPECT_TRUE(has("terrain_request_seconds_count{route=\"tiles\"} 4001")) << text;
  EXPECT_TRUE(has("terrain_request_seconds_count{route=\"healthz\"} 1000")) << text;
  // Series in label order, as before: healthz before tiles, 200 before 304.
  EXPECT_LT(text.find("route=\"healthz\",status=\"200\""), text.find("route=\"tiles\""));
  EXPECT_LT(text.find("route=\"tiles\",status=\"200\""),
            text.find("route=\"tiles\",status=\"304\""));
}

TEST(Metrics, EachInstanceCountsItsOwnRequests) {
  const ProductCache cache(1 << 20);
  for (int round = 0; round < 3; ++round) {
    // A new instance may take the place of the last one: it starts from nothing.
    Metrics metrics;
    metrics.request("scene", 200, 0.001);
    const std::string text = metrics.prometheus(cache);
    EXPECT_NE(text.find("terrain_requests_total{route=\"scene\",status=\"200\"} 1\n"),
              std::string::npos)
        << text;
  }
}

}  // namespace
}  // namespace server
