// Scenes and their versions: list, create, replace, read, history, images, the built-in examples.
#include "server/app.hpp"

#include "app_http.hpp"
#include "app_support.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "server/log.hpp"
#include "terrain/image_io.hpp"
#include "terrain/json_text.hpp"
#include "terrain/tile_products.hpp"

namespace server {

namespace fs = std::filesystem;
using json = nlohmann::json;
using terrain::Error;
using namespace detail;  // NOLINT: the App's own helpers (app_support.hpp, app_http.hpp)

namespace {

std::string slug(std::string_view name) {
  std::string s;
  for (char c : name) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    const bool keep = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
    if (keep) {
      s.push_back(c);
    } else if (!s.empty() && s.back() != '-') {
      s.push_back('-');
    }
    if (s.size() >= 40) break;
  }
  while (!s.empty() && s.back() == '-') s.pop_back();
  return s.empty() ? "scene" : s;
}

// The scene's own image references (paths beside a file, for the built-in examples) become the
// hashes of stored blobs: stored scenes never name files.
void rewrite_images(json& node, const std::map<std::string, std::string>& hashes) {
  if (node.is_object()) {
    if (node.contains("type") && node["type"] == "image" && node.contains("image") &&
        node["image"].is_string()) {
      auto it = hashes.find(node["image"].get<std::string>());
      if (it != hashes.end()) node["image"] = it->second;
    }
    for (auto& [key, value] : node.items()) rewrite_images(value, hashes);
  } else if (node.is_array()) {
    for (json& value : node) rewrite_images(value, hashes);
  }
}

void collect_images(const json& node, std::vector<std::string>& out) {
  if (node.is_object()) {
    if (node.contains("type") && node["type"] == "image" && node.contains("image") &&
        node["image"].is_string()) {
      out.push_back(node["image"].get<std::string>());
    }
    for (const auto& [key, value] : node.items()) collect_images(value, out);
  } else if (node.is_array()) {
    for (const json& value : node) collect_images(value, out);
  }
}

}  // namespace

Response App::list_scenes(const Request& request) {
  StoreResult<std::vector<SceneSummary>> scenes = store_->list_scenes();
  if (!scenes) return store_problem(request, scenes.error());
  json list = json::array();
  for (const SceneSummary& s : *scenes) {
    list.push_back({{"id", s.id},
                    {"name", s.name},
                    {"version", s.head_version},
                    {"hash", s.head_hash},
                    {"url", "/api/v1/scenes/" + s.id}});
  }
  Response r = json_response(request, http::status::ok, {{"scenes", list}});
  r.set(http::field::cache_control, "no-cache");
  return r;
}

Response App::create_scene(const Request& request, const Target& target) {
  if (Response auth = authorize(request); auth.result() != http::status::ok) return auth;
  auto compiled = compile_for_storing(request);
  if (!compiled) return compiled.error();
  const std::shared_ptr<const terrain::Scene> scene = compiled->scene;
  std::string id = target.get("id");
  if (!id.empty() && !valid_id(id)) {
    return problem(request, http::status::bad_request, "Bad scene id",
                   "scene ids are 1 to 64 characters of a-z, 0-9, '-' and '_'", "/id");
  }
  SceneVersion first;
  first.name = scene->name;
  first.hash = scene->hash;
  first.canonical_json = scene->canonical_text();
  first.author = "api";
  StoreResult<SceneVersion> created = StoreError{};
  if (!id.empty()) {
    created = store_->create_scene(id, first);
  } else {
    // A readable id from the name; a number appended while it is taken.
    const std::string base = slug(first.name);
    for (int n = 1; n < 1000; ++n) {
      id = n == 1 ? base : base + "-" + std::to_string(n);
      created = store_->create_scene(id, first);
      if (created || created.error().kind != StoreError::Kind::conflict) break;
    }
  }
  if (!created) {
    if (created.error().kind == StoreError::Kind::conflict) {
      return problem(request, http::status::conflict, "Scene exists", created.error().message,
                     "/id");
    }
    return store_problem(request, created.error());
  }
  compiled->version = *created;
  compiled->version.canonical_json.clear();
  versions_.keep(*compiled);  // its first tile needs no parse
  Response r = json_response(request, http::status::created,
                             {{"id", created->scene_id},
                              {"version", created->version},
                              {"hash", created->hash},
                              {"url", "/api/v1/scenes/" + created->scene_id}});
  r.set(http::field::location, "/api/v1/scenes/" + created->scene_id);
  r.set(http::field::etag, version_etag(*created));
  return r;
}

Response App::put_scene(const Request& request, const std::string& id) {
  if (!valid_id(id)) {
    return problem(request, http::status::bad_request, "Bad scene id",
                   "PUT names a scene id (no @version): 1 to 64 characters of a-z, 0-9, '-', '_'",
                   "/id");
  }
  if (Response auth = authorize(request); auth.result() != http::status::ok) return auth;
  auto compiled = compile_for_storing(request);
  if (!compiled) return compiled.error();
  const std::shared_ptr<const terrain::Scene> scene = compiled->scene;
  // The live channel's lock puts this version among live edits in one order (docs/live.md).
  auto channel = live_.channel(id);
  auto held = channel->lock();
  StoreResult<SceneVersion> head = store_->head(id);
  if (!head) return store_problem(request, head.error());
  std::optional<std::int64_t> expected;
  if (const auto it = request.find(http::field::if_match); it != request.end()) {
    const std::string_view given(it->value().data(), it->value().size());
    if (given != "*" && given != version_etag(*head)) {
      Response r =
          problem(request, http::status::precondition_failed, "Version mismatch",
                  "the scene is at " + version_etag(*head) + ", not " + std::string(given));
      r.set(http::field::etag, version_etag(*head));
      return r;
    }
    expected = head->version;  // the store refuses if another writer got in between
  }
  SceneVersion next;
  next.name = scene->name;
  next.hash = scene->hash;
  next.canonical_json = scene->canonical_text();
  next.author = "api";
  StoreResult<SceneVersion> stored =
      commit_version(request, *channel, id, std::move(next), expected);
  if (!stored) {
    if (stored.error().kind == StoreError::Kind::conflict) {
      return problem(request, http::status::precondition_failed, "Version mismatch",
                     stored.error().message);
    }
    return store_problem(request, stored.error());
  }
  compiled->version = *stored;
  compiled->version.canonical_json.clear();
  versions_.keep(*compiled);
  Response r =
      json_response(request, http::status::ok,
                    {{"id", stored->scene_id},
                     {"version", stored->version},
                     {"hash", stored->hash},
                     {"url", "/api/v1/scenes/" + id + "@" + std::to_string(stored->version)}});
  r.set(http::field::etag, version_etag(*stored));
  return r;
}

Response App::get_scene(const Request& request, const std::string& ref) {
  auto loaded = resolve(request, ref);
  if (!loaded) return loaded.error();
  const std::string etag = version_etag(loaded->version);
  const bool pinned = ref.find('@') != std::string::npos;
  Response r = json_response(request, http::status::ok, loaded->scene->canonical);
  r.set(http::field::cache_control, cache_policy(pinned));
  r.set("X-Scene-Version", std::to_string(loaded->version.version));
  answer_conditionally(request, r, etag);
  return r;
}

Response App::versions(const Request& request, const std::string& id) {
  if (!valid_id(id)) {
    return problem(request, http::status::bad_request, "Bad scene id", "bad scene id", "/id");
  }
  StoreResult<std::vector<SceneVersion>> all = store_->versions(id);
  if (!all) return store_problem(request, all.error());
  json list = json::array();
  for (const SceneVersion& v : *all) {
    list.push_back({{"version", v.version},
                    {"hash", v.hash},
                    {"name", v.name},
                    {"author", v.author},
                    {"created_ms", v.created_ms},
                    {"url", "/api/v1/scenes/" + id + "@" + std::to_string(v.version)}});
  }
  Response r = json_response(request, http::status::ok, {{"id", id}, {"versions", list}});
  r.set(http::field::cache_control, "no-cache");
  return r;
}

Response App::upload_image(const Request& request) {
  if (Response auth = authorize(request); auth.result() != http::status::ok) return auth;
  const std::string& body = request.body();
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(body.data());
  // Format and dimensions are checked by the decoder's limits before any pixel is decoded.
  terrain::Result<terrain::Raster> raster =
      terrain::decode_heightfield(std::span<const std::uint8_t>(bytes, body.size()), "png");
  if (!raster) {
    return problem(request, http::status::bad_request, "Invalid image", raster.error().message,
                   "/image");
  }
  std::string media = "image/png";
  if (body.size() >= 4 && (body.compare(0, 2, "II") == 0 || body.compare(0, 2, "MM") == 0)) {
    media = "image/tiff";
  } else if (body.size() >= 4 && static_cast<unsigned char>(body[0]) == 0x76 &&
             static_cast<unsigned char>(body[1]) == 0x2f) {
    media = "image/x-exr";
  }
  Blob blob{content_hash(body.data(), body.size()), media,
            std::vector<std::uint8_t>(bytes, bytes + body.size())};
  StoreResult<bool> stored = store_->put_blob(blob);
  if (!stored) return store_problem(request, stored.error());
  return json_response(request, http::status::created,
                       {{"hash", blob.hash},
                        {"media_type", media},
                        {"width", raster->width},
                        {"height", raster->height}});
}

terrain::Status App::seed_examples() {
  StoreResult<bool> empty = store_->empty();
  if (!empty) return Error{empty.error().message, ""};
  if (!*empty) return seed_planets();
  std::error_code ec;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(config_.scenes_dir, ec)) {
    if (entry.path().extension() == ".json") files.push_back(entry.path());
  }
  if (ec) return Error{"cannot read " + config_.scenes_dir + ": " + ec.message(), ""};
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    std::ifstream in(file);
    json document = json::parse(in, nullptr, false);  // a built-in file
    if (document.is_discarded()) return Error{file.string() + ": not JSON", ""};
    std::vector<std::string> images;
    collect_images(document, images);
    std::map<std::string, std::string> hashes;
    for (const std::string& image : images) {
      const fs::path path = file.parent_path() / image;
      std::ifstream img(path, std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(img)),
                              std::istreambuf_iterator<char>());
      if (!img && bytes.empty()) return Error{"cannot read " + path.string(), ""};
      Blob blob{content_hash(bytes.data(), bytes.size()), "image/png",
                std::vector<std::uint8_t>(bytes.begin(), bytes.end())};
      if (StoreResult<bool> s = store_->put_blob(blob); !s) return Error{s.error().message, ""};
      hashes[image] = blob.hash;
    }
    rewrite_images(document, hashes);
    // Checked and canonicalised: the first load of the version bakes its grids, off the I/O
    // threads, as any stored version's.
    auto scene = parse_stored(document.dump(), SceneSource::unbaked);
    if (!scene) return Error{file.string() + ": " + scene.error().message, scene.error().pointer};
    SceneVersion first;
    first.name = (*scene)->name;
    first.hash = (*scene)->hash;
    first.canonical_json = (*scene)->canonical_text();
    first.author = "built-in";
    StoreResult<SceneVersion> created = store_->create_scene(file.stem().string(), first);
    // A conflict means another replica sharing the store (PostgreSQL) seeded it meanwhile.
    if (!created && created.error().kind != StoreError::Kind::conflict) {
      return Error{created.error().message, ""};
    }
  }
  return seed_planets();
}

}  // namespace server
