// Live edits across replicas (docs/live.md, "Several replicas"): each replica publishes the
// version events of the versions it stores on a Redis pub/sub channel per scene and hears the
// others'. Redis only carries news: the store orders versions, and a replica that hears of a
// version with a gap before it (or hears nothing: App's sweep) reads the missing ones there.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "server/redis_cache.hpp"

struct redisContext;

namespace server {

class LiveBus {
 public:
  /// Called on the bus's own thread with a scene id and a version event from another replica
  /// (or this one's echo, which the receiver recognises by its version).
  using Receiver = std::function<void(const std::string& scene, const std::string& event)>;

  /// Connects to Redis at `where` (host, port, timeout) and starts listening; reconnects by
  /// itself when Redis goes away.
  LiveBus(RedisCache::Options where, Receiver receiver);
  ~LiveBus();
  LiveBus(const LiveBus&) = delete;
  LiveBus& operator=(const LiveBus&) = delete;

  /// Best effort: a Redis that is down loses the news, which the others' sweep makes up for.
  void publish(const std::string& scene, const std::string& event);
  /// Whether the listening connection is subscribed now.
  bool listening() const { return listening_.load(); }

 private:
  void listen();

  RedisCache::Options where_;
  Receiver receiver_;
  std::mutex publish_mutex_;
  redisContext* publisher_ = nullptr;  // guarded by publish_mutex_
  std::mutex listener_mutex_;
  redisContext* listener_ = nullptr;  // guarded by listener_mutex_ (closed to stop the thread)
  std::atomic<bool> stopping_{false};
  std::atomic<bool> listening_{false};
  std::thread thread_;
};

}  // namespace server
