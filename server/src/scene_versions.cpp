// Scene refs resolved to compiled versions (scene_versions.hpp).
#include "server/scene_versions.hpp"

#include <optional>

#include "app_support.hpp"

namespace server {

using detail::parse_integer;
using detail::valid_id;

namespace {

constexpr std::size_t kLoadedVersions = 64;  // compiled versions kept
constexpr std::size_t kResolvedRefs = 4096;  // refs remembered

// A ref taken apart, its version in one spelling ("id@7" for "id@07"), so that re-spellings
// share one entry of the memo instead of evicting the others.
struct ParsedRef {
  std::string id;
  std::string key;  ///< the memo's key: "id", "id@7" or "id@sha256:…"
  bool pinned = false;
  std::optional<std::int64_t> number;  ///< pinned by number; else by hash (when pinned)
  std::string hash;                    ///< pinned by hash
};

/// Nullopt when the version is neither a number from 1 nor "sha256:" and 64 lower-case hex
/// digits; the id is not checked here.
std::optional<ParsedRef> parse_ref(const std::string& ref) {
  const std::size_t at = ref.find('@');
  ParsedRef parsed{ref.substr(0, at), ref.substr(0, at), at != std::string::npos, {}, {}};
  if (!parsed.pinned) return parsed;
  const std::string token = ref.substr(at + 1);
  if (token.starts_with("sha256:") && token.size() == 71 &&
      token.find_first_not_of("0123456789abcdef", 7) == std::string::npos) {
    parsed.key += "@" + token;
    parsed.hash = token;
  } else if (auto n = parse_integer<std::int64_t>(token); n && *n >= 1) {
    parsed.number = *n;
    parsed.key += "@" + std::to_string(*n);
  } else {
    return std::nullopt;
  }
  return parsed;
}

// Built field by field: GCC 12 at -O3 warns that brace-initialised Failures' strings "may be used
// uninitialized" (a false positive that -Werror turns into a release build failure).
SceneVersions::Failure failure(SceneVersions::Failure::Kind kind) {
  SceneVersions::Failure f;
  f.kind = kind;
  return f;
}

bool still_fresh(bool pinned, std::chrono::steady_clock::time_point remembered,
                 std::chrono::steady_clock::time_point now) {
  return pinned || now - remembered < std::chrono::seconds(1);
}

}  // namespace

SceneVersions::SceneVersions(Store& store, Compile compile)
    : store_(store), compile_(std::move(compile)) {}

terrain::Result<LoadedVersion, SceneVersions::Failure> SceneVersions::resolve(
    const std::string& ref) {
  if (!valid_id(ref.substr(0, ref.find('@')))) return failure(Failure::Kind::bad_id);
  const std::optional<ParsedRef> parsed = parse_ref(ref);
  if (!parsed) return failure(Failure::Kind::bad_version);
  {
    std::lock_guard lock(mutex_);
    if (auto it = resolved_.find(parsed->key); it != resolved_.end()) {
      if (still_fresh(parsed->pinned, it->second.second, Clock::now())) return it->second.first;
      resolved_.erase(it);
    }
  }
  StoreResult<SceneVersion> version = StoreError{};
  if (!parsed->pinned) {
    version = store_.head(parsed->id);
  } else if (parsed->number) {
    version = store_.version(parsed->id, *parsed->number);
  } else {
    version = store_.version_by_hash(parsed->id, parsed->hash);
  }
  if (!version) {
    Failure refused = failure(Failure::Kind::store);
    refused.store = version.error();
    return refused;
  }
  terrain::Result<LoadedVersion, Failure> loaded = load(*version);
  if (loaded) {
    std::lock_guard lock(mutex_);
    if (resolved_.size() >= kResolvedRefs) resolved_.clear();
    // Stamped when the load ends, not when the request came: a load longer than a head's
    // freshness (a large erosion's bake) would otherwise be stale on arrival, and the request
    // it was made for would find its version "not loaded" again and be refused as busy.
    resolved_[parsed->key] = {*loaded, Clock::now()};
  }
  return loaded;
}

terrain::Result<LoadedVersion, SceneVersions::Failure> SceneVersions::load(
    const SceneVersion& version) {
  {
    std::lock_guard lock(mutex_);
    if (auto it = loaded_.find(version.hash); it != loaded_.end()) {
      LoadedVersion loaded = it->second;
      loaded.version = version;
      loaded.version.canonical_json.clear();  // the parsed scene holds it
      return loaded;
    }
  }
  terrain::Result<LoadedVersion, terrain::Error> compiled = compile_(version.canonical_json);
  if (!compiled) {
    Failure refused = failure(Failure::Kind::compile);
    refused.compile = compiled.error();
    return refused;
  }
  LoadedVersion loaded = std::move(compiled).value();
  loaded.version = version;
  loaded.version.canonical_json.clear();
  keep(loaded);
  return loaded;
}

bool SceneVersions::is_loaded(const std::string& ref) const {
  const std::optional<ParsedRef> parsed = parse_ref(ref);
  if (!parsed) return false;  // resolve() answers it, wherever it runs
  std::lock_guard lock(mutex_);
  const auto it = resolved_.find(parsed->key);
  // A head ref remembered more than a second ago may have moved to a version not loaded yet.
  return it != resolved_.end() && still_fresh(parsed->pinned, it->second.second, Clock::now()) &&
         loaded_.contains(it->second.first.version.hash);
}

void SceneVersions::keep(const LoadedVersion& loaded) {
  std::lock_guard lock(mutex_);
  if (loaded_.size() >= kLoadedVersions) loaded_.clear();
  loaded_.insert_or_assign(loaded.version.hash, loaded);
}

void SceneVersions::forget_head(const std::string& id) {
  std::lock_guard lock(mutex_);
  resolved_.erase(id);
}

}  // namespace server
