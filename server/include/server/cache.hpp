// An in-memory LRU of encoded products with a byte budget. Keys name the scene version hash,
// product, address and format, so an entry never goes stale: versions are immutable.
#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include "server/sealed_file.hpp"

namespace server {

/// A cached product: bytes as sent and the headers that describe them.
struct CachedProduct {
  std::string body;
  std::string media_type;
  std::string content_encoding;  ///< "" or "gzip"
  std::string etag;              ///< strong, quoted
  std::string backend;           ///< what evaluated it: "cpu", "gpu: <device>", ...
  /// The body in a sealed in-memory file for zero-copy sends (SealedFile::create); may be null.
  std::shared_ptr<const SealedFile> file;
};

class ProductCache {
 public:
  explicit ProductCache(std::int64_t budget_bytes) : budget_(budget_bytes) {}

  std::shared_ptr<const CachedProduct> find(const std::string& key);
  /// Like find, but a miss is not counted: for a first look whose failure a find follows.
  std::shared_ptr<const CachedProduct> find_hit(const std::string& key);
  /// Inserts (or refreshes) an entry, evicting the least recently used beyond the budget. An
  /// entry larger than the whole budget is not kept.
  void insert(const std::string& key, std::shared_ptr<const CachedProduct> product);

  std::int64_t bytes() const;
  std::int64_t entries() const;
  std::int64_t hits() const;
  std::int64_t misses() const;
  std::int64_t evictions() const;

 private:
  struct Entry {
    std::string key;
    std::shared_ptr<const CachedProduct> product;
    std::int64_t size = 0;
  };
  mutable std::mutex mutex_;
  std::int64_t budget_;
  std::int64_t bytes_ = 0;
  std::int64_t hits_ = 0, misses_ = 0, evictions_ = 0;
  std::list<Entry> order_;  // most recent first
  std::unordered_map<std::string, std::list<Entry>::iterator> index_;
};

}  // namespace server
