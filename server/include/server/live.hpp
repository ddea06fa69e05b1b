// The fan-out of live editing (docs/live.md): per scene, the connections that follow it and the
// lock that puts every new version and every new subscriber in one order. Transport-free: the
// WebSocket sessions (live_socket.cpp) implement LiveSubscriber.
#pragma once

#include <algorithm>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

namespace server {

/// A connection following a scene.
class LiveSubscriber {
 public:
  virtual ~LiveSubscriber() = default;
  /// Queues a message for the connection, in call order. Called with the scene's channel locked,
  /// from any thread: it must not block (a connection that cannot keep up closes itself).
  virtual void deliver(std::shared_ptr<const std::string> message) = 0;
};

/// Scenes' channels. Thread-safe.
class LiveHub {
 public:
  /// One scene's subscribers and its recent version events.
  class Channel {
   public:
    /// Held while a version of the scene is stored and published, and while a subscriber joins:
    /// so every subscriber gets every version once, in version order, without gaps.
    std::unique_lock<std::mutex> lock() { return std::unique_lock(mutex_); }

    // The members below need the lock held.
    /// Adds a subscriber unless `max` already follow the scene.
    bool join(std::shared_ptr<LiveSubscriber> subscriber, int max);
    void leave(const LiveSubscriber* subscriber);
    /// Delivers a version event to every subscriber and remembers it for catch-up. A version at
    /// or below the last one published is a repeat (another replica's echo, say): ignored,
    /// false. The caller publishes missing versions first (App::publish_version).
    bool publish(std::int64_t version, std::shared_ptr<const std::string> event);
    /// The last version published, or 0 when none was (subscribers joining move it to the head
    /// they were told of).
    std::int64_t last() const { return last_; }
    void advance_to(std::int64_t version) { last_ = std::max(last_, version); }
    /// The remembered event of a version, or null.
    std::shared_ptr<const std::string> recent(std::int64_t version) const;
    std::size_t size() const { return subscribers_.size(); }

   private:
    std::mutex mutex_;
    std::vector<std::weak_ptr<LiveSubscriber>> subscribers_;
    std::deque<std::pair<std::int64_t, std::shared_ptr<const std::string>>> recent_;
    std::size_t recent_bytes_ = 0;
    std::int64_t last_ = 0;
  };

  /// Versions whose events are kept for catch-up without rereading the store: the latest 256,
  /// within 8 MiB (edits may carry large ops).
  static constexpr std::size_t kRecentEvents = 256;
  static constexpr std::size_t kRecentBytes = 8u << 20;

  /// The channel of a scene (created on first use; channels live as long as the hub).
  std::shared_ptr<Channel> channel(const std::string& scene);
  /// Subscribers of every scene together (for /metrics).
  std::size_t subscribers();
  /// The scenes that have subscribers now.
  std::vector<std::string> followed_scenes();

 private:
  std::mutex mutex_;
  std::unordered_map<std::string, std::shared_ptr<Channel>> channels_;
};

}  // namespace server
