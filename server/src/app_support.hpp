// What app.cpp shares with the other files of the App (app_live.cpp).
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "server/app.hpp"

namespace server {

/// A request target split into path segments and decoded query parameters.
struct App::Target {
  std::vector<std::string> segments;
  std::map<std::string, std::string> query;
  std::string get(const std::string& key, const std::string& fallback = "") const {
    auto it = query.find(key);
    return it == query.end() ? fallback : it->second;
  }
};

}  // namespace server

namespace server::detail {

/// Scene ids: 1 to 64 characters of a-z, 0-9, '-' and '_'.
bool valid_id(std::string_view id);

}  // namespace server::detail
