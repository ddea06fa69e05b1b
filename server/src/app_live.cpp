// Live editing (docs/live.md): the protocol of one connection, edits as JSON Patch with rebasing,
// and version events published in one order per scene.
#include <algorithm>
#include <charconv>
#include <chrono>

#include <nlohmann/json.hpp>

#include "app_support.hpp"
#include "server/app.hpp"
#include "server/log.hpp"
#include "server/scene_edit.hpp"
#include "terrain/json_text.hpp"
#include "terrain/scene_diff.hpp"
#include "terrain/tile_products.hpp"

namespace server {
namespace {

using json = nlohmann::json;

// Catch-up rebuilds at most this many events the channel no longer remembers (each needs both
// versions parsed and compiled); a longer gap comes as one event from `since` to the head.
constexpr std::int64_t kRebuiltEvents = 64;
// Version comparisons kept (each holds both versions' parsed scenes).
constexpr std::size_t kSceneChanges = 64;
// The longest tile list one /changes answer carries (then "truncated": true).
constexpr std::size_t kMaxChangedTiles = 4096;

// A message must never fail to serialise: strings that are not UTF-8 (never expected here, as
// details are escaped below) become U+FFFD rather than an exception.
std::shared_ptr<const std::string> text(const json& message) {
  return std::make_shared<const std::string>(
      message.dump(-1, ' ', false, json::error_handler_t::replace));
}

// Details may quote what the client sent (a parser's message does): bytes that are not UTF-8
// are written as \xHH, as in HTTP problems.
json error_message(int status, std::string_view title, std::string_view detail,
                   std::string_view pointer) {
  json m = {{"type", "error"},
            {"status", status},
            {"title", title},
            {"detail", escape_invalid_utf8(detail)}};
  if (!pointer.empty()) m["pointer"] = escape_invalid_utf8(pointer);
  return m;
}

json reject_message(const json& request_id, const EditRejection& why) {
  json m = {{"type", "reject"},
            {"status", why.status},
            {"title", why.title},
            {"detail", escape_invalid_utf8(why.detail)}};
  if (!request_id.is_null()) m["request"] = request_id;
  if (!why.pointer.empty()) m["pointer"] = escape_invalid_utf8(why.pointer);
  return m;
}

std::string_view path_of(std::string_view target) {
  return target.substr(0, target.find('?'));
}

// "/api/v1/scenes/{id}/live" → "{id}" (unchecked), or empty.
std::string live_ref(std::string_view target) {
  constexpr std::string_view prefix = "/api/v1/scenes/";
  constexpr std::string_view suffix = "/live";
  const std::string_view path = path_of(target);
  if (!path.starts_with(prefix) || !path.ends_with(suffix) ||
      path.size() <= prefix.size() + suffix.size()) {
    return {};
  }
  return std::string(path.substr(prefix.size(), path.size() - prefix.size() - suffix.size()));
}

bool printable_name(std::string_view name) {
  if (name.empty() || name.size() > 64) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return static_cast<unsigned char>(c) >= 0x20 && c != 0x7f; });
}

}  // namespace

bool App::is_live_target(std::string_view target) {
  return !live_ref(target).empty();
}

bool App::token_matches(std::string_view given) const {
  const std::string& expected = config_.write_token;
  if (expected.empty()) return false;
  // Constant-time comparison: the token must not leak through response timing.
  unsigned diff = given.size() == expected.size() ? 0u : 1u;
  for (std::size_t i = 0; i < given.size(); ++i) {
    diff |= static_cast<unsigned>(given[i] ^ expected[i % expected.size()]);
  }
  return diff == 0;
}

terrain::Result<LiveConnection, Response> App::live_open(const Request& request) {
  const std::string ref = live_ref(request.target());
  if (!detail::valid_id(ref)) {
    return problem(request, http::status::bad_request, "Bad scene id",
                   "a live channel follows a scene's head: /api/v1/scenes/{id}/live with an id of "
                   "1 to 64 characters of a-z, 0-9, '-' and '_' (no @version, no alias)",
                   "/id");
  }
  StoreResult<SceneVersion> head = store_->head(ref);
  if (!head) return detail::store_problem(request, head.error());
  LiveConnection connection;
  connection.scene = ref;
  if (const auto it = request.find(http::field::authorization); it != request.end()) {
    const std::string_view given(it->value().data(), it->value().size());
    if (!given.starts_with("Bearer ") || !token_matches(given.substr(7))) {
      return problem(request, http::status::forbidden, "Forbidden", "the write token is wrong");
    }
    connection.can_edit = true;
  }
  auto channel = live_.channel(ref);
  {
    auto held = channel->lock();
    if (channel->size() >= static_cast<std::size_t>(config_.live_max_subscribers)) {
      Response r =
          problem(request, http::status::service_unavailable, "Too many viewers",
                  "scene '" + ref + "' has " + std::to_string(config_.live_max_subscribers) +
                      " live connections, the most allowed");
      r.set(http::field::retry_after, "5");
      return r;
    }
  }
  connection.edit_tokens = config_.live_edit_burst;
  connection.refilled = std::chrono::steady_clock::now();
  return connection;
}

void App::live_message(LiveConnection& c, std::string_view message_text) {
  // Bounded before anything copies it: edit ops copy their values (docs/live.md, limits).
  Result<json> parsed = terrain::parse_json_text(message_text, "the message");
  if (!parsed) {
    c.self->deliver(text(
        error_message(400, "Invalid message", parsed.error().message, parsed.error().pointer)));
    return;
  }
  json message = std::move(parsed).value();
  if (!message.is_object()) {
    c.self->deliver(text(
        error_message(400, "Invalid message", "a message is one JSON object with a \"type\"", "")));
    return;
  }
  const auto type = message.find("type");
  if (type == message.end() || !type->is_string()) {
    c.self->deliver(text(
        error_message(400, "Invalid message", "type must be subscribe, edit or ping", "/type")));
    return;
  }
  const std::string kind = type->get<std::string>();
  if (kind == "ping") {
    c.self->deliver(text({{"type", "pong"}}));
  } else if (kind == "subscribe") {
    live_subscribe(c, message);
  } else if (kind == "edit") {
    live_edit(c, message);
  } else {
    c.self->deliver(text(error_message(
        400, "Invalid message", "unknown type '" + kind + "' (subscribe, edit or ping)", "/type")));
  }
}

void App::live_close(LiveConnection& c) {
  if (!c.subscribed) return;
  auto channel = live_.channel(c.scene);
  auto held = channel->lock();
  channel->leave(c.self.get());
  c.subscribed = false;
}

void App::live_subscribe(LiveConnection& c, const json& message) {
  auto refuse = [&](std::string_view detail, std::string_view pointer) {
    c.self->deliver(text(error_message(400, "Invalid subscribe", detail, pointer)));
  };
  if (c.subscribed) return refuse("this connection is subscribed already", "/type");
  std::optional<std::int64_t> since;
  if (const auto it = message.find("since"); it != message.end() && !it->is_null()) {
    if (!it->is_number_integer() || it->get<std::int64_t>() < 0) {
      return refuse("since is the last version the client knows: an integer ≥ 0", "/since");
    }
    since = it->get<std::int64_t>();
  }
  if (const auto it = message.find("name"); it != message.end()) {
    if (!it->is_string() || !printable_name(it->get<std::string>())) {
      return refuse("name is 1 to 64 printable characters", "/name");
    }
    c.author = it->get<std::string>();
  }
  if (const auto it = message.find("token"); it != message.end()) {
    if (!it->is_string() || !token_matches(it->get<std::string>())) {
      c.self->deliver(text(error_message(403, "Forbidden", "the write token is wrong", "/token")));
      return;
    }
    c.can_edit = true;
  }
  Request context{http::verb::get, "/api/v1/scenes/" + c.scene + "/live", 11};
  auto channel = live_.channel(c.scene);
  auto held = channel->lock();  // no version lands between the catch-up and the join
  StoreResult<SceneVersion> head = store_->head(c.scene);
  if (!head) {
    c.self->deliver(text(error_message(503, "Store unavailable", head.error().message, "")));
    return;
  }
  // Versions another replica stored that this channel has not published yet go to its present
  // subscribers first, so that nobody misses them when the newcomer moves the channel on.
  if (channel->last() > 0 && head->version > channel->last()) {
    publish_version(c.scene, *channel, head->version, nullptr);
  }
  if (!channel->join(c.self, config_.live_max_subscribers)) {
    c.self->deliver(text(error_message(503, "Too many viewers",
                                       "the scene has the most live connections allowed", "")));
    return;
  }
  c.subscribed = true;
  channel->advance_to(head->version);
  c.self->deliver(text({{"type", "welcome"},
                        {"scene", c.scene},
                        {"head", head->version},
                        {"hash", head->hash},
                        {"can_edit", c.can_edit},
                        {"limits",
                         {{"max_message_bytes", config_.live_max_message_bytes},
                          {"edits_per_second", config_.live_edits_per_second},
                          {"edit_burst", config_.live_edit_burst}}}}));
  if (!since || *since == head->version) return;
  if (*since > head->version) {
    c.self->deliver(
        text(error_message(409, "Unknown version",
                           "the scene is at version " + std::to_string(head->version) + ", not " +
                               std::to_string(*since) + ": start again from the head",
                           "/since")));
    return;
  }
  // Remembered events first; a gap the channel forgot is rebuilt from the store when short,
  // else sent as one step from `since` to the head.
  std::vector<std::shared_ptr<const std::string>> events;
  std::int64_t first_missing = 0;
  for (std::int64_t v = *since + 1; v <= head->version; ++v) {
    if (auto event = channel->recent(v)) {
      if (first_missing == 0) events.push_back(std::move(event));
    } else if (first_missing == 0) {
      first_missing = v;
    }
  }
  if (first_missing != 0) {
    events.clear();
    const std::int64_t gap = head->version - *since;
    StoreResult<std::vector<SceneVersion>> stored =
        gap <= kRebuiltEvents
            ? store_->versions_after(c.scene, *since - (*since > 0 ? 1 : 0), kRebuiltEvents + 1)
            : StoreResult<std::vector<SceneVersion>>(std::vector<SceneVersion>{});
    if (!stored) {
      c.self->deliver(text(error_message(503, "Store unavailable", stored.error().message, "")));
      return;
    }
    if (gap <= kRebuiltEvents) {
      // stored[0] is `since` itself (when > 0), the base of the first event.
      for (std::size_t i = 0; i < stored->size(); ++i) {
        const SceneVersion& v = (*stored)[i];
        if (v.version <= *since) continue;
        if (auto event = channel->recent(v.version)) {
          events.push_back(std::move(event));
          continue;
        }
        const SceneVersion none{};
        const SceneVersion& previous = i > 0 ? (*stored)[i - 1] : none;
        events.push_back(text(version_event(context, v, previous)));
      }
    } else {
      StoreResult<SceneVersion> base = store_->version(c.scene, *since);
      if (!base) {
        c.self->deliver(text(error_message(503, "Store unavailable", base.error().message, "")));
        return;
      }
      json jump = version_event(context, *head, *base);
      jump["ops"] = nullptr;
      events.push_back(text(jump));
    }
  }
  for (auto& event : events) c.self->deliver(std::move(event));
}

void App::live_edit(LiveConnection& c, const json& message) {
  const json request_id = message.contains("request") ? message["request"] : json();
  auto reject = [&](EditRejection why) { c.self->deliver(text(reject_message(request_id, why))); };
  if (!request_id.is_null() &&
      (!request_id.is_string() || request_id.get<std::string>().size() > 64)) {
    return reject(
        {400, "Invalid edit", "request is a string of at most 64 characters", "/request"});
  }
  if (!c.subscribed) {
    return reject({400, "Not subscribed", "send subscribe before edits", "/type"});
  }
  if (config_.write_token.empty()) {
    return reject({403, "Writes disabled",
                   "this server has no write token configured (auth.write_token)", ""});
  }
  if (!c.can_edit) {
    return reject({401, "Authorization required",
                   "edits need the write token (subscribe with \"token\")", "/token"});
  }
  // Token bucket: edit_burst at once, edits_per_second sustained.
  const auto now = std::chrono::steady_clock::now();
  c.edit_tokens =
      std::min<double>(config_.live_edit_burst,
                       c.edit_tokens + std::chrono::duration<double>(now - c.refilled).count() *
                                           config_.live_edits_per_second);
  c.refilled = now;
  if (c.edit_tokens < 1.0) {
    return reject({429, "Too many edits",
                   "at most " + std::to_string(config_.live_edit_burst) + " edits at once and " +
                       json(config_.live_edits_per_second).dump() + " per second",
                   ""});
  }
  c.edit_tokens -= 1.0;
  const auto base_it = message.find("base");
  if (base_it == message.end() || !base_it->is_number_integer() ||
      base_it->get<std::int64_t>() < 1) {
    return reject(
        {400, "Invalid edit", "base is the version the ops were written against", "/base"});
  }
  const std::int64_t base_number = base_it->get<std::int64_t>();
  const auto ops_it = message.find("ops");
  if (ops_it == message.end()) return reject({400, "Invalid edit", "ops is required", "/ops"});
  if (auto checked = check_patch(*ops_it); !checked) return reject(checked.error());

  Request context{http::verb::put, "/api/v1/scenes/" + c.scene, 11};
  auto channel = live_.channel(c.scene);
  auto held = channel->lock();  // one edit at a time per scene, published in version order
  // Replicas write to one store: the head may move between reading it and storing onto it.
  constexpr int kAttempts = 8;
  StoreResult<SceneVersion> stored = StoreError{};
  json ack;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    StoreResult<SceneVersion> head = store_->head(c.scene);
    if (!head) return reject({503, "Store unavailable", head.error().message, ""});
    if (base_number > head->version) {
      return reject({409, "Unknown version",
                     "the scene is at version " + std::to_string(head->version), "/base"});
    }
    const json head_doc = detail::parse_bounded_json(head->canonical_json);
    if (head_doc.is_discarded()) {
      return reject({500, "Stored scene unreadable", "the head is not JSON", ""});
    }
    // What other authors changed since the base, version by version.
    std::vector<NewerChange> newer;
    if (base_number < head->version) {
      if (head->version - base_number > kRebuiltEvents) {
        return reject({409, "Base too old",
                       "the edit is " + std::to_string(head->version - base_number) +
                           " versions behind the head (at most " + std::to_string(kRebuiltEvents) +
                           "): edit the head",
                       "/base"});
      }
      StoreResult<std::vector<SceneVersion>> between =
          store_->versions_after(c.scene, base_number - 1, head->version - base_number + 1);
      if (!between) return reject({503, "Store unavailable", between.error().message, ""});
      json previous;
      for (const SceneVersion& v : *between) {
        json document = detail::parse_bounded_json(v.canonical_json);
        const bool own = std::find(c.own_versions.begin(), c.own_versions.end(), v.version) !=
                         c.own_versions.end();
        if (v.version > base_number && !own) {
          newer.push_back({v.version, v.author, json::diff(previous, document)});
        }
        previous = std::move(document);
      }
    }
    auto patched = rebase_and_apply(*ops_it, newer, head_doc);
    if (!patched) return reject(patched.error());
    auto scene = parse_stored(patched->dump());
    if (!scene) {
      return reject({400, "Invalid scene",
                     "after the edit, " + scene.error().pointer + ": " + scene.error().message,
                     "/ops"});
    }
    ack = {{"type", "ack"}, {"rebased", base_number != head->version}};
    if (!request_id.is_null()) ack["request"] = request_id;
    if ((*scene)->hash == head->hash) {  // nothing changed: no new version
      ack["version"] = head->version;
      ack["hash"] = head->hash;
      ack["unchanged"] = true;
      c.self->deliver(text(ack));
      return;
    }
    SceneVersion next;
    next.name = (*scene)->name;
    next.hash = (*scene)->hash;
    next.canonical_json = (*scene)->canonical_text();
    next.author = c.author;
    next.ops_json = ops_it->dump();
    stored = commit_version(context, *channel, c.scene, std::move(next), head->version);
    // Another replica stored a version between our read of the head and our write (the store
    // refuses a stale head): rebase onto the newer head and try again.
    if (!stored && stored.error().kind == StoreError::Kind::conflict && attempt + 1 < kAttempts) {
      continue;
    }
    if (!stored) {
      return reject({stored.error().kind == StoreError::Kind::conflict ? 409 : 503,
                     stored.error().kind == StoreError::Kind::conflict ? "Edit conflict"
                                                                       : "Store unavailable",
                     stored.error().message, ""});
    }
    break;
  }
  ack["version"] = stored->version;
  ack["hash"] = stored->hash;
  c.own_versions.push_back(stored->version);
  if (c.own_versions.size() > static_cast<std::size_t>(kRebuiltEvents)) {
    c.own_versions.erase(c.own_versions.begin());
  }
  c.self->deliver(text(ack));  // after the version event, which publish delivered
}

StoreResult<SceneVersion> App::commit_version(const Request& context, LiveHub::Channel& channel,
                                              const std::string& id, SceneVersion next,
                                              std::optional<std::int64_t> expected_head) {
  StoreResult<SceneVersion> previous = store_->head(id);
  if (!previous) return previous.error();
  StoreResult<SceneVersion> stored = store_->add_version(id, next, expected_head);
  if (!stored) return stored;
  versions_.forget_head(id);
  stored->canonical_json = next.canonical_json;
  auto event = text(version_event(context, *stored, *previous));
  publish_version(id, channel, stored->version, event);
  if (bus_) bus_->publish(id, *event);
  return stored;
}

json App::version_event(const Request& context, const SceneVersion& current,
                        const SceneVersion& previous) {
  json event = {{"type", "version"},
                {"scene", current.scene_id},
                {"version", current.version},
                {"previous", previous.version},
                {"hash", current.hash},
                {"author", current.author},
                {"created_ms", current.created_ms}};
  event["ops"] = current.ops_json.empty() ? json() : detail::parse_bounded_json(current.ops_json);
  if (previous.version == 0) {
    event["changed"] = {{"everything", true}, {"box", nullptr}, {"global_formats", "all"}};
    return event;
  }
  auto before = load_version(context, previous);
  auto after = load_version(context, current);
  if (!before || !after) {
    event["changed"] = {{"everything", true}, {"box", nullptr}, {"global_formats", "all"}};
    return event;
  }
  event["changed"] = changed_between(*before, *after);
  return event;
}

}  // namespace server

namespace server {

void App::publish_version(const std::string& scene, LiveHub::Channel& channel, std::int64_t version,
                          std::shared_ptr<const std::string> event) {
  if (version <= channel.last()) return;  // published already (an echo, a repeat)
  const Request context{http::verb::get, "/api/v1/scenes/" + scene + "/live", 11};
  const std::int64_t last = channel.last();
  if (last > 0 && (version > last + 1 || !event)) {
    // The versions in between (and this one, without an event), from the store: one event each
    // for a short gap, else one step from the last published version.
    const std::int64_t gap = version - last;
    StoreResult<std::vector<SceneVersion>> stored =
        gap <= kRebuiltEvents ? store_->versions_after(scene, last - 1, gap + 1)
                              : StoreResult<std::vector<SceneVersion>>(StoreError{});
    if (stored && static_cast<std::int64_t>(stored->size()) == gap + 1) {
      for (std::size_t i = 1; i < stored->size(); ++i) {
        const SceneVersion& v = (*stored)[i];
        if (v.version == version && event) break;
        channel.publish(v.version, text(version_event(context, v, (*stored)[i - 1])));
      }
    } else {
      StoreResult<SceneVersion> from = store_->version(scene, last);
      StoreResult<SceneVersion> to = store_->version(scene, event ? version - 1 : version);
      if (!from || !to) return;  // the store is away: the next sweep or event tries again
      json jump = version_event(context, *to, *from);
      jump["ops"] = nullptr;
      channel.publish(to->version, text(jump));
    }
  } else if (!event) {
    StoreResult<SceneVersion> current = store_->version(scene, version);
    if (!current) return;
    const SceneVersion none{};
    StoreResult<SceneVersion> previous =
        version > 1 ? store_->version(scene, version - 1) : StoreResult<SceneVersion>(none);
    if (!previous) return;
    event = text(version_event(context, *current, *previous));
  }
  if (event) channel.publish(version, std::move(event));
}

void App::on_remote_event(const std::string& scene, const std::string& event_text) {
  if (!detail::valid_id(scene)) return;
  const json event = detail::parse_bounded_json(event_text);
  if (event.is_discarded() || !event.contains("version") || !event["version"].is_number_integer()) {
    return;
  }
  const std::int64_t version = event["version"].get<std::int64_t>();
  versions_.forget_head(scene);  // the head moved on another replica
  auto channel = live_.channel(scene);
  auto held = channel->lock();
  if (channel->size() == 0) {
    channel->publish(version, std::make_shared<const std::string>(event_text));
    return;
  }
  publish_version(scene, *channel, version, std::make_shared<const std::string>(event_text));
}

void App::sweep_heads() {
  for (const std::string& scene : live_.followed_scenes()) {
    StoreResult<SceneVersion> head = store_->head(scene);
    if (!head) continue;
    auto channel = live_.channel(scene);
    auto held = channel->lock();
    if (head->version > channel->last()) {
      versions_.forget_head(scene);
      publish_version(scene, *channel, head->version, nullptr);
    }
  }
}

std::shared_ptr<const terrain::SceneChange> App::scene_change(const LoadedVersion& before,
                                                              const LoadedVersion& after) {
  const std::string key = before.version.hash + ">" + after.version.hash;
  {
    std::lock_guard lock(changes_mutex_);
    if (auto it = changes_.find(key); it != changes_.end()) return it->second;
  }
  auto change = std::make_shared<const terrain::SceneChange>(
      terrain::SceneChange::between(before.scene, before.source, after.scene, after.source));
  std::lock_guard lock(changes_mutex_);
  if (changes_.size() >= kSceneChanges) changes_.clear();
  changes_.emplace(key, change);
  return change;
}

json App::changed_between(const LoadedVersion& before, const LoadedVersion& after) {
  const auto change = scene_change(before, after);
  json out = {{"everything", change->everything()}};
  if (const auto box = change->box()) {
    out["box"] = {{"min", {box->lo.x, box->lo.y}}, {"max", {box->hi.x, box->hi.y}}};
  } else {
    out["box"] = nullptr;
  }
  if (change->everything()) {
    out["global_formats"] = "all";
    return out;
  }
  json global = json::array();
  for (const terrain::TileFormatInfo& info : terrain::tile_formats()) {
    if (change->format_global(info.format)) {
      global.push_back(info.encoding.empty() ? info.extension : info.encoding);
    }
  }
  out["global_formats"] = global;
  return out;
}

std::shared_ptr<const CachedProduct> App::reuse_unchanged_tile(
    const LoadedVersion& current, const std::string& key, terrain::TileScheme scheme,
    const terrain::TileAddress& address, terrain::TileFormat format,
    const terrain::ProductOptions& options) {
  if (current.version.version <= 1) return nullptr;
  StoreResult<SceneVersion> previous =
      store_->version(current.version.scene_id, current.version.version - 1);
  if (!previous) return nullptr;
  std::shared_ptr<const CachedProduct> hit = cache_.find(previous->hash + key);
  if (!hit && disk_cache_) hit = disk_cache_->find(previous->hash + key);
  if (!hit) return nullptr;  // nothing to reuse: not worth comparing the versions
  const Request context{http::verb::get, "/", 11};
  auto before = load_version(context, *previous);
  if (!before) return nullptr;
  // Only when provably identical (docs/tiles.md, "Which tiles an edit changes"): the edit reaches
  // none of its samples.
  if (scene_change(*before, current)->tile_may_change(scheme, address, format, options)) {
    return nullptr;
  }
  metrics_.reused_across_versions.fetch_add(1);
  return hit;
}

Response App::scene_changes(const Request& request, const std::string& id, const Target& target) {
  if (!detail::valid_id(id)) {
    return problem(request, http::status::bad_request, "Bad scene id",
                   "changes are between versions of one scene: /api/v1/scenes/{id}/changes "
                   "(no @version)",
                   "/id");
  }
  auto version_param = [&](const char* name) -> terrain::Result<SceneVersion, Response> {
    const std::string text = target.get(name);
    std::int64_t number = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), number);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size() || number < 1) {
      return problem(request, http::status::bad_request, "Bad version",
                     std::string(name) + " must be a version number (1, 2, …)",
                     std::string("/") + name);
    }
    StoreResult<SceneVersion> v = store_->version(id, number);
    if (!v) return detail::store_problem(request, v.error(), std::string("/") + name);
    return *v;
  };
  auto from = version_param("from");
  if (!from) return from.error();
  auto to = version_param("to");
  if (!to) return to.error();
  // The tile shape: the same parameters as a tile URL, with the format as `format`.
  const std::string format = target.get("format", "png");
  const std::string z = target.get("z");
  if (z.empty()) {
    return problem(request, http::status::bad_request, "Bad tile address", "z is required", "/z");
  }
  const bool mesh = format == "terrain" || format == "glb" || format == "drc";
  auto shape =
      detail::tile_shape(request, {mesh ? "mesh" : "tiles", z, "0", "0." + format}, target.query);
  if (!shape) return shape.error();
  auto before = load_version(request, *from);
  if (!before) return before.error();
  auto after = load_version(request, *to);
  if (!after) return after.error();
  const auto change = scene_change(*before, *after);
  bool truncated = false;
  const std::vector<terrain::TileAddress> tiles = change->changed_tiles(
      shape->scheme, shape->address.z, shape->format, shape->options, kMaxChangedTiles, &truncated);
  json list = json::array();
  for (const terrain::TileAddress& a : tiles) list.push_back({a.x, a.y});
  json body = changed_between(*before, *after);
  body["scene"] = id;
  body["from"] = from->version;
  body["to"] = to->version;
  body["scheme"] = terrain::scheme_name(shape->scheme);
  body["z"] = shape->address.z;
  body["format"] = format;
  body["tiles"] = std::move(list);
  body["truncated"] = truncated;
  Response r = detail::json_response(request, http::status::ok, body);
  // Both versions are immutable, so is what differs between them.
  r.set(http::field::cache_control, detail::kImmutable);
  return r;
}

}  // namespace server
