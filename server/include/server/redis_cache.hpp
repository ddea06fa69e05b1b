// A product cache shared by replicas, in Redis (hiredis), behind the in-process LRU: products by
// cache key with a time to live. Redis is an accelerator, never a dependency: every call has a
// short timeout, and after a failure the cache stays away for a while, so a Redis that is down
// costs one timeout and then nothing — the server generates instead and says so in /metrics.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "server/cache.hpp"

struct redisContext;

namespace server {

class RedisCache {
 public:
  struct Options {
    std::string host = "127.0.0.1";
    int port = 6379;
    int timeout_ms = 100;             ///< connect and per-command timeout
    int ttl_seconds = 7 * 24 * 3600;  ///< entries expire (Redis evicts within its maxmemory)
    std::int64_t max_entry_bytes = 8ll << 20;  ///< larger products are not shared
    int retry_ms = 2000;                       ///< after a failure, Redis is left alone this long
    std::string prefix = "terrain:product:";
  };

  /// Parses "redis://host:port" or "host:port" (port 6379 when absent); false when malformed.
  static bool parse_url(const std::string& url, Options& options);

  explicit RedisCache(Options options);
  ~RedisCache();
  RedisCache(const RedisCache&) = delete;
  RedisCache& operator=(const RedisCache&) = delete;

  /// The product stored under `key`, or null (absent, unreadable, or Redis unavailable).
  std::shared_ptr<const CachedProduct> find(const std::string& key);
  /// Stores a product (best effort: failures are counted, never reported).
  void insert(const std::string& key, const CachedProduct& product);

  /// Whether the last exchange with Redis worked.
  bool up() const { return up_.load(); }
  std::int64_t hits() const { return hits_.load(); }
  std::int64_t misses() const { return misses_.load(); }
  std::int64_t errors() const { return errors_.load(); }

 private:
  struct Connection;
  std::unique_ptr<Connection> take();
  void give_back(std::unique_ptr<Connection> connection);
  void failed();

  Options options_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<Connection>> idle_;  // connections ready for a command
  std::chrono::steady_clock::time_point retry_after_{};
  std::atomic<bool> up_{true};
  std::atomic<std::int64_t> hits_{0}, misses_{0}, errors_{0};
};

/// The bytes a product is stored as in Redis (versioned, length-prefixed fields), and back;
/// null when the bytes are not such a record.
std::string encode_product(const CachedProduct& product);
std::shared_ptr<CachedProduct> decode_product(const std::string& bytes);

}  // namespace server
