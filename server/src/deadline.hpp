#pragma once
// A connection's read and write deadlines, for the HTTP sessions of net.cpp.

#include <boost/asio.hpp>

#include <chrono>
#include <cstdint>
#include <memory>

namespace server {

// Deadlines for a connection. When a read's deadline passes, the receiving side is shut (the
// pending read ends, and so does any read started after it) so that a 408 can still be sent;
// when a write's passes, the socket is closed. The handler runs on the connection's thread,
// like the session.
//
// Arming only records when the deadline is due: cancelling and queueing the timer again for
// every read and write was about 8% of a cached answer's user-space work. A wait that ends
// early starts another, until the deadline is due or disarmed. No wait reaches further ahead
// than `horizon` (the shortest timeout), so a later arm, due at least that far ahead, never
// needs an earlier wake-up than the pending wait's.
class Deadline {
 public:
  using tcp = boost::asio::ip::tcp;
  enum class Expiry { shut_receive, close };

  Deadline(const std::shared_ptr<tcp::socket>& socket, std::chrono::milliseconds horizon)
      : state_(std::make_shared<State>(socket, horizon)) {}
  ~Deadline() {
    state_->ended = true;
    state_->timer.cancel();
  }
  Deadline(const Deadline&) = delete;
  Deadline& operator=(const Deadline&) = delete;

  void arm(int ms, Expiry expiry) {
    State& s = *state_;
    s.due = Clock::now() + std::chrono::milliseconds(ms);
    s.expiry = expiry;
    s.armed = true;
    s.expired = false;
    if (!s.waiting || s.timer.expiry() > s.due) wait(state_);
  }
  /// Ends the current deadline; a pending wait then lapses harmlessly.
  void disarm() { state_->armed = false; }
  bool expired() const { return state_->expired; }

 private:
  using Clock = std::chrono::steady_clock;
  struct State {
    State(const std::shared_ptr<tcp::socket>& s, std::chrono::milliseconds h)
        : timer(s->get_executor()), socket(s), horizon(h) {}
    boost::asio::steady_timer timer;
    std::weak_ptr<tcp::socket> socket;
    std::chrono::milliseconds horizon;
    Clock::time_point due{};
    Expiry expiry = Expiry::close;
    std::uint64_t wait_id = 0;  // the pending wait; an older one's end is ignored
    bool armed = false;
    bool expired = false;
    bool waiting = false;
    bool ended = false;  // the connection is gone: a queued wait's end does nothing
  };

  static void wait(const std::shared_ptr<State>& state) {
    State& s = *state;
    const std::uint64_t id = ++s.wait_id;
    s.waiting = true;
    s.timer.expires_at(std::min(s.due, Clock::now() + s.horizon));  // ends any pending wait
    s.timer.async_wait([state, id](const boost::system::error_code& ec) {
      State& now = *state;
      if (id != now.wait_id) return;  // superseded by a later wait
      now.waiting = false;
      if (ec || now.ended || !now.armed) return;
      if (Clock::now() < now.due) {
        wait(state);
        return;
      }
      now.expired = true;
      if (auto socket = now.socket.lock()) {
        boost::system::error_code ignored;
        if (now.expiry == Expiry::close) {
          socket->close(ignored);
        } else {
          socket->shutdown(tcp::socket::shutdown_receive, ignored);
        }
      }
    });
  }

  std::shared_ptr<State> state_;
};

}  // namespace server
