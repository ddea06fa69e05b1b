#include "live_client.hpp"

#include <sys/socket.h>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>

#include <stdexcept>

namespace http_test {

namespace asio = boost::asio;
namespace websocket = boost::beast::websocket;
using boost::system::error_code;

namespace {

/// The one completion handler type of every operation, so that each Beast operation is
/// instantiated once.
struct Completion {
  bool* finished;
  error_code* result;
  template <class... Rest>
  void operator()(error_code ec, Rest&&...) const {
    *finished = true;
    *result = ec;
  }
};

}  // namespace

struct LiveClient::Stream {
  asio::io_context io;
  websocket::stream<asio::ip::tcp::socket> ws{io};
  bool timed_out = false;

  // Runs one asynchronous operation to completion or `timeout` (then cancels it); its error.
  template <class Start>
  error_code run(Start start, Millis timeout = kIoTimeout) {
    bool finished = false;
    timed_out = false;
    error_code result;
    start(Completion{&finished, &result});
    io.restart();
    io.run_for(timeout);
    if (!finished) {
      error_code ignored;
      ws.next_layer().cancel(ignored);
      io.restart();
      io.run();
      timed_out = true;
      return asio::error::operation_aborted;
    }
    return result;
  }

  error_code read(boost::beast::flat_buffer& buffer, Millis timeout) {
    return run([&](Completion done) { ws.async_read(buffer, done); }, timeout);
  }
};

std::string client_frame(bool fin, int opcode, const std::string& payload) {
  std::string frame(1, static_cast<char>((fin ? 0x80 : 0x00) | (opcode & 0x0f)));
  const std::uint64_t length = payload.size();
  if (length < 126) {
    frame += static_cast<char>(0x80 | length);
  } else if (length <= 0xffff) {
    frame += static_cast<char>(0x80 | 126);
    for (int shift = 8; shift >= 0; shift -= 8)
      frame += static_cast<char>((length >> shift) & 0xff);
  } else {
    frame += static_cast<char>(0x80 | 127);
    for (int shift = 56; shift >= 0; shift -= 8) {
      frame += static_cast<char>((length >> shift) & 0xff);
    }
  }
  frame += std::string(4, '\0');  // the mask key
  return frame + payload;
}

LiveClient::LiveClient() : stream_(std::make_unique<Stream>()) {}

LiveClient::LiveClient(int port, const std::string& scene, const Headers& headers,
                       int receive_buffer)
    : LiveClient() {
  if (const int status = open(port, scene, headers, receive_buffer); status != 101) {
    throw std::runtime_error("live upgrade refused with " + std::to_string(status));
  }
}

LiveClient::~LiveClient() = default;

int LiveClient::try_open(int port, const std::string& scene, const Headers& headers) {
  LiveClient client;
  return client.open(port, scene, headers, 0);
}

void LiveClient::send_text(const std::string& text) {
  stream_->ws.text(true);
  stream_->run([&](Completion done) { stream_->ws.async_write(asio::buffer(text), done); });
}

bool LiveClient::send_raw(const std::string& bytes, Millis timeout) {
  return !stream_->run(
      [&](Completion done) {
        asio::async_write(stream_->ws.next_layer(), asio::buffer(bytes), done);
      },
      timeout);
}

nlohmann::json LiveClient::next(Millis timeout) {
  boost::beast::flat_buffer buffer;
  if (const error_code ec = stream_->read(buffer, timeout)) {
    throw std::runtime_error("live read failed: " + ec.message());
  }
  return nlohmann::json::parse(boost::beast::buffers_to_string(buffer.data()));
}

nlohmann::json LiveClient::next_of(const std::string& type, Millis timeout) {
  const auto deadline = Clock::now() + timeout;
  while (true) {
    nlohmann::json m = next(Millis(std::max(1, remaining_ms(deadline))));
    if (m.value("type", "") == type) return m;
  }
}

bool LiveClient::message_within(Millis timeout) {
  boost::beast::flat_buffer buffer;
  return !stream_->read(buffer, timeout);
}

std::optional<int> LiveClient::close_code(Millis timeout) {
  const auto deadline = Clock::now() + timeout;
  while (remaining_ms(deadline) > 0) {
    boost::beast::flat_buffer buffer;
    const error_code ec = stream_->read(buffer, Millis(std::max(1, remaining_ms(deadline))));
    if (stream_->timed_out) return std::nullopt;
    if (ec == websocket::error::closed) return static_cast<int>(stream_->ws.reason().code);
    if (ec) return 0;
  }
  return std::nullopt;
}

nlohmann::json LiveClient::subscribe(bool editor, std::optional<std::int64_t> since,
                                     const std::string& name) {
  nlohmann::json m = {{"type", "subscribe"}, {"name", name}};
  if (editor) m["token"] = kToken;
  if (since) m["since"] = *since;
  send(m);
  return next_of("welcome");
}

void LiveClient::close() {
  stream_->run(
      [&](Completion done) { stream_->ws.async_close(websocket::close_code::normal, done); },
      Millis(2000));
}

int LiveClient::open(int port, const std::string& scene, const Headers& headers,
                     int receive_buffer) {
  auto& socket = stream_->ws.next_layer();
  socket.open(asio::ip::tcp::v4());
  if (receive_buffer > 0) {
    ::setsockopt(socket.native_handle(), SOL_SOCKET, SO_RCVBUF, &receive_buffer,
                 sizeof receive_buffer);
  }
  const asio::ip::tcp::endpoint endpoint(asio::ip::make_address("127.0.0.1"),
                                         static_cast<unsigned short>(port));
  if (stream_->run([&](Completion done) { socket.async_connect(endpoint, done); })) return -1;
  stream_->ws.set_option(websocket::stream_base::decorator([headers](websocket::request_type& r) {
    for (const auto& [name, value] : headers) r.set(name, value);
  }));
  websocket::response_type response;
  const error_code ec = stream_->run([&](Completion done) {
    stream_->ws.async_handshake(response, "127.0.0.1:" + std::to_string(port),
                                "/api/v1/scenes/" + scene + "/live", done);
  });
  if (ec) return static_cast<int>(response.result_int());
  return 101;
}

}  // namespace http_test
