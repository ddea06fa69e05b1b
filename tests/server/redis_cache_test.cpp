// The shared product cache in Redis: the record format, and against a real redis-server on
// loopback (started by the test, like the servers): two replicas share products byte for byte,
// and a Redis that goes away makes the server generate instead, saying so in /metrics.
#include <gtest/gtest.h>

#include <thread>

#include "redis_harness.hpp"
#include "server/redis_cache.hpp"

namespace {

using namespace http_test;
using server::CachedProduct;
using server::RedisCache;

TEST(RedisRecord, RoundTripsEveryField) {
  CachedProduct product;
  product.body = std::string("\x89PNG\0\x01", 6) + std::string(70000, 'x');
  product.media_type = "image/png";
  product.content_encoding = "gzip";
  product.etag = "\"abc\"";
  product.backend = "cpu";
  const auto back = server::decode_product(server::encode_product(product));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->body, product.body);
  EXPECT_EQ(back->media_type, product.media_type);
  EXPECT_EQ(back->content_encoding, product.content_encoding);
  EXPECT_EQ(back->etag, product.etag);
  EXPECT_EQ(back->backend, product.backend);
  EXPECT_TRUE(back->file);  // ready for sendfile like any cached body of 16 kB or more
}

TEST(RedisRecord, ForeignOrTornBytesAreNotAProduct) {
  CachedProduct product;
  product.body = "body";
  const std::string record = server::encode_product(product);
  EXPECT_FALSE(server::decode_product("hello"));
  EXPECT_FALSE(server::decode_product(record.substr(0, record.size() - 1)));
  EXPECT_FALSE(server::decode_product(record + "x"));
}

TEST(RedisUrl, ParsesHostAndPort) {
  RedisCache::Options o;
  ASSERT_TRUE(RedisCache::parse_url("redis://cache.internal:6380", o));
  EXPECT_EQ(o.host, "cache.internal");
  EXPECT_EQ(o.port, 6380);
  ASSERT_TRUE(RedisCache::parse_url("127.0.0.1", o));
  EXPECT_EQ(o.port, 6379);
  EXPECT_FALSE(RedisCache::parse_url("redis://", o));
  EXPECT_FALSE(RedisCache::parse_url("host:99999", o));
  EXPECT_FALSE(RedisCache::parse_url("host:port", o));
}

TEST(RedisUrl, AMalformedUrlStopsTheServerNamingTheOption) {
  TempDir dir("redis-bad-url");
  EXPECT_THROW(ServerProcess(dir.path() / "data", {"--redis-url", "redis://:x"}),
               std::runtime_error);
}

class SharedCache : public ::testing::Test {
 protected:
  void SetUp() override {
    redis_ = std::make_unique<RedisProcess>(free_port());
    for (auto* replica : {&a_, &b_}) {
      dirs_.push_back(std::make_unique<TempDir>("redis-replica"));
      *replica = std::make_unique<ServerProcess>(
          dirs_.back()->path() / "data", std::vector<std::string>{"--redis-url", redis_->url()});
    }
  }
  void TearDown() override {
    a_.reset();
    b_.reset();
    redis_.reset();
  }

  std::unique_ptr<RedisProcess> redis_;
  std::vector<std::unique_ptr<TempDir>> dirs_;
  std::unique_ptr<ServerProcess> a_, b_;
};

TEST_F(SharedCache, AProductMadeByOneReplicaIsServedByAnotherFromRedis) {
  const std::string tile = "/api/v1/scenes/hills-river@1/tiles/3/2/5.png?scheme=local";
  const Response made = get(a_->port(), tile);
  ASSERT_EQ(made.result_int(), 200u) << made.body();
  EXPECT_EQ(metric(a_->port(), "terrain_redis_misses_total"), 1);
  const Response shared = get(b_->port(), tile);
  ASSERT_EQ(shared.result_int(), 200u);
  EXPECT_EQ(shared.body(), made.body());
  EXPECT_EQ(header(shared, http::field::etag), header(made, http::field::etag));
  EXPECT_EQ(header(shared, http::field::content_type), header(made, http::field::content_type));
  EXPECT_EQ(metric(b_->port(), "terrain_redis_hits_total"), 1);
  EXPECT_EQ(metric(b_->port(), "terrain_redis_up"), 1);
  // Planet tiles go through it too.
  const std::string planet = "/api/v1/planets/default/tiles/2/3/1.png";
  const Response planet_made = get(a_->port(), planet);
  ASSERT_EQ(planet_made.result_int(), 200u);
  EXPECT_EQ(get(b_->port(), planet).body(), planet_made.body());
  EXPECT_EQ(metric(b_->port(), "terrain_redis_hits_total"), 2);
}

TEST_F(SharedCache, WithRedisDownTheServerGeneratesAndSaysSo) {
  redis_->stop();
  const Response r = get(a_->port(), "/api/v1/scenes/hills-river@1/tiles/2/1/1.png?scheme=local");
  EXPECT_EQ(r.result_int(), 200u) << r.body();
  EXPECT_EQ(metric(a_->port(), "terrain_redis_up"), 0);
  EXPECT_GE(metric(a_->port(), "terrain_redis_errors_total"), 1);
  // Further requests do not wait on Redis while it is away.
  const auto start = Clock::now();
  for (int x = 0; x < 4; ++x) {
    const Response again = get(a_->port(), "/api/v1/scenes/hills-river@1/tiles/2/" +
                                               std::to_string(x) + "/2.png?scheme=local");
    EXPECT_EQ(again.result_int(), 200u);
  }
  EXPECT_LT(Clock::now() - start, Millis(5000));
  // Back: after the retry pause the cache is used again.
  redis_->start();
  std::this_thread::sleep_for(Millis(2100));
  get(a_->port(), "/api/v1/scenes/hills-river@1/tiles/2/3/3.png?scheme=local");
  EXPECT_EQ(metric(a_->port(), "terrain_redis_up"), 1);
}

}  // namespace
