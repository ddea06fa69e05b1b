// libFuzzer target: the live protocol (docs/live.md) must answer every message a connection
// sends (subscribe, edit with its JSON Patch ops and rebasing, ping, anything else) with a reply
// and never crash, as a WebSocket session would pass them to App::live_message.
//
// Input: messages, one a line. Lines starting with '>' come from a second editor on the same
// scene (so that edits are rebased onto, and conflict with, someone else's versions). Unless the
// input starts with {"type":"subscribe", both connections subscribe first, so that edits get
// past the subscription check. Each input runs on a server and store of its own, whose one scene
// is the same small scene at version 1.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include <unistd.h>

#include "server/app.hpp"

namespace {

constexpr std::string_view kScene =
    R"({"format":"terrain-scene/1","name":"Fuzz","seed":1,)"
    R"("extent":{"min":[-2000,-2000],"max":[2000,2000]},)"
    R"("root":{"type":"blend","children":[)"
    R"({"type":"disc","center":[-1000,-1000],"radius":500,"elevation":100},)"
    R"({"type":"disc","center":[1000,-1000],"radius":500,"elevation":100},)"
    R"({"type":"transform","translate":[0,800],"children":[)"
    R"({"type":"disc","center":[0,0],"radius":400,"elevation":50}]}]}})";

/// Counts what a connection is sent (the session's socket, without the socket).
class Replies final : public server::LiveSubscriber {
 public:
  void deliver(std::shared_ptr<const std::string> message) override { bytes_ += message->size(); }

 private:
  std::size_t bytes_ = 0;
};

// The folder of this process's store, emptied after each input. In memory where there can be:
// every accepted edit is a synchronous commit.
const std::filesystem::path& store_dir() {
  namespace fs = std::filesystem;
  static const fs::path dir =
      (fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path()) /
      ("terrain-live-fuzz-" + std::to_string(::getpid()));
  return dir;
}

/// A server of its own for every input, on a store created for it: nothing carries over from one
/// input to the next (an input replays the same way in any process, and nothing grows).
server::Config fresh_config() {
  std::filesystem::remove_all(store_dir());
  server::Config config;
  config.data_dir = store_dir().string();
  config.backend = server::Backend::cpu;  // no tile is generated here
  config.write_token = "token";
  config.live_edits_per_second = 1e9;  // the rate limit would refuse most edits unread
  config.live_edit_burst = 1'000'000'000;
  return config;
}

void create_scene(server::App& app) {
  server::Request post{boost::beast::http::verb::post, "/api/v1/scenes?id=fuzz", 11};
  post.set(boost::beast::http::field::authorization, "Bearer token");
  post.body() = std::string(kScene);
  post.prepare_payload();
  // Writes are deferred to the generation pool; here they run on this thread.
  if (server::settle(app, post).result_int() != 201) std::abort();  // the harness is broken
}

server::LiveConnection open(server::App& app) {
  server::Request upgrade{boost::beast::http::verb::get, "/api/v1/scenes/fuzz/live", 11};
  auto connection = app.live_open(upgrade);
  if (!connection) std::abort();
  connection->self = std::make_shared<Replies>();
  connection->can_edit = true;
  return std::move(connection).value();
}

void run(std::string_view input) {
  const server::Config config = fresh_config();
  auto store = server::open_sqlite_store(config.data_dir);
  if (!store) std::abort();
  server::App app(config, std::move(store).value());
  create_scene(app);
  server::LiveConnection first = open(app);
  server::LiveConnection second = open(app);
  if (!input.starts_with(R"({"type":"subscribe")")) {
    app.live_message(first, R"({"type":"subscribe","name":"first"})");
    app.live_message(second, R"({"type":"subscribe","name":"second"})");
  }
  std::size_t at = 0;
  while (at <= input.size()) {
    const std::size_t end = std::min(input.find('\n', at), input.size());
    std::string_view line = input.substr(at, end - at);
    server::LiveConnection* from = &first;
    if (line.starts_with('>')) {
      from = &second;
      line.remove_prefix(1);
    }
    app.live_message(*from, line);
    at = end + 1;
  }
  app.live_close(first);
  app.live_close(second);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  run(std::string_view(reinterpret_cast<const char*>(data), size));
  std::filesystem::remove_all(store_dir());
  return 0;
}
