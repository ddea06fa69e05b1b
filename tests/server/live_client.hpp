// A WebSocket client of live channels (docs/live.md) for the integration tests: Beast's
// WebSocket stream on its own io_context, every operation run with a deadline so that a server
// bug fails a test instead of hanging it.
//
// The Beast code lives in live_client.cpp, compiled once: instantiated in every test file that
// includes this header, it cost each of them about 40 s of compile time.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "http_harness.hpp"

namespace http_test {

/// One masked client frame (RFC 6455 §5.2) with a zero mask key, so the payload goes out as it
/// is: `opcode` 0 continues a message, 1 starts a text one; `fin` ends the message.
std::string client_frame(bool fin, int opcode, const std::string& payload = "");

class LiveClient {
 public:
  /// Connects and upgrades to /api/v1/scenes/{scene}/live. `receive_buffer` > 0 shrinks the
  /// socket's receive buffer (a reader the server cannot flood quickly). Throws when the upgrade
  /// is refused (see try_open for tests of refusals).
  LiveClient(int port, const std::string& scene, const Headers& headers = {},
             int receive_buffer = 0);
  ~LiveClient();
  LiveClient(const LiveClient&) = delete;
  LiveClient& operator=(const LiveClient&) = delete;

  /// The HTTP status of an upgrade attempt: 101 when it was accepted.
  static int try_open(int port, const std::string& scene, const Headers& headers = {});

  void send(const nlohmann::json& message) { send_text(message.dump()); }
  void send_text(const std::string& text);
  /// Writes bytes straight to the socket, below the WebSocket layer (hand-made frames: see
  /// client_frame). False when the connection failed or `timeout` passed first.
  bool send_raw(const std::string& bytes, Millis timeout = kIoTimeout);

  /// The next message; throws after `timeout` without one, or when the connection ended.
  nlohmann::json next(Millis timeout = kIoTimeout);
  /// The next message of this type, skipping others (pongs, say).
  nlohmann::json next_of(const std::string& type, Millis timeout = kIoTimeout);
  /// Whether a message arrives within `timeout` (it is consumed).
  bool message_within(Millis timeout);
  /// Reads until the connection ends (or `timeout`); the close code the server sent, 0 when the
  /// connection ended without a close frame, nullopt on timeout.
  std::optional<int> close_code(Millis timeout = kIoTimeout);

  /// Subscribes (with the token when `editor`) and returns the welcome.
  nlohmann::json subscribe(bool editor, std::optional<std::int64_t> since = std::nullopt,
                           const std::string& name = "tester");

  /// Closes with a normal close frame (best effort, within 2 s).
  void close();

 private:
  struct Stream;
  LiveClient();
  int open(int port, const std::string& scene, const Headers& headers, int receive_buffer);

  std::unique_ptr<Stream> stream_;
};

}  // namespace http_test
