// Session I/O of live channels (docs/live.md): the WebSocket after an upgrade request, a
// reader and a writer coroutine, and the bounded outgoing queue behind LiveSubscriber.
#pragma once

#include <list>
#include <memory>
#include <mutex>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/awaitable.hpp>
#include <boost/asio/ip/tcp.hpp>

#include "server/app.hpp"

namespace server {

class LiveSocket;

/// The live connections of a server, so that a shutdown can close them. Thread-safe.
class LiveSessions {
 public:
  void add(const std::shared_ptr<LiveSocket>& session);
  /// Closes every live connection with 1001 (going away), each on its own thread.
  void close_all();

 private:
  std::mutex mutex_;
  std::list<std::weak_ptr<LiveSocket>> sessions_;
};

/// Serves a live channel on `socket`, whose upgrade request `upgrade` App::live_open accepted
/// as `connection`: completes the WebSocket handshake, then runs until either side closes.
/// Messages are handled on `messages` (an edit parses and compiles a scene version, decoding
/// its images: work kept off the I/O threads), one at a time per connection, in order.
boost::asio::awaitable<void> serve_live(boost::asio::ip::tcp::socket socket, Request upgrade,
                                        LiveConnection connection, App& app, LiveSessions& sessions,
                                        boost::asio::any_io_executor messages);

}  // namespace server
