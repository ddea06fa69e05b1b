#include "server/live_bus.hpp"

#include <hiredis/hiredis.h>
#include <sys/socket.h>

#include <chrono>

#include "server/log.hpp"

namespace server {
namespace {

constexpr std::string_view kChannelPrefix = "terrain:live:";

timeval to_timeval(int ms) {
  timeval tv{};
  tv.tv_sec = ms / 1000;
  tv.tv_usec = static_cast<decltype(tv.tv_usec)>((ms % 1000) * 1000);
  return tv;
}

redisContext* connect(const RedisCache::Options& where) {
  redisContext* c =
      redisConnectWithTimeout(where.host.c_str(), where.port, to_timeval(where.timeout_ms));
  if (c != nullptr && c->err != 0) {
    redisFree(c);
    return nullptr;
  }
  return c;
}

}  // namespace

LiveBus::LiveBus(RedisCache::Options where, Receiver receiver)
    : where_(std::move(where)), receiver_(std::move(receiver)), thread_([this] { listen(); }) {}

LiveBus::~LiveBus() {
  stopping_ = true;
  {
    // Wakes the listener from its blocking read.
    std::lock_guard lock(listener_mutex_);
    if (listener_ != nullptr) ::shutdown(listener_->fd, SHUT_RDWR);
  }
  thread_.join();
  if (publisher_ != nullptr) redisFree(publisher_);
}

void LiveBus::publish(const std::string& scene, const std::string& event) {
  const std::string channel = std::string(kChannelPrefix) + scene;
  std::lock_guard lock(publish_mutex_);
  if (publisher_ == nullptr) {
    publisher_ = connect(where_);
    if (publisher_ == nullptr) return;
    redisSetTimeout(publisher_, to_timeval(where_.timeout_ms));
  }
  auto* reply = static_cast<redisReply*>(redisCommand(publisher_, "PUBLISH %b %b", channel.data(),
                                                      channel.size(), event.data(), event.size()));
  if (reply == nullptr) {
    redisFree(publisher_);
    publisher_ = nullptr;
    return;
  }
  freeReplyObject(reply);
}

void LiveBus::listen() {
  int wait_ms = 100;
  while (!stopping_) {
    redisContext* c = connect(where_);
    if (c != nullptr) {
      auto* reply = static_cast<redisReply*>(
          redisCommand(c, "PSUBSCRIBE %s*", std::string(kChannelPrefix).c_str()));
      if (reply != nullptr) {
        freeReplyObject(reply);
        {
          std::lock_guard lock(listener_mutex_);
          listener_ = c;
        }
        if (stopping_) ::shutdown(c->fd, SHUT_RDWR);
        listening_ = true;
        wait_ms = 100;
        void* raw = nullptr;
        // Blocks until a message (no timeout: the destructor shuts the socket to end it).
        while (redisGetReply(c, &raw) == REDIS_OK) {
          auto* message = static_cast<redisReply*>(raw);
          if (message->type == REDIS_REPLY_ARRAY && message->elements == 4 &&
              message->element[2]->type == REDIS_REPLY_STRING &&
              message->element[3]->type == REDIS_REPLY_STRING) {
            const std::string channel(message->element[2]->str, message->element[2]->len);
            const std::string event(message->element[3]->str, message->element[3]->len);
            if (channel.starts_with(kChannelPrefix)) {
              receiver_(channel.substr(kChannelPrefix.size()), event);
            }
          }
          freeReplyObject(message);
        }
        listening_ = false;
        std::lock_guard lock(listener_mutex_);
        listener_ = nullptr;
      }
      redisFree(c);
    }
    if (stopping_) break;
    log(LogLevel::warn, "live bus: redis unavailable, retrying",
        {{"host", where_.host}, {"port", where_.port}});
    // Sleep in small steps so that a shutdown is not held up.
    for (int slept = 0; slept < wait_ms && !stopping_; slept += 50) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    wait_ms = std::min(wait_ms * 2, 5000);
  }
}

}  // namespace server
