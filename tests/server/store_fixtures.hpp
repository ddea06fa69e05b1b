// What the store tests (SQLite and PostgreSQL alike) write: a scene version with a given body.
#pragma once

#include <string>

#include "server/store.hpp"

namespace server::store_fixtures {

/// A version named "n" by "test" whose canonical JSON is `json`, hashed as the server hashes.
inline SceneVersion body(const std::string& json) {
  SceneVersion v;
  v.name = "n";
  v.canonical_json = json;
  v.hash = content_hash(json.data(), json.size());
  v.author = "test";
  return v;
}

}  // namespace server::store_fixtures
