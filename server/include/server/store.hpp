// Durable storage of scenes, their immutable versions, uploaded images and planet definitions. The
// interface is what the HTTP layer needs; SQLite (embedded default, sqlite_store.cpp) and
// PostgreSQL (shared by replicas, postgres_store.hpp) implement it with the same semantics, and
// open_store picks one by configuration.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "terrain/result.hpp"

namespace server {

struct Config;

/// Why a store operation failed.
struct StoreError {
  enum class Kind {
    not_found,    ///< no such scene, version or blob
    conflict,     ///< the head moved since the caller looked (If-Match), or the id is taken
    unavailable,  ///< the storage engine failed (disk, locks, corruption): retry later
  };
  Kind kind = Kind::unavailable;
  std::string message;
};

template <class T>
using StoreResult = terrain::Result<T, StoreError>;

/// One immutable version of a scene.
struct SceneVersion {
  std::string scene_id;
  std::int64_t version = 0;  ///< 1, 2, 3, … per scene
  std::string hash;          ///< "sha256:…" of the canonical JSON
  std::string name;
  std::string canonical_json;
  std::string author;
  std::int64_t created_ms = 0;  ///< Unix time in milliseconds
  /// The JSON Patch a live edit applied to make this version (docs/live.md); empty when the
  /// version came whole (POST, PUT).
  std::string ops_json;
};

/// A scene and its head version, without the body.
struct SceneSummary {
  std::string id;
  std::string name;
  std::int64_t head_version = 0;
  std::string head_hash;
};

/// A stored image, referenced by its content hash from scenes.
struct Blob {
  std::string hash;  ///< "sha256:…" of the bytes
  std::string media_type;
  std::vector<std::uint8_t> bytes;
};

/// A stored planet definition. Its id is the SHA-256 of its canonical JSON (planet_id), so a
/// definition is stored once however often it is posted.
struct StoredPlanet {
  std::string id;               ///< 64 lowercase hex characters
  std::string canonical_json;   ///< planet::canonical_text of the definition
  std::int64_t created_ms = 0;  ///< Unix time in milliseconds of the first store
};

/// What put_planet did: stored the planet, or found it stored already (then `planet` is the
/// stored one, with its original creation time).
struct PlanetPut {
  StoredPlanet planet;
  bool created = false;
};

/// Thread-safe: every method may be called from any thread.
class Store {
 public:
  virtual ~Store() = default;

  virtual StoreResult<std::vector<SceneSummary>> list_scenes() = 0;
  /// Creates a scene with its first version. `id` must be new (else conflict).
  virtual StoreResult<SceneVersion> create_scene(const std::string& id,
                                                 const SceneVersion& first) = 0;
  /// Appends a version in one transaction. When `expected_head` is set and the head is another
  /// version, nothing is written and the error is a conflict.
  virtual StoreResult<SceneVersion> add_version(const std::string& id, const SceneVersion& next,
                                                std::optional<std::int64_t> expected_head) = 0;
  virtual StoreResult<SceneVersion> head(const std::string& id) = 0;
  virtual StoreResult<SceneVersion> version(const std::string& id, std::int64_t number) = 0;
  /// The version of a scene with this content hash (the latest such, when a scene went back).
  virtual StoreResult<SceneVersion> version_by_hash(const std::string& id,
                                                    const std::string& hash) = 0;
  /// Every version's metadata (bodies left empty), oldest first.
  virtual StoreResult<std::vector<SceneVersion>> versions(const std::string& id) = 0;
  /// Whole versions (bodies and ops) numbered above `after`, oldest first, at most `limit`.
  virtual StoreResult<std::vector<SceneVersion>> versions_after(const std::string& id,
                                                                std::int64_t after,
                                                                std::int64_t limit) = 0;
  /// Stores a blob under its hash (idempotent).
  virtual StoreResult<bool> put_blob(const Blob& blob) = 0;
  virtual StoreResult<Blob> blob(const std::string& hash) = 0;
  /// Stores a planet under its id; idempotent. The same id with another body is a conflict
  /// (the id is a content hash, so that means a caller bug or corruption) and writes nothing.
  virtual StoreResult<PlanetPut> put_planet(const StoredPlanet& planet) = 0;
  virtual StoreResult<StoredPlanet> get_planet(const std::string& id) = 0;
  /// Every stored planet, oldest first (ties by id).
  virtual StoreResult<std::vector<StoredPlanet>> list_planets() = 0;
  /// True when no scene has ever been stored (built-in examples are loaded then).
  virtual StoreResult<bool> empty() = 0;

  /// Keeps a baked grid (an erosion's or a drainage's, sealed by the caller) under the content
  /// hash of what made it, so that no replica and no restart computes it again. Idempotent. The
  /// grids kept stay within `max_total_bytes` together: the oldest go first, and a grid larger
  /// than the bound is not kept (false).
  virtual StoreResult<bool> put_baked_grid(const std::string& key,
                                           const std::vector<std::uint8_t>& bytes,
                                           std::int64_t max_total_bytes) = 0;
  virtual StoreResult<std::vector<std::uint8_t>> baked_grid(const std::string& key) = 0;
};

/// Opens (creating when needed) `<data_dir>/terrain.sqlite3` in WAL mode with synchronous=FULL,
/// migrating its schema to the current version.
StoreResult<std::unique_ptr<Store>> open_sqlite_store(const std::string& data_dir);

/// Opens the store the configuration names: SQLite in `store.data_dir`, or PostgreSQL at
/// `store.postgres_url` with up to `store.postgres_pool_size` connections.
StoreResult<std::unique_ptr<Store>> open_store(const Config& config);

/// "sha256:<hex>" of bytes.
std::string content_hash(const void* data, std::size_t size);

}  // namespace server
