// One instance of a value per thread that uses it, owned by the object that holds the shards: for
// state that every request touches (metric counters, memos), so that I/O threads never share a
// lock or a cache line on the hot path.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace server {

template <class T>
class ThreadShards {
 public:
  ThreadShards() = default;
  ThreadShards(const ThreadShards&) = delete;
  ThreadShards& operator=(const ThreadShards&) = delete;

  /// This thread's shard, made on its first use. Only this thread gets it from local(); others
  /// see it through for_each(), so T guards whatever they share.
  T& local() {
    // A thread remembers the last shard it used. Owners are told apart by an id that is never
    // reused, not by address: a new owner may live where a destroyed one did.
    thread_local Last last;
    if (last.owner == id_) return *last.shard;
    T* shard = find_or_make();
    last = {id_, shard};
    return *shard;
  }

  /// Calls f on every shard made so far (while no new shard can be made).
  template <class F>
  void for_each(F&& f) const {
    std::lock_guard lock(mutex_);
    for (const auto& [thread, shard] : shards_) f(*shard);
  }

 private:
  struct Last {
    std::uint64_t owner = 0;
    T* shard = nullptr;
  };
  static std::uint64_t next_id() {
    static std::atomic<std::uint64_t> counter{0};
    return ++counter;
  }
  T* find_or_make() {
    const std::thread::id self = std::this_thread::get_id();
    std::lock_guard lock(mutex_);
    for (auto& [thread, shard] : shards_) {
      if (thread == self) return shard.get();
    }
    shards_.emplace_back(self, std::make_unique<T>());
    return shards_.back().second.get();
  }

  const std::uint64_t id_ = next_id();
  mutable std::mutex mutex_;
  // A thread's shard outlives the thread (its counts still count); the owner frees them all.
  std::vector<std::pair<std::thread::id, std::unique_ptr<T>>> shards_;
};

}  // namespace server
