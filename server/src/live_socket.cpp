#include "live_socket.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <deque>
#include <functional>
#include <limits>
#include <mutex>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>

#include "server/log.hpp"

namespace server {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using asio::awaitable;
using asio::use_awaitable;

namespace {

// Meters what one live connection reads from its socket, below the WebSocket layer, where every
// byte counts: frame headers, empty frames and control frames too. Above it nothing sees empty
// non-final frames: Beast's reader loops over them without returning, and read_message_max
// counts payload only, so a peer could stream them inside one message forever. Two bounds
// (docs/live.md, "Limits"):
// - one message may take `message_budget` wire bytes, counted from the end of the previous one;
//   reaching it calls on_over_budget (the connection is cut) and nothing more is read;
// - reads are paced by a token bucket refilled at `bytes_per_second` that holds one message's
//   budget (or one second's worth, if more: basic_stream waits in one-second steps), so one
//   full-size message arrives at once, and a flood of anything (tiny messages, pings, empty
//   frames) costs the server at most that many bytes a second per connection.
// A Beast rate policy (basic_stream): called on the connection's thread only.
class LiveReadMeter {
 public:
  LiveReadMeter(std::int64_t message_budget, std::int64_t bytes_per_second)
      : budget_(static_cast<double>(message_budget)),
        rate_(static_cast<double>(bytes_per_second)),
        capacity_(std::max(budget_, rate_)),
        tokens_(capacity_),
        refilled_(std::chrono::steady_clock::now()) {}

  /// Called once, when a message has taken its whole budget.
  std::function<void()> on_over_budget;
  /// A whole message was read: the next one starts a fresh budget.
  void message_done() { message_bytes_ = 0; }

 private:
  friend class beast::rate_policy_access;

  std::size_t available_read_bytes() {
    const auto now = std::chrono::steady_clock::now();
    tokens_ = std::min(capacity_,
                       tokens_ + std::chrono::duration<double>(now - refilled_).count() * rate_);
    refilled_ = now;
    const double allowed = std::min(tokens_, budget_ - message_bytes_);
    // basic_stream waits for its next one-second tick when this is 0.
    return allowed < 1.0 ? 0 : static_cast<std::size_t>(allowed);
  }
  void transfer_read_bytes(std::size_t n) {
    tokens_ -= static_cast<double>(n);
    message_bytes_ += static_cast<double>(n);
    if (message_bytes_ >= budget_ && !over_budget_) {
      over_budget_ = true;
      if (on_over_budget) on_over_budget();
    }
  }
  static std::size_t available_write_bytes() { return std::numeric_limits<std::size_t>::max(); }
  static void transfer_write_bytes(std::size_t) {}
  static void on_timer() {}

  const double budget_;
  const double rate_;
  const double capacity_;
  double tokens_;
  double message_bytes_ = 0.0;
  bool over_budget_ = false;
  std::chrono::steady_clock::time_point refilled_;
};

/// The wire bytes one message may take: twice the largest message (room for the 6 to 14 header
/// bytes of each masked frame of 6 payload bytes or more) plus room for control frames and for
/// what the reader read ahead of the next message (Beast's 1536-byte buffer).
std::int64_t live_message_budget(const Config& config) {
  constexpr std::int64_t kAllowance = 16 << 10;
  return 2 * config.live_max_message_bytes + kAllowance;
}

using LiveStream = beast::basic_stream<tcp, asio::any_io_executor, LiveReadMeter>;

}  // namespace

class LiveSocket final : public LiveSubscriber, public std::enable_shared_from_this<LiveSocket> {
 public:
  LiveSocket(tcp::socket socket, const Config& config, Metrics& metrics)
      : metrics_(metrics),
        ws_(LiveReadMeter(live_message_budget(config), config.live_read_bytes_per_second),
            std::move(socket)),
        wake_(ws_.get_executor()),
        queue_bytes_(config.live_queue_bytes),
        queue_messages_(config.live_queue_messages) {
    wake_.expires_at(asio::steady_timer::time_point::max());
  }

  // Any thread: counts the message against the connection's backlog, queues it and wakes the
  // connection's thread. A connection that owes too much is cut instead of buffering more.
  //
  // The message joins the queue here, in call order, rather than in a handler posted to the
  // connection's thread: a single-threaded io_context runs handlers that its own thread posted
  // only after the running handler returns, so a version posted by another connection's thread
  // in the meantime would overtake them (live_test's ConcurrentEditsConvergeInOneOrderEverywhere).
  void deliver(std::shared_ptr<const std::string> message) override {
    const auto size = static_cast<std::int64_t>(message->size());
    const std::int64_t bytes = owed_bytes_.fetch_add(size) + size;
    const int messages = owed_messages_.fetch_add(1) + 1;
    metrics_.live_backlog_bytes.fetch_add(size);
    if (bytes > queue_bytes_ || messages > queue_messages_) {
      owed_bytes_.fetch_sub(size);
      owed_messages_.fetch_sub(1);
      metrics_.live_backlog_bytes.fetch_sub(size);
      if (!overflowed_.exchange(true)) {
        asio::post(ws_.get_executor(), [self = shared_from_this()] { self->cut("slow reader"); });
      }
      return;
    }
    {
      std::lock_guard lock(queue_mutex_);
      queue_.push_back(std::move(message));
    }
    asio::post(ws_.get_executor(), [self = shared_from_this()] { self->wake_.cancel_one(); });
  }

  websocket::stream<LiveStream>& ws() { return ws_; }
  LiveReadMeter& meter() { return beast::get_lowest_layer(ws_).rate_policy(); }

  /// Cuts the connection when a message takes more wire bytes than its budget.
  void watch_reads() {
    meter().on_over_budget = [weak = weak_from_this()] {
      auto self = weak.lock();
      if (!self) return;
      self->flooded_ = true;
      // Posted: the meter is called from inside the read that counted the bytes.
      asio::post(self->ws_.get_executor(), [self] { self->cut("a message took too many bytes"); });
    };
  }
  bool flooded() const { return flooded_; }

  ~LiveSocket() override {
    // Messages queued after the writer ended (the connection went first) are owed no more.
    metrics_.live_backlog_bytes.fetch_sub(owed_bytes_.load());
  }
  bool subscribed = false;  ///< the connection's thread only
  bool overflowed() const { return overflowed_; }

  // The connection's thread: sends queued messages in order until the connection ends. Holds
  // the session, which therefore outlives every operation the loop has started.
  static awaitable<void> write_loop(std::shared_ptr<LiveSocket> self) {
    while (self->open_) {
      std::shared_ptr<const std::string> message = self->take();
      if (!message) {
        // A message queued after take() also posts a wake-up, which runs on this thread after
        // the wait below has started: no wake-up is lost.
        boost::system::error_code ignored;
        co_await self->wake_.async_wait(asio::redirect_error(use_awaitable, ignored));
        continue;
      }
      boost::system::error_code ec;
      self->ws_.text(true);
      co_await self->ws_.async_write(asio::buffer(*message),
                                     asio::redirect_error(use_awaitable, ec));
      self->forget(*message);
      if (ec) break;
    }
    while (auto left = self->take()) self->forget(*left);
  }

  // The oldest queued message, or null.
  std::shared_ptr<const std::string> take() {
    std::lock_guard lock(queue_mutex_);
    if (queue_.empty()) return nullptr;
    std::shared_ptr<const std::string> message = std::move(queue_.front());
    queue_.pop_front();
    return message;
  }

  // A message left the backlog (sent, or dropped with the connection).
  void forget(const std::string& message) {
    const auto size = static_cast<std::int64_t>(message.size());
    owed_bytes_.fetch_sub(size);
    owed_messages_.fetch_sub(1);
    metrics_.live_backlog_bytes.fetch_sub(size);
  }

  /// Ends the connection without a close handshake (a full send buffer would hold it back).
  void cut(std::string_view why) {
    if (!open_) return;
    open_ = false;
    log(LogLevel::info, "live connection cut", {{"why", std::string(why)}});
    // basic_stream's close also ends a read waiting for the read meter.
    beast::get_lowest_layer(ws_).close();
    wake_.cancel();
  }

  /// Closes with a close frame (shutdown, policy); the reader then ends. A peer that does not
  /// answer the close within a second is cut, so a shutdown never waits on a silent client.
  void close(websocket::close_code code, std::string_view reason) {
    if (!open_ || closing_) return;
    closing_ = true;
    auto give_up = std::make_shared<asio::steady_timer>(ws_.get_executor());
    give_up->expires_after(std::chrono::seconds(1));
    give_up->async_wait([weak = weak_from_this()](const boost::system::error_code& ec) {
      if (auto self = weak.lock(); self && !ec) self->cut("no answer to close");
    });
    asio::co_spawn(
        ws_.get_executor(),
        [self = shared_from_this(), code, why = std::string(reason), give_up]() -> awaitable<void> {
          boost::system::error_code ec;
          co_await self->ws_.async_close(websocket::close_reason(code, why),
                                         asio::redirect_error(use_awaitable, ec));
          give_up->cancel();
          if (ec) self->cut("close failed");
        },
        asio::detached);
  }

  void stop_writer() {
    open_ = false;
    wake_.cancel();
  }

 private:
  Metrics& metrics_;
  websocket::stream<LiveStream> ws_;
  asio::steady_timer wake_;  // cancelled to wake the writer
  std::mutex queue_mutex_;
  std::deque<std::shared_ptr<const std::string>> queue_;  // guarded by queue_mutex_
  std::atomic<std::int64_t> owed_bytes_{0};
  std::atomic<int> owed_messages_{0};
  std::atomic<bool> overflowed_{false};
  bool open_ = true;
  bool closing_ = false;
  bool flooded_ = false;
  const std::int64_t queue_bytes_;
  const int queue_messages_;
};

void LiveSessions::add(const std::shared_ptr<LiveSocket>& session) {
  std::lock_guard lock(mutex_);
  std::erase_if(sessions_, [](const auto& weak) { return weak.expired(); });
  sessions_.push_back(session);
}

void LiveSessions::close_all() {
  std::lock_guard lock(mutex_);
  for (const auto& weak : sessions_) {
    if (auto session = weak.lock()) {
      asio::post(session->ws().get_executor(), [session] {
        session->close(websocket::close_code::going_away, "server shutting down");
      });
    }
  }
}

awaitable<void> serve_live(tcp::socket socket, Request upgrade, LiveConnection connection, App& app,
                           LiveSessions& sessions, asio::any_io_executor messages) {
  const Config& config = app.config();
  auto session = std::make_shared<LiveSocket>(std::move(socket), config, app.metrics());
  session->watch_reads();
  auto& ws = session->ws();
  // Beast pings a connection that has been silent for half the idle time and drops it when the
  // whole idle time passes without a frame (a pong counts).
  websocket::stream_base::timeout timeouts{};
  timeouts.handshake_timeout = std::chrono::milliseconds(config.live_handshake_timeout_ms);
  timeouts.idle_timeout = std::chrono::milliseconds(2ll * config.live_ping_interval_ms);
  timeouts.keep_alive_pings = true;
  ws.set_option(timeouts);
  ws.read_message_max(static_cast<std::size_t>(config.live_max_message_bytes));
  ws.set_option(websocket::stream_base::decorator(
      [](websocket::response_type& r) { r.set(http::field::server, "terrain-server"); }));
  boost::system::error_code ec;
  co_await ws.async_accept(upgrade, asio::redirect_error(use_awaitable, ec));
  if (ec) co_return;
  sessions.add(session);
  connection.self = session;
  app.metrics().live_connections.fetch_add(1);

  asio::co_spawn(ws.get_executor(), LiveSocket::write_loop(session), asio::detached);
  // The first message must be `subscribe`, and soon.
  asio::steady_timer subscribe_deadline(ws.get_executor());
  subscribe_deadline.expires_after(std::chrono::milliseconds(config.live_handshake_timeout_ms));
  subscribe_deadline.async_wait(
      [weak = std::weak_ptr<LiveSocket>(session)](const boost::system::error_code& waited) {
        if (waited) return;
        if (auto s = weak.lock(); s && !s->subscribed) {
          s->close(websocket::close_code::policy_error, "no subscribe in time");
        }
      });

  beast::flat_buffer buffer;
  while (true) {
    co_await ws.async_read(buffer, asio::redirect_error(use_awaitable, ec));
    if (ec) break;
    session->meter().message_done();
    if (!ws.got_text()) {
      connection.self->deliver(std::make_shared<const std::string>(
          R"({"type":"error","status":400,"title":"Invalid message","detail":"messages are JSON text frames"})"));
    } else {
      const auto data = buffer.cdata();
      const std::string_view text(static_cast<const char*>(data.data()), data.size());
      // The reader waits for it, so that the buffer, the connection and the order of messages
      // stay this coroutine's.
      co_await asio::co_spawn(
          messages,
          [&]() -> awaitable<void> {
            app.live_message(connection, text);
            co_return;
          },
          use_awaitable);
      session->subscribed = connection.subscribed;
    }
    buffer.consume(buffer.size());
  }
  subscribe_deadline.cancel();
  if (ec == websocket::error::message_too_big || session->flooded()) {
    app.metrics().live_oversize.fetch_add(1);
  }
  if (session->overflowed()) app.metrics().live_slow_readers.fetch_add(1);
  app.live_close(connection);
  session->stop_writer();
  app.metrics().live_connections.fetch_sub(1);
}

}  // namespace server
