// Scene versions: parsed (images decoded once per hash) and compiled; refs resolved through
// SceneVersions, its failures as problems; a request body's scene checked as it will be read back
// before it is stored; baked grids shared through the disk cache, Redis and the store.
#include <cstring>
#include <limits>
#include <optional>

#include "app_support.hpp"
#include "server/app.hpp"
#include "server/log.hpp"
#include "terrain/image_io.hpp"
#include "terrain/scene.hpp"

namespace server {

using detail::store_problem;
using terrain::Error;
using terrain::Result;

namespace {

Response version_problem(const Request& request, const SceneVersions::Failure& failure) {
  using Kind = SceneVersions::Failure::Kind;
  switch (failure.kind) {
    case Kind::bad_id:
      return problem(request, http::status::bad_request, "Bad scene id",
                     "scene ids are 1 to 64 characters of a-z, 0-9, '-' and '_'", "/id");
    case Kind::bad_version:
      return problem(request, http::status::bad_request, "Bad version",
                     "a version is a number from 1 or a sha256: hash (64 lower-case hex digits)",
                     "/version");
    case Kind::store:
      return store_problem(request, failure.store);
    case Kind::compile:
      break;
  }
  // Beyond a limit configured since it was stored (erosion work): 422, as its write would be.
  if (failure.compile.kind == terrain::ErrorKind::unsupported) {
    return problem(request, http::status::unprocessable_entity, "Stored scene too costly",
                   failure.compile.message, failure.compile.pointer);
  }
  return problem(request, http::status::internal_server_error, "Stored scene unreadable",
                 failure.compile.message, failure.compile.pointer);
}

/// A baked grid as the shared stores keep it: the SHA-256 (hex) of its bytes, then the bytes.
/// The stores check an entry's framing only; a grid's floats include offsets the evaluators
/// index with, so its content is checked too, and a damaged entry is made again, not used.
std::string sealed_grid(const std::vector<float>& grid) {
  const std::string_view bytes(reinterpret_cast<const char*>(grid.data()),
                               grid.size() * sizeof(float));
  return terrain::sha256_hex(bytes) + std::string(bytes);
}

std::optional<std::vector<float>> unsealed_grid(std::string_view body) {
  constexpr std::size_t kDigest = 64;
  if (body.size() < kDigest || (body.size() - kDigest) % sizeof(float) != 0) return std::nullopt;
  const std::string_view bytes = body.substr(kDigest);
  if (terrain::sha256_hex(bytes) != body.substr(0, kDigest)) return std::nullopt;
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

terrain::Result<LoadedVersion, Response> App::load_version(const Request& request,
                                                           const SceneVersion& version) {
  terrain::Result<LoadedVersion, SceneVersions::Failure> loaded = versions_.load(version);
  if (!loaded) return version_problem(request, loaded.error());
  return std::move(loaded).value();
}

terrain::Result<LoadedVersion, Response> App::resolve(const Request& request,
                                                      const std::string& ref) {
  terrain::Result<LoadedVersion, SceneVersions::Failure> loaded = versions_.resolve(ref);
  if (!loaded) return version_problem(request, loaded.error());
  return std::move(loaded).value();
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
  // Nearest first: the disk cache, Redis, then the store (SQLite or PostgreSQL, which outlives
  // both and is shared by every replica). A grid found further away is copied nearer.
  const bool in_store = config_.store_bake_bytes > 0;
  if (!disk_cache_ && !redis_ && !in_store) return;
  terrain::BakeCache::Shared shared;
  shared.find = [this, in_store](const std::string& key) -> std::optional<std::vector<float>> {
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
    if (in_store) {
      // Unavailable or missing alike: a miss, and the grid is made (and offered back).
      if (StoreResult<std::vector<std::uint8_t>> bytes = store_->baked_grid(key)) {
        const std::string_view body(reinterpret_cast<const char*>(bytes->data()), bytes->size());
        if (auto grid = unsealed_grid(body)) {
          if (disk_cache_ || redis_) {
            CachedProduct sealed;
            sealed.media_type = "application/octet-stream";
            sealed.body = body;
            if (disk_cache_) disk_cache_->insert(name, sealed);
            if (redis_) redis_->insert(name, sealed);
          }
          return grid;
        }
      }
    }
    return std::nullopt;
  };
  shared.insert = [this, in_store](const std::string& key, const std::vector<float>& grid) {
    CachedProduct sealed;
    sealed.body = sealed_grid(grid);
    sealed.media_type = "application/octet-stream";
    if (disk_cache_) disk_cache_->insert("bake/" + key, sealed);
    if (redis_) redis_->insert("bake/" + key, sealed);  // within Redis's entry size only
    if (in_store) {
      const std::vector<std::uint8_t> bytes(sealed.body.begin(), sealed.body.end());
      if (StoreResult<bool> kept = store_->put_baked_grid(key, bytes, config_.store_bake_bytes);
          !kept) {
        log(LogLevel::warn, "baked grid not kept in the store",
            {{"key", key}, {"message", kept.error().message}});
      }
    }
  };
  bake_cache_.share_with(std::move(shared));
}

}  // namespace server
