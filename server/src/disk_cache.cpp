#include "server/disk_cache.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "terrain/scene.hpp"

namespace server {
namespace {

namespace fs = std::filesystem;

// Entry layout: "terrain-cache/1\n" key "\n" media type "\n" content encoding "\n" etag "\n"
// then the body. The key is stored so that a hash collision can never serve the wrong bytes.
constexpr std::string_view kMagic = "terrain-cache/1\n";

std::string name_of(const std::string& key) {
  return terrain::sha256_hex(key).substr(0, 40);
}

}  // namespace

DiskCache::DiskCache(std::string directory, std::int64_t budget_bytes)
    : directory_(std::move(directory)), budget_(budget_bytes) {
  std::error_code ec;
  fs::create_directories(directory_, ec);
  std::vector<std::pair<fs::file_time_type, fs::path>> found;
  for (auto it = fs::directory_iterator(directory_, ec); !ec && it != fs::directory_iterator();
       it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    if (it->path().extension() == ".tmp") {
      fs::remove(it->path(), ec);  // an interrupted write
      continue;
    }
    found.emplace_back(it->last_write_time(ec), it->path());
  }
  std::sort(found.begin(), found.end());
  std::lock_guard lock(mutex_);
  for (const auto& [time, path] : found) {
    const auto size = static_cast<std::int64_t>(fs::file_size(path, ec));
    if (ec) continue;
    const std::string name = path.filename().string();
    order_.push_back(name);
    index_[name] = {std::prev(order_.end()), size};
    bytes_ += size;
  }
  evict_locked();
}

std::string DiskCache::path_of(const std::string& name) const {
  return (fs::path(directory_) / name).string();
}

std::shared_ptr<const CachedProduct> DiskCache::find(const std::string& key) {
  const std::string name = name_of(key);
  {
    std::lock_guard lock(mutex_);
    if (!index_.contains(name)) return nullptr;
  }
  std::ifstream in(path_of(name), std::ios::binary);
  if (!in) return nullptr;
  std::string magic(kMagic.size(), '\0');
  in.read(magic.data(), static_cast<std::streamsize>(magic.size()));
  std::string stored_key;
  auto product = std::make_shared<CachedProduct>();
  if (magic != kMagic || !std::getline(in, stored_key) || stored_key != key ||
      !std::getline(in, product->media_type) || !std::getline(in, product->content_encoding) ||
      !std::getline(in, product->etag)) {
    return nullptr;
  }
  product->body.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  product->file = SealedFile::create(product->body);
  return product;
}

void DiskCache::insert(const std::string& key, const CachedProduct& product) {
  const std::string name = name_of(key);
  static std::atomic<unsigned> counter{0};
  const std::string tmp = path_of(name + "." + std::to_string(counter++) + ".tmp");
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << kMagic << key << '\n'
        << product.media_type << '\n'
        << product.content_encoding << '\n'
        << product.etag << '\n';
    out.write(product.body.data(), static_cast<std::streamsize>(product.body.size()));
    if (!out) {
      std::error_code ec;
      fs::remove(tmp, ec);
      return;  // a full disk only costs regeneration later
    }
  }
  std::error_code ec;
  fs::rename(tmp, path_of(name), ec);
  if (ec) {
    fs::remove(tmp, ec);
    return;
  }
  const auto size = static_cast<std::int64_t>(fs::file_size(path_of(name), ec));
  std::lock_guard lock(mutex_);
  if (auto it = index_.find(name); it != index_.end()) {
    bytes_ -= it->second.second;
    order_.erase(it->second.first);
    index_.erase(it);
  }
  order_.push_back(name);
  index_[name] = {std::prev(order_.end()), size};
  bytes_ += size;
  evict_locked();
}

void DiskCache::evict_locked() {
  while (bytes_ > budget_ && !order_.empty()) {
    const std::string name = order_.front();
    order_.pop_front();
    bytes_ -= index_[name].second;
    index_.erase(name);
    std::error_code ec;
    fs::remove(path_of(name), ec);
  }
}

std::int64_t DiskCache::bytes() const {
  std::lock_guard lock(mutex_);
  return bytes_;
}

}  // namespace server
