// Session I/O: a Boost.Beast HTTP/1.1 server on C++20 coroutines. Reads a request under the
// configured header/body limits and timeouts, hands it to App::handle, runs Deferred work on the
// bounded generation pool, writes the response. Graceful stop: no new connections, idle ones
// closed, in-flight requests finished.
#pragma once

#include <atomic>
#include <memory>
#include <string>

#include "server/app.hpp"

namespace server {

class HttpServer {
 public:
  HttpServer(App& app, const Config& config);
  ~HttpServer();

  /// Binds and listens; the error says why not (address in use, bad address).
  terrain::Result<int> listen();
  /// Runs the I/O and generation threads until stop(); returns when everything has drained.
  void run();
  /// Thread-safe and signal-safe to call through post: starts the graceful shutdown.
  void stop();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace server
