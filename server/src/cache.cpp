#include "server/cache.hpp"

namespace server {

std::shared_ptr<const CachedProduct> ProductCache::find(const std::string& key) {
  std::lock_guard lock(mutex_);
  auto it = index_.find(key);
  if (it == index_.end()) {
    ++misses_;
    return nullptr;
  }
  ++hits_;
  order_.splice(order_.begin(), order_, it->second);
  return it->second->product;
}

std::shared_ptr<const CachedProduct> ProductCache::find_hit(const std::string& key) {
  std::lock_guard lock(mutex_);
  auto it = index_.find(key);
  if (it == index_.end()) return nullptr;
  ++hits_;
  order_.splice(order_.begin(), order_, it->second);
  return it->second->product;
}

void ProductCache::insert(const std::string& key, std::shared_ptr<const CachedProduct> product) {
  // A sealed file holds a second copy of the body: it counts against the budget too.
  const std::size_t body = product->body.size() * (product->file ? 2 : 1);
  const auto size = static_cast<std::int64_t>(body + key.size() + 256);
  std::lock_guard lock(mutex_);
  if (auto it = index_.find(key); it != index_.end()) {
    bytes_ -= it->second->size;
    order_.erase(it->second);
    index_.erase(it);
  }
  if (size > budget_) return;
  order_.push_front({key, std::move(product), size});
  index_[key] = order_.begin();
  bytes_ += size;
  while (bytes_ > budget_ && !order_.empty()) {
    bytes_ -= order_.back().size;
    index_.erase(order_.back().key);
    order_.pop_back();
    ++evictions_;
  }
}

std::int64_t ProductCache::bytes() const {
  std::lock_guard lock(mutex_);
  return bytes_;
}
std::int64_t ProductCache::entries() const {
  std::lock_guard lock(mutex_);
  return static_cast<std::int64_t>(index_.size());
}
std::int64_t ProductCache::hits() const {
  std::lock_guard lock(mutex_);
  return hits_;
}
std::int64_t ProductCache::misses() const {
  std::lock_guard lock(mutex_);
  return misses_;
}
std::int64_t ProductCache::evictions() const {
  std::lock_guard lock(mutex_);
  return evictions_;
}

}  // namespace server
