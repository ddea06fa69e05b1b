// A WebSocket client of live channels (docs/live.md) for the integration tests: Beast's
// WebSocket stream on its own io_context, every operation run with a deadline so that a server
// bug fails a test instead of hanging it.
#pragma once

#include <sys/socket.h>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "http_harness.hpp"

namespace http_test {

namespace websocket = boost::beast::websocket;

class LiveClient {
 public:
  /// Connects and upgrades to /api/v1/scenes/{scene}/live. `receive_buffer` > 0 shrinks the
  /// socket's receive buffer (a reader the server cannot flood quickly). Throws when the upgrade
  /// is refused; `refused_status` then says how (for tests of refusals, see try_open).
  LiveClient(int port, const std::string& scene, const Headers& headers = {},
             int receive_buffer = 0) {
    if (auto status = open(port, scene, headers, receive_buffer); status != 101) {
      throw std::runtime_error("live upgrade refused with " + std::to_string(status));
    }
  }

  /// The HTTP status of an upgrade attempt: 101 when it was accepted.
  static int try_open(int port, const std::string& scene, const Headers& headers = {}) {
    LiveClient client;
    return client.open(port, scene, headers, 0);
  }

  void send(const nlohmann::json& message) { send_text(message.dump()); }
  void send_text(const std::string& text) {
    ws_.text(true);
    run([&](auto done) { ws_.async_write(boost::asio::buffer(text), done); });
  }

  /// The next message; throws after `timeout` without one, or when the connection ended.
  nlohmann::json next(Millis timeout = kIoTimeout) {
    boost::beast::flat_buffer buffer;
    const auto ec = run([&](auto done) { ws_.async_read(buffer, done); }, timeout);
    if (ec) throw std::runtime_error("live read failed: " + ec.message());
    return nlohmann::json::parse(boost::beast::buffers_to_string(buffer.data()));
  }

  /// The next message of this type, skipping others (pongs, say).
  nlohmann::json next_of(const std::string& type, Millis timeout = kIoTimeout) {
    const auto deadline = Clock::now() + timeout;
    while (true) {
      nlohmann::json m = next(Millis(std::max(1, remaining_ms(deadline))));
      if (m.value("type", "") == type) return m;
    }
  }

  /// Whether a message arrives within `timeout` (it is consumed).
  bool message_within(Millis timeout) {
    boost::beast::flat_buffer buffer;
    return !run([&](auto done) { ws_.async_read(buffer, done); }, timeout, false);
  }

  /// Reads until the connection ends (or `timeout`); the close code the server sent, 0 when the
  /// connection ended without a close frame, nullopt on timeout.
  std::optional<int> close_code(Millis timeout = kIoTimeout) {
    const auto deadline = Clock::now() + timeout;
    while (remaining_ms(deadline) > 0) {
      boost::beast::flat_buffer buffer;
      const auto ec = run([&](auto done) { ws_.async_read(buffer, done); },
                          Millis(std::max(1, remaining_ms(deadline))), false);
      if (timed_out_) return std::nullopt;
      if (ec == websocket::error::closed) return static_cast<int>(ws_.reason().code);
      if (ec) {
        last_error = ec.message();
        return 0;
      }
    }
    return std::nullopt;
  }

  /// Subscribes (with the token when `editor`) and returns the welcome.
  nlohmann::json subscribe(bool editor, std::optional<std::int64_t> since = std::nullopt,
                           const std::string& name = "tester") {
    nlohmann::json m = {{"type", "subscribe"}, {"name", name}};
    if (editor) m["token"] = kToken;
    if (since) m["since"] = *since;
    send(m);
    return next_of("welcome");
  }

  std::string last_error;  ///< why close_code() saw the connection end without a close frame

  void close() {
    run([&](auto done) { ws_.async_close(websocket::close_code::normal, done); }, Millis(2000),
        false);
  }

 private:
  LiveClient() = default;

  int open(int port, const std::string& scene, const Headers& headers, int receive_buffer) {
    auto& socket = ws_.next_layer();
    socket.open(boost::asio::ip::tcp::v4());
    if (receive_buffer > 0) {
      ::setsockopt(socket.native_handle(), SOL_SOCKET, SO_RCVBUF, &receive_buffer,
                   sizeof receive_buffer);
    }
    const boost::asio::ip::tcp::endpoint endpoint(boost::asio::ip::make_address("127.0.0.1"),
                                                  static_cast<unsigned short>(port));
    if (run([&](auto done) { socket.async_connect(endpoint, done); })) return -1;
    ws_.set_option(websocket::stream_base::decorator([headers](websocket::request_type& r) {
      for (const auto& [name, value] : headers) r.set(name, value);
    }));
    websocket::response_type response;
    const auto ec = run([&](auto done) {
      ws_.async_handshake(response, "127.0.0.1:" + std::to_string(port),
                          "/api/v1/scenes/" + scene + "/live", done);
    });
    if (ec) return static_cast<int>(response.result_int());
    return 101;
  }

  // Runs one asynchronous operation to completion or `timeout` (then cancels it); its error.
  template <class Start>
  boost::system::error_code run(Start start, Millis timeout = kIoTimeout, bool must = false) {
    bool finished = false;
    timed_out_ = false;
    boost::system::error_code result;
    start([&](boost::system::error_code ec, auto&&...) {
      finished = true;
      result = ec;
    });
    io_.restart();
    io_.run_for(timeout);
    if (!finished) {
      boost::system::error_code ignored;
      ws_.next_layer().cancel(ignored);
      io_.restart();
      io_.run();
      timed_out_ = true;
      if (must) throw std::runtime_error("live operation timed out");
      return boost::asio::error::operation_aborted;
    }
    return result;
  }

  bool timed_out_ = false;
  boost::asio::io_context io_;
  websocket::stream<boost::asio::ip::tcp::socket> ws_{io_};
};

}  // namespace http_test
