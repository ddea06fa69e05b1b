#include "server/redis_cache.hpp"

#include <hiredis/hiredis.h>

#include <charconv>
#include <cstring>

#include "server/log.hpp"

namespace server {
namespace {

constexpr std::string_view kMagic = "terrain-product/1\n";

void put_field(std::string& out, std::string_view field) {
  const auto size = static_cast<std::uint32_t>(field.size());
  for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((size >> shift) & 0xffu);
  out += field;
}

bool get_field(std::string_view& in, std::string& field) {
  if (in.size() < 4) return false;
  std::uint32_t size = 0;
  for (int i = 0; i < 4; ++i)
    size = (size << 8) | static_cast<unsigned char>(in[static_cast<std::size_t>(i)]);
  in.remove_prefix(4);
  if (in.size() < size) return false;
  field.assign(in.substr(0, size));
  in.remove_prefix(size);
  return true;
}

timeval to_timeval(int ms) {
  timeval tv{};
  tv.tv_sec = ms / 1000;
  tv.tv_usec = static_cast<decltype(tv.tv_usec)>((ms % 1000) * 1000);
  return tv;
}

}  // namespace

struct RedisCache::Connection {
  redisContext* context = nullptr;
  ~Connection() {
    if (context != nullptr) redisFree(context);
  }
};

std::string encode_product(const CachedProduct& product) {
  std::string out(kMagic);
  for (std::string_view field :
       {std::string_view(product.media_type), std::string_view(product.content_encoding),
        std::string_view(product.etag), std::string_view(product.backend),
        std::string_view(product.body)}) {
    put_field(out, field);
  }
  return out;
}

std::shared_ptr<CachedProduct> decode_product(const std::string& bytes) {
  std::string_view in(bytes);
  if (!in.starts_with(kMagic)) return nullptr;
  in.remove_prefix(kMagic.size());
  auto product = std::make_shared<CachedProduct>();
  for (std::string* field : {&product->media_type, &product->content_encoding, &product->etag,
                             &product->backend, &product->body}) {
    if (!get_field(in, *field)) return nullptr;
  }
  if (!in.empty()) return nullptr;
  product->file = SealedFile::create(product->body);
  return product;
}

bool RedisCache::parse_url(const std::string& url, Options& options) {
  std::string_view rest(url);
  if (rest.starts_with("redis://")) rest.remove_prefix(8);
  if (const auto slash = rest.find('/'); slash != std::string_view::npos) {
    rest = rest.substr(0, slash);
  }
  if (rest.empty()) return false;
  const auto colon = rest.rfind(':');
  options.host = std::string(rest.substr(0, colon));
  options.port = 6379;
  if (colon != std::string_view::npos) {
    const std::string_view port = rest.substr(colon + 1);
    int value = 0;
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
    if (ec != std::errc() || end != port.data() + port.size() || value < 1 || value > 65535) {
      return false;
    }
    options.port = value;
  }
  return !options.host.empty();
}

RedisCache::RedisCache(Options options) : options_(std::move(options)) {}
RedisCache::~RedisCache() = default;

std::unique_ptr<RedisCache::Connection> RedisCache::take() {
  {
    std::lock_guard lock(mutex_);
    if (std::chrono::steady_clock::now() < retry_after_) return nullptr;
    if (!idle_.empty()) {
      auto connection = std::move(idle_.back());
      idle_.pop_back();
      return connection;
    }
  }
  auto connection = std::make_unique<Connection>();
  connection->context = redisConnectWithTimeout(options_.host.c_str(), options_.port,
                                                to_timeval(options_.timeout_ms));
  if (connection->context == nullptr || connection->context->err != 0) {
    failed();
    return nullptr;
  }
  redisSetTimeout(connection->context, to_timeval(options_.timeout_ms));
  return connection;
}

void RedisCache::give_back(std::unique_ptr<Connection> connection) {
  up_ = true;
  std::lock_guard lock(mutex_);
  if (idle_.size() < 16) idle_.push_back(std::move(connection));
}

void RedisCache::failed() {
  errors_.fetch_add(1);
  if (up_.exchange(false)) {
    log(LogLevel::warn, "redis unavailable: generating instead",
        {{"host", options_.host}, {"port", options_.port}});
  }
  std::lock_guard lock(mutex_);
  idle_.clear();  // their streams may hold half an answer
  retry_after_ = std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.retry_ms);
}

std::shared_ptr<const CachedProduct> RedisCache::find(const std::string& key) {
  auto connection = take();
  if (!connection) return nullptr;
  const std::string name = options_.prefix + key;
  auto* reply = static_cast<redisReply*>(
      redisCommand(connection->context, "GET %b", name.data(), name.size()));
  if (reply == nullptr) {
    failed();
    return nullptr;
  }
  std::shared_ptr<CachedProduct> product;
  if (reply->type == REDIS_REPLY_STRING) {
    product = decode_product(std::string(reply->str, reply->len));
    if (!product) errors_.fetch_add(1);  // not ours, or torn: a miss
  }
  const bool error = reply->type == REDIS_REPLY_ERROR;
  freeReplyObject(reply);
  if (error) {
    failed();
    return nullptr;
  }
  give_back(std::move(connection));
  (product ? hits_ : misses_).fetch_add(1);
  return product;
}

void RedisCache::insert(const std::string& key, const CachedProduct& product) {
  if (static_cast<std::int64_t>(product.body.size()) > options_.max_entry_bytes) return;
  auto connection = take();
  if (!connection) return;
  const std::string name = options_.prefix + key;
  const std::string value = encode_product(product);
  auto* reply = static_cast<redisReply*>(redisCommand(connection->context, "SET %b %b EX %d",
                                                      name.data(), name.size(), value.data(),
                                                      value.size(), options_.ttl_seconds));
  if (reply == nullptr) {
    failed();
    return;
  }
  const bool error = reply->type == REDIS_REPLY_ERROR;
  freeReplyObject(reply);
  if (error) {
    failed();
    return;
  }
  give_back(std::move(connection));
}

}  // namespace server
