#include "server/live.hpp"

#include <algorithm>

namespace server {

bool LiveHub::Channel::join(std::shared_ptr<LiveSubscriber> subscriber, int max) {
  std::erase_if(subscribers_, [](const auto& weak) { return weak.expired(); });
  if (subscribers_.size() >= static_cast<std::size_t>(std::max(max, 0))) return false;
  subscribers_.push_back(std::move(subscriber));
  return true;
}

void LiveHub::Channel::leave(const LiveSubscriber* subscriber) {
  std::erase_if(subscribers_, [subscriber](const auto& weak) {
    const auto locked = weak.lock();
    return !locked || locked.get() == subscriber;
  });
}

bool LiveHub::Channel::publish(std::int64_t version, std::shared_ptr<const std::string> event) {
  if (version <= last_) return false;
  last_ = version;
  for (const auto& weak : subscribers_) {
    if (auto subscriber = weak.lock()) subscriber->deliver(event);
  }
  recent_bytes_ += event->size();
  recent_.emplace_back(version, std::move(event));
  while (recent_.size() > kRecentEvents || (recent_bytes_ > kRecentBytes && recent_.size() > 1)) {
    recent_bytes_ -= recent_.front().second->size();
    recent_.pop_front();
  }
  return true;
}

std::shared_ptr<const std::string> LiveHub::Channel::recent(std::int64_t version) const {
  for (const auto& [number, event] : recent_) {
    if (number == version) return event;
  }
  return nullptr;
}

std::shared_ptr<LiveHub::Channel> LiveHub::channel(const std::string& scene) {
  std::lock_guard lock(mutex_);
  auto& slot = channels_[scene];
  if (!slot) slot = std::make_shared<Channel>();
  return slot;
}

std::vector<std::string> LiveHub::followed_scenes() {
  std::vector<std::pair<std::string, std::shared_ptr<Channel>>> all;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, channel] : channels_) all.emplace_back(id, channel);
  }
  std::vector<std::string> out;
  for (const auto& [id, channel] : all) {
    auto held = channel->lock();
    if (channel->size() > 0) out.push_back(id);
  }
  return out;
}

std::size_t LiveHub::subscribers() {
  std::vector<std::shared_ptr<Channel>> all;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, channel] : channels_) all.push_back(channel);
  }
  std::size_t total = 0;
  for (const auto& channel : all) {
    auto held = channel->lock();
    total += channel->size();
  }
  return total;
}

}  // namespace server
