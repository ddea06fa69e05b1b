// Prometheus metrics: requests by route and status, latency histograms, generation time, queue
// depth, cache counters.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "server/thread_shards.hpp"

namespace server {

class ProductCache;

/// Writes one unlabelled sample with its HELP and TYPE lines (the text exposition format).
void append_sample(std::ostream& out, std::string_view name, std::string_view type,
                   std::string_view help, std::int64_t value);

class Metrics {
 public:
  static constexpr std::array<double, 12> kBuckets = {0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025,
                                                      0.05,   0.1,   0.25,   0.5,   1.0,  5.0};

  void request(std::string_view route, int status, double seconds);
  void generation(std::string_view product, double seconds, std::string_view backend);

  std::atomic<int> queued{0};    ///< requests waiting for or running on the generation pool
  std::atomic<int> rejected{0};  ///< requests refused because the queue was full
  std::atomic<std::int64_t> abandoned{0};  ///< deferred work whose client left before the answer
  std::atomic<std::int64_t> refused_connections{0};  ///< closed at once: at the connection cap
  std::atomic<std::int64_t> accept_backoffs{0};      ///< accept waits for lack of descriptors
  /// Tiles of a new version answered with the previous version's bytes (provably the same).
  std::atomic<std::int64_t> reused_across_versions{0};
  std::atomic<int> live_connections{0};             ///< open live WebSockets
  std::atomic<std::int64_t> live_backlog_bytes{0};  ///< queued for live connections, not yet sent
  std::atomic<std::int64_t> live_oversize{0};       ///< closed with 1009, or cut for wire bytes
  std::atomic<std::int64_t> live_slow_readers{0};   ///< live connections cut for their backlog

  /// The text exposition format.
  std::string prometheus(const ProductCache& cache) const;

 private:
  struct Histogram {
    std::array<std::int64_t, kBuckets.size()> counts{};
    std::int64_t count = 0;
    double sum = 0.0;
    void add(double v);
  };
  // Every request is counted, so each thread counts in a shard of its own: I/O threads never
  // wait for one another's lock or share its cache line. A scrape adds the shards up. Route
  // labels are few, so short vectors do.
  struct RequestShard {
    struct Count {
      std::string route;
      int status = 0;
      std::int64_t n = 0;
    };
    struct Latency {
      std::string route;
      Histogram histogram;
    };
    std::mutex mutex;  // taken by its thread and by a scrape, so hardly ever contended
    std::vector<Count> counts;
    std::vector<Latency> latency;
  };
  ThreadShards<RequestShard> request_shards_;
  mutable std::mutex mutex_;  // guards generation_
  std::map<std::pair<std::string, std::string>, Histogram> generation_;
};

}  // namespace server
