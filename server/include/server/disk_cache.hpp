// An optional on-disk product cache behind the in-memory LRU: survives restarts, bounded by a
// byte budget (oldest entries evicted first). File names are hashes of the cache key, so no
// request value becomes a path; files are written to a temporary name and renamed, so a crash
// never leaves a torn entry.
#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "server/cache.hpp"

namespace server {

class DiskCache {
 public:
  /// Uses `directory` (created when missing); indexes what an earlier run left there.
  DiskCache(std::string directory, std::int64_t budget_bytes);

  std::shared_ptr<const CachedProduct> find(const std::string& key);
  void insert(const std::string& key, const CachedProduct& product);

  std::int64_t bytes() const;

 private:
  std::string path_of(const std::string& name) const;
  void evict_locked();

  std::string directory_;
  std::int64_t budget_;
  mutable std::mutex mutex_;
  std::int64_t bytes_ = 0;
  std::list<std::string> order_;  // file names, oldest first
  std::unordered_map<std::string, std::pair<std::list<std::string>::iterator, std::int64_t>> index_;
};

}  // namespace server
