// Structured logs: one JSON object per line on stderr (time, level, event and its fields), so
// that journald, Docker or any log shipper can parse them.
#pragma once

#include <string_view>

#include <nlohmann/json.hpp>

namespace server {

enum class LogLevel { error = 0, warn = 1, info = 2, debug = 3 };

/// Sets the threshold from "error", "warn", "info" or "debug" (others leave it unchanged).
void set_log_level(std::string_view name);
bool log_enabled(LogLevel level);
/// Writes {"time": ISO-8601 UTC, "level": ..., "event": ..., fields...} as one line.
void log(LogLevel level, std::string_view event, nlohmann::json fields = nlohmann::json::object());

}  // namespace server
