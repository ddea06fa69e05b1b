// libFuzzer target: the request handler's parsing and routing (targets, queries, tile
// addresses, headers) must answer every request with a response or deferred work, never crash.
// Deferred generation is not run: the router's job is to refuse bad input before work.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

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
    auto store = server::open_sqlite_store(config.data_dir);
    auto* a = new server::App(config, std::move(store).value());
    (void)a->seed_examples();
    return a;
  }();
  return *instance;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  namespace http = boost::beast::http;
  static const http::verb verbs[] = {http::verb::get, http::verb::head, http::verb::put,
                                     http::verb::post, http::verb::options, http::verb::delete_};
  const http::verb verb = verbs[data[0] % 6];
  std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  // "target\nheader-value\nbody": the fuzzer reaches paths, an If-None-Match and a body.
  const std::size_t a = text.find('\n');
  const std::string target = "/api/v1/" + text.substr(0, a);
  const std::string rest = a == std::string::npos ? "" : text.substr(a + 1);
  const std::size_t b = rest.find('\n');
  server::Request request{verb, target, 11};
  request.set(http::field::if_none_match, rest.substr(0, b));
  request.set(http::field::authorization, "Bearer token");
  request.body() = b == std::string::npos ? "" : rest.substr(b + 1);
  request.prepare_payload();
  server::Outcome outcome = app().handle(request);
  (void)outcome;
  return 0;
}
