// Scene versions: parsed (images decoded once per hash), compiled, kept in memory, resolved
// from refs; and a request body's scene checked as it will be read back before it is stored.
#include <chrono>
#include <cstring>
#include <limits>
#include <optional>

#include "app_support.hpp"
#include "server/app.hpp"
#include "terrain/image_io.hpp"
#include "terrain/scene.hpp"

namespace server {

using detail::parse_integer;
using detail::store_problem;
using detail::valid_id;
using terrain::Error;
using terrain::Result;

namespace {

constexpr std::size_t kLoadedVersions = 64;  // compiled scene versions kept in memory

// A scene ref taken apart, its version in one spelling ("id@7" for "id@07"), so that re-spellings
// share one entry of the bounded memo of resolved refs instead of evicting the others.
struct ParsedRef {
  std::string id;
  std::string key;  ///< the memo's key: "id", "id@7" or "id@sha256:…"
  bool pinned = false;
  std::optional<std::int64_t> number;  ///< pinned by number; else by hash (when pinned)
};

/// Nullopt when the version is neither a number from 1 nor "sha256:" and 64 lower-case hex
/// digits; the id is not checked here.
std::optional<ParsedRef> parse_ref(const std::string& ref) {
  const std::size_t at = ref.find('@');
  ParsedRef parsed{ref.substr(0, at), ref.substr(0, at), at != std::string::npos, std::nullopt};
  if (!parsed.pinned) return parsed;
  const std::string token = ref.substr(at + 1);
  if (token.starts_with("sha256:") && token.size() == 71 &&
      token.find_first_not_of("0123456789abcdef", 7) == std::string::npos) {
    parsed.key += "@" + token;
  } else if (auto n = parse_integer<std::int64_t>(token); n && *n >= 1) {
    parsed.number = *n;
    parsed.key += "@" + std::to_string(*n);
  } else {
    return std::nullopt;
  }
  return parsed;
}

// Pinned refs name immutable versions: once resolved, never asked of the store again. Head refs
// are remembered for a second (their responses say max-age=5 anyway).
bool still_fresh(bool pinned, std::chrono::steady_clock::time_point remembered,
                 std::chrono::steady_clock::time_point now) {
  return pinned || now - remembered < std::chrono::seconds(1);
}

/// A baked grid as the shared stores keep it: the SHA-256 (hex) of its bytes, then the bytes.
/// The stores check an entry's framing only; a grid's floats include offsets the evaluators
/// index with, so its content is checked too, and a damaged entry is made again, not used.
std::string sealed_grid(const std::vector<float>& grid) {
  const std::string_view bytes(reinterpret_cast<const char*>(grid.data()),
                               grid.size() * sizeof(float));
  return terrain::sha256_hex(bytes) + std::string(bytes);
}

std::optional<std::vector<float>> unsealed_grid(const std::string& body) {
  constexpr std::size_t kDigest = 64;
  if (body.size() < kDigest || (body.size() - kDigest) % sizeof(float) != 0) return std::nullopt;
  const std::string_view bytes = std::string_view(body).substr(kDigest);
  if (terrain::sha256_hex(bytes) != std::string_view(body).substr(0, kDigest)) return std::nullopt;
  std::vector<float> grid(bytes.size() / sizeof(float));
  std::memcpy(grid.data(), bytes.data(), bytes.size());
  return grid;
}

}  // namespace

terrain::Result<std::shared_ptr<const terrain::Scene>, terrain::Error> App::parse_stored(
    const std::string& text, SceneSource source) {
  terrain::ParseOptions options;
  if (source == SceneSource::stored) {
    options.limits.max_name_bytes = std::numeric_limits<std::size_t>::max();
  }
  options.limits.max_erosion_work = config_.erosion_work;
  options.bake = source != SceneSource::unbaked;
  options.bake_cache = &bake_cache_;
  // Every image node packs its own copy of its pixels into the program, so the bound counts
  // each use; decoding is done once per image (decoded_image).
  std::int64_t pixels = 0;
  options.images = [this, &pixels](std::string_view reference) -> terrain::Result<terrain::Raster> {
    if (!reference.starts_with("sha256:")) {
      return Error{"images are referenced by the hash of an uploaded image (POST /api/v1/images)",
                   ""};
    }
    Result<std::shared_ptr<const terrain::Raster>> raster = decoded_image(std::string(reference));
    if (!raster) return raster.error();
    pixels += static_cast<std::int64_t>((*raster)->width) * (*raster)->height;
    if (pixels > config_.scene_image_pixels) {
      return Error{"the scene's image nodes add up to more than " +
                       std::to_string(config_.scene_image_pixels) +
                       " decoded pixels (limits.scene_image_pixels)",
                   ""};
    }
    return **raster;
  };
  terrain::Result<terrain::Scene> scene = terrain::parse_scene_text(text, options);
  if (!scene) return scene.error();
  return std::make_shared<const terrain::Scene>(std::move(scene).value());
}

terrain::Result<std::shared_ptr<const terrain::Raster>> App::decoded_image(
    const std::string& hash) {
  {
    std::lock_guard lock(images_mutex_);
    if (auto it = decoded_.find(hash); it != decoded_.end()) return it->second;
  }
  StoreResult<Blob> blob = store_->blob(hash);
  if (!blob) return Error{blob.error().message, ""};
  Result<terrain::Raster> raster = terrain::decode_heightfield(blob->bytes, blob->media_type);
  if (!raster) return raster.error();
  auto shared = std::make_shared<const terrain::Raster>(std::move(raster).value());
  const std::int64_t size = static_cast<std::int64_t>(shared->width) * shared->height;
  std::lock_guard lock(images_mutex_);
  // Bounded by pixels: twice what one scene may use, forgotten all at once beyond.
  if (decoded_pixels_ + size > 2 * config_.scene_image_pixels) {
    decoded_.clear();
    decoded_pixels_ = 0;
  }
  if (decoded_.emplace(hash, shared).second) decoded_pixels_ += size;
  return shared;
}

terrain::Result<LoadedVersion, terrain::Error> App::compile_scene(const std::string& text,
                                                                  SceneSource from) {
  auto scene = parse_stored(text, from);
  if (!scene) return scene.error();
  // Compiled as every product will compile it: a scene that is stored can always be served.
  terrain::Result<terrain::TileSource> source = terrain::TileSource::from_scene(**scene);
  if (!source) return source.error();
  LoadedVersion loaded;
  loaded.source = std::make_shared<const terrain::TileSource>(std::move(source).value());
  loaded.scene = *scene;
  return loaded;
}

void App::keep_loaded(const LoadedVersion& loaded) {
  std::lock_guard lock(versions_mutex_);
  if (loaded_.size() >= kLoadedVersions) loaded_.clear();
  loaded_.insert_or_assign(loaded.version.hash, loaded);
}

terrain::Result<LoadedVersion, Response> App::load_version(const Request& request,
                                                           const SceneVersion& version) {
  {
    std::lock_guard lock(versions_mutex_);
    auto it = loaded_.find(version.hash);
    if (it != loaded_.end()) {
      LoadedVersion loaded = it->second;
      loaded.version = version;
      loaded.version.canonical_json.clear();  // the parsed scene holds it
      return loaded;
    }
  }
  terrain::Result<LoadedVersion, terrain::Error> compiled =
      compile_scene(version.canonical_json, SceneSource::stored);
  if (!compiled) {
    // Beyond a limit configured since it was stored (erosion work): 422, as its write would be.
    if (compiled.error().kind == terrain::ErrorKind::unsupported) {
      return problem(request, http::status::unprocessable_entity, "Stored scene too costly",
                     compiled.error().message, compiled.error().pointer);
    }
    return problem(request, http::status::internal_server_error, "Stored scene unreadable",
                   compiled.error().message, compiled.error().pointer);
  }
  LoadedVersion loaded = std::move(compiled).value();
  loaded.version = version;
  loaded.version.canonical_json.clear();  // the parsed scene holds it
  keep_loaded(loaded);
  return loaded;
}

terrain::Result<LoadedVersion, Response> App::resolve(const Request& request,
                                                      const std::string& ref) {
  const std::size_t at = ref.find('@');
  const std::string id = ref.substr(0, at);
  if (!valid_id(id)) {
    return problem(request, http::status::bad_request, "Bad scene id",
                   "scene ids are 1 to 64 characters of a-z, 0-9, '-' and '_'", "/id");
  }
  const std::optional<ParsedRef> parsed = parse_ref(ref);
  if (!parsed) {
    return problem(request, http::status::bad_request, "Bad version",
                   "a version is a number from 1 or a sha256: hash (64 lower-case hex digits)",
                   "/version");
  }
  const bool pinned = parsed->pinned;
  const std::string& key = parsed->key;
  // A head ref is also forgotten at once when this server writes a new version (forget_head).
  const auto now = std::chrono::steady_clock::now();
  {
    std::lock_guard lock(versions_mutex_);
    if (auto it = resolved_.find(key); it != resolved_.end()) {
      if (still_fresh(pinned, it->second.second, now)) return it->second.first;
      resolved_.erase(it);
    }
  }
  auto remember = [&](terrain::Result<LoadedVersion, Response> loaded) {
    if (loaded) {
      std::lock_guard lock(versions_mutex_);
      if (resolved_.size() >= 4096) resolved_.clear();
      // Stamped when the load ends, not when the request came: a load longer than a head's
      // freshness (a large erosion's bake) would otherwise be stale on arrival, and the request
      // it was made for would find its version "not loaded" again and be refused as busy.
      resolved_[key] = {*loaded, std::chrono::steady_clock::now()};
    }
    return loaded;
  };
  StoreResult<SceneVersion> version = StoreError{};
  if (!pinned) {
    version = store_->head(id);
  } else if (parsed->number) {
    version = store_->version(id, *parsed->number);
  } else {
    version = store_->version_by_hash(id, ref.substr(ref.find('@') + 1));
  }
  if (!version) return store_problem(request, version.error());
  return remember(load_version(request, *version));
}

bool App::is_loaded(const std::string& ref) {
  const std::optional<ParsedRef> parsed = parse_ref(ref);
  if (!parsed) return false;  // resolve() answers it, wherever it runs
  std::lock_guard lock(versions_mutex_);
  const auto it = resolved_.find(parsed->key);
  // A head ref remembered more than a second ago may have moved to a version not loaded yet.
  return it != resolved_.end() &&
         still_fresh(parsed->pinned, it->second.second, std::chrono::steady_clock::now()) &&
         loaded_.contains(it->second.first.version.hash);
}

void App::forget_head(const std::string& id) {
  std::lock_guard lock(versions_mutex_);
  resolved_.erase(id);
}

terrain::Result<LoadedVersion, Response> App::compile_for_storing(const Request& request) {
  // Validated without baking: the canonical form compiled below is what bakes the grids.
  auto parsed = parse_stored(request.body(), SceneSource::unbaked);
  if (!parsed) {
    // Malformed: 400; well-formed but beyond what this server computes (erosion work): 422.
    const http::status status = parsed.error().kind == terrain::ErrorKind::unsupported
                                    ? http::status::unprocessable_entity
                                    : http::status::bad_request;
    return problem(request, status, "Invalid scene", parsed.error().message,
                   parsed.error().pointer);
  }
  // What is stored is the canonical text, and it is what every later read parses and compiles:
  // check that, so that a stored scene can always be served (limits included).
  auto compiled = compile_scene((*parsed)->canonical_text());
  if (!compiled) {
    return problem(request, http::status::bad_request, "Invalid scene",
                   "the scene in its canonical form: " + compiled.error().message,
                   compiled.error().pointer);
  }
  return std::move(compiled).value();
}

void App::share_baked_grids() {
  if (!disk_cache_ && !redis_) return;
  terrain::BakeCache::Shared shared;
  shared.find = [this](const std::string& key) -> std::optional<std::vector<float>> {
    const std::string name = "bake/" + key;
    if (disk_cache_) {
      if (auto found = disk_cache_->find(name)) {
        if (auto grid = unsealed_grid(found->body)) return grid;
      }
    }
    if (redis_) {
      if (auto found = redis_->find(name)) {
        if (auto grid = unsealed_grid(found->body)) {
          if (disk_cache_) disk_cache_->insert(name, *found);
          return grid;
        }
      }
    }
    return std::nullopt;
  };
  shared.insert = [this](const std::string& key, const std::vector<float>& grid) {
    CachedProduct sealed;
    sealed.body = sealed_grid(grid);
    sealed.media_type = "application/octet-stream";
    if (disk_cache_) disk_cache_->insert("bake/" + key, sealed);
    if (redis_) redis_->insert("bake/" + key, sealed);  // within Redis's entry size only
  };
  bake_cache_.share_with(std::move(shared));
}

}  // namespace server
