#include "server/log.hpp"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>

namespace server {
namespace {

std::atomic<int> threshold{static_cast<int>(LogLevel::info)};

constexpr const char* kNames[] = {"error", "warn", "info", "debug"};

}  // namespace

void set_log_level(std::string_view name) {
  for (int i = 0; i < 4; ++i) {
    if (name == kNames[i]) threshold = i;
  }
}

bool log_enabled(LogLevel level) {
  return static_cast<int>(level) <= threshold.load();
}

void log(LogLevel level, std::string_view event, nlohmann::json fields) {
  if (!log_enabled(level)) return;
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto millis =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char stamp[64];  // room for any year GCC imagines
  std::snprintf(stamp, sizeof stamp, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec,
                static_cast<int>(millis));
  nlohmann::json line{
      {"time", stamp}, {"level", kNames[static_cast<int>(level)]}, {"event", event}};
  for (auto& [key, value] : fields.items()) line[key] = std::move(value);
  // One fputs per line: lines from different threads never interleave.
  const std::string text =
      line.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  std::fputs(text.c_str(), stderr);
}

}  // namespace server
