// libFuzzer target: the request handler's parsing and routing (targets, queries, tile
// addresses, headers) must answer every request with a response or deferred work, never crash.
// Deferred generation is not run: the router's job is to refuse bad input before work. Writes
// are (they parse, compile and store on the pool), and the example scenes' first versions are
// loaded at start, so that their product routes are reached without deferral.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "server/admission.hpp"
#include "server/app.hpp"

namespace {

server::App& app() {
  static server::App* instance = [] {
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / "terrain-router-fuzz";
    fs::remove_all(dir);
    server::Config config;
    config.data_dir = dir.string();
    config.scenes_dir = TERRAIN_SOURCE_DIR "/config/scenes";
    config.write_token = "token";
    // Small erosions only: a mutated scene never spends seconds of the run (the eroded example
    // scenes are refused when loaded, which is fuzzed too).
    config.erosion_work = std::int64_t{1} << 18;
    auto store = server::open_sqlite_store(config.data_dir);
    auto* a = new server::App(config, std::move(store).value());
    (void)a->seed_examples();
    for (const char* id :
         {"butte", "craters", "hills-river", "lake-dunes", "mountain-range", "winding-road"}) {
      server::Request load{boost::beast::http::verb::get,
                           std::string("/api/v1/scenes/") + id + "@1", 11};
      (void)server::settle(*a, load);
    }
    return a;
  }();
  return *instance;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  namespace http = boost::beast::http;
  static const http::verb verbs[] = {http::verb::get,  http::verb::head,    http::verb::put,
                                     http::verb::post, http::verb::options, http::verb::delete_};
  const http::verb verb = verbs[data[0] % 6];
  std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  // "target\nheader-value\nbody": the fuzzer reaches paths, an If-None-Match and a body.
  const std::size_t a = text.find('\n');
  const std::string target = "/api/v1/" + text.substr(0, a);
  const std::string rest = a == std::string::npos ? "" : text.substr(a + 1);
  const std::size_t b = rest.find('\n');
  server::Request request{verb, target, 11};
  // The header line also stands for the fields the session and the handler parse themselves.
  const std::string field = rest.substr(0, b);
  request.set(http::field::if_none_match, field);
  request.set(http::field::host, field);
  request.set(http::field::transfer_encoding, field);
  (void)server::check_framing(request.base());
  request.set(http::field::authorization, "Bearer token");
  request.body() = b == std::string::npos ? "" : rest.substr(b + 1);
  request.prepare_payload();
  server::Outcome outcome = app().handle(request);
  if (auto* deferred = std::get_if<server::Deferred>(&outcome)) {
    // Writes and version loads are what the pool parses and compiles; products are not made.
    if (deferred->prepare) {
      (void)deferred->prepare();
    } else if (verb == http::verb::put || verb == http::verb::post) {
      (void)deferred->work();
    }
  }
  return 0;
}
