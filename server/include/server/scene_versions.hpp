// Scene refs resolved to compiled versions: what every scene route does first. Kept apart from
// the HTTP layer, which only turns a failure into a problem response.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "server/store.hpp"
#include "terrain/result.hpp"
#include "terrain/scene.hpp"
#include "terrain/tile_source.hpp"

namespace server {

/// A stored scene version, parsed and compiled once and shared by every thread.
struct LoadedVersion {
  SceneVersion version;
  std::shared_ptr<const terrain::TileSource> source;
  std::shared_ptr<const terrain::Scene> scene;
};

/// Resolves refs — "id" (the head), "id@7" and "id@sha256:…" (pinned) — to compiled versions,
/// through two bounded memos: compiled versions by content hash, and resolved refs. A pinned ref
/// names an immutable version, so once resolved it never asks the store again; a head ref is
/// remembered for a second (its responses say max-age=5 anyway), or until forget_head. Re-spellings
/// ("id@07") share one entry. Thread-safe.
class SceneVersions {
 public:
  /// Parses and compiles a stored version's canonical text; the version is left for the caller.
  using Compile =
      std::function<terrain::Result<LoadedVersion, terrain::Error>(const std::string& text)>;

  /// Why a ref did not resolve.
  struct Failure {
    enum class Kind {
      bad_id,       ///< not 1 to 64 characters of a-z, 0-9, '-' and '_'
      bad_version,  ///< neither a number from 1 nor "sha256:" and 64 lower-case hex digits
      store,        ///< the store's answer (not found, unavailable): `store`
      compile,      ///< the stored text no longer compiles (a limit lowered since): `compile`
    };
    Kind kind = Kind::store;
    StoreError store;
    terrain::Error compile;
  };

  SceneVersions(Store& store, Compile compile);

  terrain::Result<LoadedVersion, Failure> resolve(const std::string& ref);
  /// A version read from the store, compiled (or found compiled).
  terrain::Result<LoadedVersion, Failure> load(const SceneVersion& version);
  /// True when `ref` resolves without work: remembered, still fresh, and its version compiled.
  bool is_loaded(const std::string& ref) const;
  /// Keeps a compiled version (a write's, so that its first tile needs no parse).
  void keep(const LoadedVersion& loaded);
  /// Forgets what the head ref of `id` resolved to: this server or another wrote a version.
  void forget_head(const std::string& id);

 private:
  using Clock = std::chrono::steady_clock;

  Store& store_;
  Compile compile_;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, LoadedVersion> loaded_;  ///< by version hash (bounded)
  /// Refs by their canonical spelling, with when they were resolved (head refs expire).
  std::unordered_map<std::string, std::pair<LoadedVersion, Clock::time_point>> resolved_;
};

}  // namespace server
