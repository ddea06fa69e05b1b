#include "server/metrics.hpp"

#include <algorithm>
#include <sstream>

#include "server/cache.hpp"

namespace server {

void Metrics::Histogram::add(double v) {
  for (std::size_t i = 0; i < kBuckets.size(); ++i) {
    if (v <= kBuckets[i]) ++counts[i];
  }
  ++count;
  sum += v;
}

void Metrics::request(std::string_view route, int status, double seconds) {
  RequestShard& shard = request_shards_.local();
  std::lock_guard lock(shard.mutex);
  auto count = std::find_if(shard.counts.begin(), shard.counts.end(),
                            [&](const auto& c) { return c.status == status && c.route == route; });
  if (count == shard.counts.end()) {
    count = shard.counts.insert(shard.counts.end(), {std::string(route), status, 0});
  }
  ++count->n;
  auto latency = std::find_if(shard.latency.begin(), shard.latency.end(),
                              [&](const auto& l) { return l.route == route; });
  if (latency == shard.latency.end()) {
    latency = shard.latency.insert(shard.latency.end(), {std::string(route), {}});
  }
  latency->histogram.add(seconds);
}

void Metrics::generation(std::string_view product, double seconds, std::string_view backend) {
  std::lock_guard lock(mutex_);
  generation_[{std::string(product), std::string(backend)}].add(seconds);
}

namespace {

void histogram_lines(std::ostringstream& out, const std::string& name, const std::string& labels,
                     const std::array<std::int64_t, Metrics::kBuckets.size()>& counts,
                     std::int64_t count, double sum) {
  const std::string sep = labels.empty() ? "" : ",";
  for (std::size_t i = 0; i < Metrics::kBuckets.size(); ++i) {
    out << name << "_bucket{" << labels << sep << "le=\"" << Metrics::kBuckets[i] << "\"} "
        << counts[i] << "\n";
  }
  out << name << "_bucket{" << labels << sep << "le=\"+Inf\"} " << count << "\n";
  out << name << "_sum{" << labels << "} " << sum << "\n";
  out << name << "_count{" << labels << "} " << count << "\n";
}

}  // namespace

void append_sample(std::ostream& out, std::string_view name, std::string_view type,
                   std::string_view help, std::int64_t value) {
  out << "# HELP " << name << ' ' << help << "\n# TYPE " << name << ' ' << type << '\n'
      << name << ' ' << value << '\n';
}

std::string Metrics::prometheus(const ProductCache& cache) const {
  // The threads' shards added up, in the order of the series' labels.
  std::map<std::pair<std::string, int>, std::int64_t> requests;
  std::map<std::string, Histogram> latency;
  request_shards_.for_each([&](RequestShard& shard) {
    std::lock_guard lock(shard.mutex);
    for (const auto& c : shard.counts) requests[{c.route, c.status}] += c.n;
    for (const auto& l : shard.latency) {
      Histogram& total = latency[l.route];
      for (std::size_t i = 0; i < kBuckets.size(); ++i) total.counts[i] += l.histogram.counts[i];
      total.count += l.histogram.count;
      total.sum += l.histogram.sum;
    }
  });
  std::ostringstream out;
  std::lock_guard lock(mutex_);
  out << "# HELP terrain_requests_total HTTP requests by route and status.\n"
         "# TYPE terrain_requests_total counter\n";
  for (const auto& [key, n] : requests) {
    out << "terrain_requests_total{route=\"" << key.first << "\",status=\"" << key.second << "\"} "
        << n << "\n";
  }
  out << "# HELP terrain_request_seconds Time from a complete request to its response being ready "
         "to send.\n"
         "# TYPE terrain_request_seconds histogram\n";
  for (const auto& [route, h] : latency) {
    histogram_lines(out, "terrain_request_seconds", "route=\"" + route + "\"", h.counts, h.count,
                    h.sum);
  }
  out << "# HELP terrain_generation_seconds Time to generate and encode one product.\n"
         "# TYPE terrain_generation_seconds histogram\n";
  for (const auto& [key, h] : generation_) {
    histogram_lines(out, "terrain_generation_seconds",
                    "product=\"" + key.first + "\",backend=\"" + key.second + "\"", h.counts,
                    h.count, h.sum);
  }
  append_sample(out, "terrain_generation_queue", "gauge",
                "Requests waiting for or on the generation pool.", queued.load());
  append_sample(out, "terrain_generation_rejected_total", "counter",
                "Requests refused with 503 (queue full).", rejected.load());
  append_sample(out, "terrain_generation_abandoned_total", "counter",
                "Deferred requests whose client left before the answer (skipped if not started; "
                "pictures stop at the next pixel).",
                abandoned.load());
  append_sample(out, "terrain_connections_refused_total", "counter",
                "Connections answered 503 and closed at once: the server was at "
                "server.max_connections.",
                refused_connections.load());
  append_sample(out, "terrain_accept_backoffs_total", "counter",
                "Times the accept loop waited because the process was out of descriptors.",
                accept_backoffs.load());
  append_sample(out, "terrain_cache_reused_across_versions_total", "counter",
                "Tiles of a new version answered with the previous version's bytes, which the "
                "edit provably left unchanged.",
                reused_across_versions.load());
  append_sample(out, "terrain_live_connections", "gauge", "Open live-editing WebSockets.",
                live_connections.load());
  append_sample(out, "terrain_live_backlog_bytes", "gauge",
                "Bytes queued for live connections and not yet written to their sockets.",
                live_backlog_bytes.load());
  append_sample(
      out, "terrain_live_oversize_total", "counter",
      "Live connections closed for an oversize message (1009, or cut for its wire bytes).",
      live_oversize.load());
  append_sample(out, "terrain_live_slow_readers_total", "counter",
                "Live connections cut because they fell too far behind.", live_slow_readers.load());
  out << "# TYPE terrain_cache_hits_total counter\nterrain_cache_hits_total " << cache.hits()
      << "\n# TYPE terrain_cache_misses_total counter\nterrain_cache_misses_total "
      << cache.misses() << "\n# TYPE terrain_cache_evictions_total counter\n"
      << "terrain_cache_evictions_total " << cache.evictions()
      << "\n# TYPE terrain_cache_bytes gauge\nterrain_cache_bytes " << cache.bytes()
      << "\n# TYPE terrain_cache_entries gauge\nterrain_cache_entries " << cache.entries() << "\n";
  return out.str();
}

}  // namespace server
