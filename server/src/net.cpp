#include "server/net.hpp"

#include <sys/sendfile.h>
#include <sys/socket.h>

#include <cerrno>
#include <cmath>
#include <csignal>

#include "live_socket.hpp"
#include "server/log.hpp"

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket/rfc6455.hpp>

#include <algorithm>
#include <chrono>
#include <iostream>
#include <list>
#include <thread>

namespace server {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
using tcp = asio::ip::tcp;
using asio::awaitable;
using asio::use_awaitable;

// The status line and header fields of a response as Beast's serializer writes them. Bodies are
// never chunked here: every response carries its Content-Length (or has no body).
std::string wire_header(const Response& response) {
  BOOST_ASSERT(!response.chunked());
  std::string out;
  out.reserve(384);
  out += response.version() == 10 ? "HTTP/1.0 " : "HTTP/1.1 ";
  out += std::to_string(response.result_int());
  out += ' ';
  out.append(response.reason().data(), response.reason().size());
  out += "\r\n";
  for (const auto& field : response) {
    out.append(field.name_string().data(), field.name_string().size());
    out += ": ";
    out.append(field.value().data(), field.value().size());
    out += "\r\n";
  }
  out += "\r\n";
  return out;
}

unsigned thread_count(int configured) {
  return configured > 0 ? static_cast<unsigned>(configured)
                        : std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace

struct HttpServer::State {
  // One io_context per I/O thread. A connection lives on one of them for its whole life, so its
  // session, its deadlines and a shutdown's close run on one thread: no strands, no locks, and
  // each context's scheduler and reactor are touched by their own thread alone.
  struct Worker {
    asio::io_context io{1};
    asio::executor_work_guard<asio::io_context::executor_type> keep_running{io.get_executor()};
    // Streams of connections waiting for a request: closed at shutdown so they end at once.
    std::list<std::weak_ptr<tcp::socket>> idle;
  };

  App& app;
  Config config;
  std::vector<std::unique_ptr<Worker>> workers;
  asio::thread_pool generation;
  tcp::acceptor acceptor;  // on workers[0], which runs the accept loop and closes it
  std::atomic<bool> stopping{false};
  std::size_t next_worker = 0;
  LiveSessions live_sessions;

  State(App& a, const Config& c)
      : app(a),
        config(c),
        workers(make_workers(thread_count(c.io_threads))),
        generation(thread_count(c.generation_threads)),
        acceptor(workers[0]->io) {}

  static std::vector<std::unique_ptr<Worker>> make_workers(unsigned n) {
    std::vector<std::unique_ptr<Worker>> made;
    for (unsigned i = 0; i < n; ++i) made.push_back(std::make_unique<Worker>());
    return made;
  }

  awaitable<void> accept_loop() {
    while (!stopping) {
      boost::system::error_code ec;
      Worker& worker = *workers[next_worker];
      next_worker = (next_worker + 1) % workers.size();
      tcp::socket socket =
          co_await acceptor.async_accept(worker.io, asio::redirect_error(use_awaitable, ec));
      if (ec) {
        if (stopping || ec == asio::error::operation_aborted) break;
        continue;  // e.g. too many open files: keep serving the others
      }
      // Without TCP_NODELAY, Nagle's algorithm holds a body's last, partial segment until the
      // segment before it is acknowledged, and the client may delay that ACK by 40 ms, all that
      // time the connection idles (docs/performance.md). nginx sets it too. Headers still leave
      // with their body (MSG_MORE, one gather write). Best effort: no error to act on.
      boost::system::error_code unset;
      socket.set_option(tcp::no_delay(true), unset);
      asio::co_spawn(worker.io, session(std::move(socket), worker), asio::detached);
    }
  }

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
      asio::steady_timer timer;
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

  // Writes a response: the status line and fields, then the body, in one gather write. The
  // header bytes are what Beast's serializer would write; a shared body (a cached tile) goes
  // out without a copy.
  awaitable<void> write(tcp::socket& socket, Deadline& deadline, const Response& response) {
    const std::string header = wire_header(response);
    deadline.arm(config.request_timeout_ms, Deadline::Expiry::close);
    boost::system::error_code ec;
    if (const SealedFile* file = response.body().file()) {
      co_await send_file(socket, header, *file, ec);
    } else {
      const std::array<asio::const_buffer, 2> buffers = {
          asio::buffer(header), asio::buffer(response.body().data(), response.body().size())};
      co_await asio::async_write(socket, buffers, asio::redirect_error(use_awaitable, ec));
    }
    deadline.disarm();
  }

  // The header, then the body straight from its sealed file with sendfile(2): the kernel takes
  // the file's pages instead of a copy of the bytes, as nginx does for static files. The header
  // goes with MSG_MORE so that it leaves in one segment with the start of the body.
  static awaitable<void> send_file(tcp::socket& socket, const std::string& header,
                                   const SealedFile& file, boost::system::error_code& ec) {
    // Setting the mode is a system call each time; Asio's own reads have usually set it.
    if (!socket.native_non_blocking()) socket.native_non_blocking(true, ec);
    if (ec) co_return;
    std::size_t sent = 0;
    while (sent < header.size()) {
      const ssize_t n = ::send(socket.native_handle(), header.data() + sent, header.size() - sent,
                               MSG_MORE | MSG_NOSIGNAL);
      if (n >= 0) {
        sent += static_cast<std::size_t>(n);
      } else if (errno == EAGAIN || errno == EWOULDBLOCK) {
        co_await socket.async_wait(tcp::socket::wait_write,
                                   asio::redirect_error(use_awaitable, ec));
        if (ec) co_return;
      } else if (errno != EINTR) {
        ec = boost::system::error_code(errno, boost::system::system_category());
        co_return;
      }
    }
    off_t offset = 0;
    while (static_cast<std::size_t>(offset) < file.size()) {
      const ssize_t n = ::sendfile(socket.native_handle(), file.descriptor(), &offset,
                                   file.size() - static_cast<std::size_t>(offset));
      if (n > 0) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        co_await socket.async_wait(tcp::socket::wait_write,
                                   asio::redirect_error(use_awaitable, ec));
        if (ec) co_return;
      } else if (n < 0 && errno == EINTR) {
        continue;
      } else {
        ec = n == 0 ? asio::error::eof
                    : boost::system::error_code(errno, boost::system::system_category());
        co_return;
      }
    }
  }

  awaitable<void> session(tcp::socket accepted, Worker& worker) {
    auto stream = std::make_shared<tcp::socket>(std::move(accepted));
    beast::flat_buffer buffer;
    Deadline deadline(stream, std::chrono::milliseconds(
                                  std::min({config.header_timeout_ms, config.idle_timeout_ms,
                                            config.body_timeout_ms, config.request_timeout_ms})));
    // Only this worker's thread touches its idle list.
    auto registration = worker.idle.end();
    auto set_idle = [&](bool is_idle) {
      if (registration != worker.idle.end()) worker.idle.erase(registration);
      registration = is_idle ? worker.idle.insert(worker.idle.begin(), stream) : worker.idle.end();
    };
    set_idle(true);
    bool first = true;
    while (!stopping) {
      http::request_parser<http::empty_body> header_parser;
      header_parser.header_limit(static_cast<std::uint32_t>(config.header_limit));
      // The route's body limit is checked below, once the target is known; the parser's default
      // (1 MiB) would refuse larger declared bodies as malformed before that.
      header_parser.body_limit(boost::none);
      boost::system::error_code ec;
      deadline.arm(first ? config.header_timeout_ms : config.idle_timeout_ms,
                   Deadline::Expiry::shut_receive);
      co_await http::async_read_header(*stream, buffer, header_parser,
                                       asio::redirect_error(use_awaitable, ec));
      const bool header_timed_out = deadline.expired();
      deadline.disarm();
      const auto started = std::chrono::steady_clock::now();
      if (ec) {
        Request bare{http::verb::get, "/", 11};
        bare.keep_alive(false);
        if (header_timed_out && !stopping && buffer.size() > 0) {
          co_await write(*stream, deadline,
                         problem(bare, http::status::request_timeout, "Request timeout",
                                 "the request header did not arrive in time"));
        } else if (ec == http::error::header_limit) {
          co_await write(
              *stream, deadline,
              problem(bare, http::status::request_header_fields_too_large, "Header too large",
                      "request headers are limited to " + std::to_string(config.header_limit) +
                          " bytes"));
        } else if (!header_timed_out && ec != http::error::end_of_stream &&
                   ec != asio::error::operation_aborted && ec != asio::error::eof &&
                   ec != asio::error::connection_reset && ec != asio::error::bad_descriptor) {
          co_await write(
              *stream, deadline,
              problem(bare, http::status::bad_request, "Malformed request", ec.message()));
        }
        break;
      }
      first = false;
      set_idle(false);  // busy: not closed by a shutdown
      // Body limits depend on the route; refuse before reading a byte of an oversized body.
      const auto& header = header_parser.get();
      const std::string_view target(header.target().data(), header.target().size());
      if (beast::websocket::is_upgrade(header) && App::is_live_target(target)) {
        // A live channel: the connection leaves HTTP for good (docs/live.md).
        Request upgrade(std::move(header_parser.release().base()));
        auto opened = app.live_open(upgrade);
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        if (!opened) {
          Response refusal = std::move(opened).error();
          app.add_cors(upgrade, refusal);
          refusal.keep_alive(false);
          refusal.content_length(refusal.body().size());
          app.metrics().request("live", static_cast<int>(refusal.result_int()), seconds);
          co_await write(*stream, deadline, refusal);
          break;
        }
        app.metrics().request("live", 101, seconds);
        if (stopping) break;
        co_await serve_live(std::move(*stream), std::move(upgrade), std::move(opened).value(), app,
                            live_sessions);
        co_return;
      }
      const std::int64_t limit =
          target.starts_with("/api/v1/images") ? config.image_body_limit : config.scene_body_limit;
      const auto declared = header_parser.content_length();
      if (declared && static_cast<std::int64_t>(*declared) > limit) {
        Request bare{header.method(), header.target(), header.version()};
        bare.keep_alive(false);
        co_await write(*stream, deadline,
                       problem(bare, http::status::payload_too_large, "Body too large",
                               "this route accepts at most " + std::to_string(limit) + " bytes"));
        break;
      }
      http::request_parser<http::string_body> parser(std::move(header_parser));
      parser.body_limit(static_cast<std::uint64_t>(limit));
      if (!parser.is_done()) {  // most requests (GETs) have no body and need no second read
        deadline.arm(config.body_timeout_ms, Deadline::Expiry::shut_receive);
        co_await http::async_read(*stream, buffer, parser, asio::redirect_error(use_awaitable, ec));
        const bool body_timed_out = deadline.expired();
        deadline.disarm();
        if (ec) {
          Request bare{http::verb::get, "/", 11};
          bare.keep_alive(false);
          if (ec == http::error::body_limit) {
            co_await write(
                *stream, deadline,
                problem(bare, http::status::payload_too_large, "Body too large",
                        "this route accepts at most " + std::to_string(limit) + " bytes"));
          } else if (body_timed_out) {
            co_await write(*stream, deadline,
                           problem(bare, http::status::request_timeout, "Request timeout",
                                   "the request body did not arrive in time"));
          } else if (ec.category() == http::make_error_code(http::error::bad_target).category() &&
                     ec != http::error::partial_message && ec != http::error::end_of_stream) {
            // A malformed body (bad chunk framing, say); a client that went away gets nothing.
            co_await write(
                *stream, deadline,
                problem(bare, http::status::bad_request, "Malformed request", ec.message()));
          }
          break;
        }
      }
      Request request = parser.release();
      Outcome outcome = app.handle(request);
      Response response;
      if (Deferred* work = std::get_if<Deferred>(&outcome)) {
        if (app.metrics().queued.fetch_add(1) >= config.queue_limit) {
          app.metrics().queued.fetch_sub(1);
          app.metrics().rejected.fetch_add(1);
          response = problem(request, http::status::service_unavailable, "Busy",
                             "the generation queue is full; retry shortly");
          response.set(http::field::retry_after, "1");
        } else {
          // Work on the generation pool; this coroutine resumes on the connection's context.
          std::exception_ptr failure;
          try {
            response = co_await asio::co_spawn(
                generation, [work]() -> awaitable<Response> { co_return work->work(); },
                use_awaitable);
          } catch (...) {
            failure = std::current_exception();
          }
          app.metrics().queued.fetch_sub(1);
          if (failure) {
            std::string what = "generation failed";
            try {
              std::rethrow_exception(failure);
            } catch (const std::exception& e) {
              what = e.what();
            } catch (...) {
            }
            response =
                problem(request, http::status::internal_server_error, "Internal error", what);
          }
        }
        app.add_cors(request, response);
      } else {
        response = std::move(std::get<Response>(outcome));
      }
      const auto code = response.result_int();
      if (!response.has_content_length() && code != 204 && code != 304 && code >= 200) {
        response.content_length(response.body().size());  // the framing a keep-alive client needs
      }
      if (request.method() == http::verb::head) {
        const auto length = response.body().size();
        response.body().clear();
        response.content_length(length);
      }
      const bool keep_alive = response.keep_alive() && !stopping;
      response.keep_alive(keep_alive);
      const int status = static_cast<int>(response.result_int());
      // Counted before the write: a client that has its answer finds it in /metrics.
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      const std::string_view route = App::route_label(request);
      app.metrics().request(route, status, seconds);
      co_await write(*stream, deadline, response);
      if (log_enabled(LogLevel::info)) {
        log(LogLevel::info, "request",
            {{"method", std::string(request.method_string())},
             {"target", std::string(request.target())},
             {"route", std::string(route)},
             {"status", status},
             {"ms", std::round(seconds * 1e5) / 100.0}});
      }
      if (!keep_alive) break;
      set_idle(true);
    }
    set_idle(false);
    boost::system::error_code ignored;
    stream->shutdown(tcp::socket::shutdown_send, ignored);
    stream->close(ignored);
  }
};

HttpServer::HttpServer(App& app, const Config& config)
    : state_(std::make_unique<State>(app, config)) {}

HttpServer::~HttpServer() = default;

terrain::Result<int> HttpServer::listen() {
  boost::system::error_code ec;
  const auto address = asio::ip::make_address(state_->config.address, ec);
  if (ec) {
    return terrain::Error{"bad address '" + state_->config.address + "': " + ec.message(),
                          "/server.address"};
  }
  const tcp::endpoint endpoint(address, static_cast<unsigned short>(state_->config.port));
  auto& acceptor = state_->acceptor;
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    return terrain::Error{"cannot listen on " + state_->config.address + ":" +
                              std::to_string(state_->config.port) + ": " + ec.message(),
                          "/server.port"};
  }
  return static_cast<int>(acceptor.local_endpoint().port());
}

void HttpServer::run() {
  // sendfile(2) has no MSG_NOSIGNAL: a client that hangs up mid-body would raise SIGPIPE and
  // end the process. Broken pipes are errors of that one connection (EPIPE), nothing more.
  std::signal(SIGPIPE, SIG_IGN);
  auto& workers = state_->workers;
  asio::co_spawn(workers[0]->io, state_->accept_loop(), asio::detached);
  std::vector<std::thread> threads;
  for (std::size_t i = 1; i < workers.size(); ++i) {
    threads.emplace_back([&worker = *workers[i]] { worker.io.run(); });
  }
  workers[0]->io.run();
  for (std::thread& t : threads) t.join();
  state_->generation.join();
}

void HttpServer::stop() {
  State* s = state_.get();
  s->stopping = true;
  s->live_sessions.close_all();
  asio::post(s->workers[0]->io, [s] {
    boost::system::error_code ignored;
    s->acceptor.close(ignored);
  });
  for (auto& worker : s->workers) {
    // On the worker's own thread: its idle list and streams are touched there alone.
    asio::post(worker->io, [w = worker.get()] {
      for (auto& weak : w->idle) {
        if (auto stream = weak.lock()) {
          boost::system::error_code ignored;
          stream->close(ignored);
        }
      }
      w->keep_running.reset();  // run() returns once the sessions in flight have finished
    });
  }
}

}  // namespace server
