#include "server/net.hpp"

#include <sys/resource.h>
#include <sys/sendfile.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>

#include "deadline.hpp"
#include "live_socket.hpp"
#include "server/admission.hpp"
#include "server/log.hpp"

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket/rfc6455.hpp>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <iostream>
#include <list>
#include <mutex>
#include <optional>
#include <stop_token>
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

// Connections served at once: the configured cap, kept under half the descriptors this process
// may open (cached products hold a descriptor each, server/sealed_file.hpp).
int connection_cap(int configured) {
  rlimit files{};
  if (::getrlimit(RLIMIT_NOFILE, &files) != 0 || files.rlim_cur == RLIM_INFINITY) {
    return configured;
  }
  const auto half = static_cast<long long>(files.rlim_cur / 2);
  return static_cast<int>(std::max(1LL, std::min<long long>(configured, half)));
}

// What a connection beyond the cap is told before it is closed: written with one non-blocking
// send, as nothing of the connection is read or kept.
const std::string& too_many_connections() {
  static const std::string text = [] {
    const std::string body = R"({"type":"about:blank","title":"Too many connections","status":503,)"
                             R"("detail":"the server is at its connection limit; retry shortly"})";
    return "HTTP/1.1 503 Service Unavailable\r\nServer: terrain-server\r\nRetry-After: 1\r\n"
           "Content-Type: application/problem+json\r\nConnection: close\r\nContent-Length: " +
           std::to_string(body.size()) + "\r\n\r\n" + body;
  }();
  return text;
}

// Accept failures that mean "out of descriptors or memory": retrying at once would spin.
bool resource_exhausted(const boost::system::error_code& ec) {
  return ec == asio::error::no_descriptors || ec == asio::error::no_buffer_space ||
         ec == asio::error::no_memory || ec.value() == ENFILE;
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
    // Every HTTP connection's stream: closed when the shutdown's grace period is over.
    std::list<std::weak_ptr<tcp::socket>> open;
  };

  // Pictures (render.png, depth.bin) render on threads of their own at the lowest CPU
  // priority (nice 19): the kernel gives the cores to tiles first, so a burst of pictures never
  // holds a tile back, and a picture is never stuck in the queue behind tiles either.
  struct PicturePool {
    asio::io_context io;
    asio::executor_work_guard<asio::io_context::executor_type> keep_running{io.get_executor()};
    std::vector<std::thread> threads;

    explicit PicturePool(unsigned n) {
      for (unsigned i = 0; i < n; ++i) {
        threads.emplace_back([this] {
          // Linux gives each thread a nice value of its own; failing that, it runs at normal
          // priority (best effort, nothing to act on).
          ::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 19);
          io.run();
        });
      }
    }
    void join() {
      keep_running.reset();
      for (std::thread& t : threads) t.join();
      threads.clear();
    }
    ~PicturePool() {
      if (!threads.empty()) {
        io.stop();
        join();
      }
    }
  };

  App& app;
  Config config;
  std::vector<std::unique_ptr<Worker>> workers;
  asio::thread_pool generation;
  PicturePool pictures;
  // Live messages: an edit parses and compiles a version (docs/live.md); apart from the tiles'
  // queue, so that edits are not held behind tiles.
  asio::thread_pool live_messages{2};
  tcp::acceptor acceptor;  // on workers[0], which runs the accept loop and closes it
  std::atomic<bool> stopping{false};
  std::size_t next_worker = 0;
  LiveSessions live_sessions;
  const int max_connections;
  std::atomic<int> connections{0};  // HTTP and live, accepted and not yet closed
  std::atomic<int> pictures_queued{0};
  BodyBudget bodies;
  LogRate log_rate;
  // Shutdown: once the grace period has passed, every connection still open is closed.
  std::mutex shutdown_mutex;
  std::condition_variable_any shutdown_wake;
  bool shutting_down = false;  // guarded by shutdown_mutex

  // Closes the streams of a worker's list that are still open (on the worker's thread).
  static void close_streams(const std::list<std::weak_ptr<tcp::socket>>& streams) {
    for (const auto& weak : streams) {
      if (auto stream = weak.lock()) {
        boost::system::error_code ignored;
        stream->close(ignored);
      }
    }
  }

  // Runs for the life of run(): once stop() is called, waits out the grace period, then closes
  // every HTTP connection still open (each on its worker's thread).
  void close_after_grace(std::stop_token stop) {
    std::unique_lock lock(shutdown_mutex);
    if (!shutdown_wake.wait(lock, stop, [this] { return shutting_down; })) return;
    shutdown_wake.wait_for(lock, stop, std::chrono::milliseconds(config.shutdown_timeout_ms),
                           [] { return false; });
    if (stop.stop_requested()) return;
    log(LogLevel::info, "shutdown grace period over", {{"ms", config.shutdown_timeout_ms}});
    for (auto& worker : workers) {
      asio::post(worker->io, [w = worker.get()] { close_streams(w->open); });
    }
  }

  State(App& a, const Config& c)
      : app(a),
        config(c),
        workers(make_workers(thread_count(c.io_threads))),
        generation(thread_count(c.generation_threads)),
        pictures(thread_count(c.picture_threads)),
        acceptor(workers[0]->io),
        max_connections(connection_cap(c.max_connections)),
        bodies(c.bodies_in_flight_bytes),
        log_rate(c.log_requests_per_second) {}

  static std::vector<std::unique_ptr<Worker>> make_workers(unsigned n) {
    std::vector<std::unique_ptr<Worker>> made;
    for (unsigned i = 0; i < n; ++i) made.push_back(std::make_unique<Worker>());
    return made;
  }

  // Counts a connection for its whole life, live channel included.
  struct Counted {
    explicit Counted(std::atomic<int>& n) : count(n) {}
    ~Counted() { count.fetch_sub(1); }
    Counted(const Counted&) = delete;
    Counted& operator=(const Counted&) = delete;
    std::atomic<int>& count;
  };

  awaitable<void> accept_loop() {
    asio::steady_timer backoff(workers[0]->io);
    while (!stopping) {
      boost::system::error_code ec;
      Worker& worker = *workers[next_worker];
      next_worker = (next_worker + 1) % workers.size();
      tcp::socket socket =
          co_await acceptor.async_accept(worker.io, asio::redirect_error(use_awaitable, ec));
      if (ec) {
        if (stopping || ec == asio::error::operation_aborted) break;
        if (resource_exhausted(ec)) {
          // Out of descriptors: the pending connection stays in the backlog, so accepting again
          // at once fails again and spins. Wait for connections to close instead.
          app.metrics().accept_backoffs.fetch_add(1);
          backoff.expires_after(std::chrono::milliseconds(50));
          co_await backoff.async_wait(asio::redirect_error(use_awaitable, ec));
        }
        continue;
      }
      if (connections.load() >= max_connections) {
        app.metrics().refused_connections.fetch_add(1);
        boost::system::error_code ignored;
        const std::string& refusal = too_many_connections();
        const ssize_t sent = ::send(socket.native_handle(), refusal.data(), refusal.size(),
                                    MSG_DONTWAIT | MSG_NOSIGNAL);
        (void)sent;  // a client that cannot take it now gets the close alone
        socket.shutdown(tcp::socket::shutdown_both, ignored);
        socket.close(ignored);
        continue;
      }
      connections.fetch_add(1);
      // Without TCP_NODELAY, Nagle's algorithm holds a body's last, partial segment until the
      // segment before it is acknowledged, and the client may delay that ACK by 40 ms, all that
      // time the connection idles (docs/performance.md). nginx sets it too. Headers still leave
      // with their body (MSG_MORE, one gather write). Best effort: no error to act on.
      boost::system::error_code unset;
      socket.set_option(tcp::no_delay(true), unset);
      asio::co_spawn(worker.io, session(std::move(socket), worker), asio::detached);
    }
  }

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

  // Sets `abandoned` when the client hangs up while its request is worked on: a readable socket
  // whose next byte is the end of the stream (or an error). A client that sends its next
  // request meanwhile (pipelining) is not watched any further.
  static void watch_for_hangup(const std::shared_ptr<tcp::socket>& stream,
                               std::shared_ptr<std::atomic<bool>> abandoned) {
    stream->async_wait(tcp::socket::wait_read, [weak = std::weak_ptr<tcp::socket>(stream),
                                                abandoned = std::move(abandoned)](
                                                   const boost::system::error_code& ec) {
      if (ec == asio::error::operation_aborted) return;
      const auto socket = weak.lock();
      if (!socket) return;
      char byte = 0;
      const ssize_t n = ::recv(socket->native_handle(), &byte, 1, MSG_PEEK | MSG_DONTWAIT);
      if (ec || n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
        abandoned->store(true);
      }
    });
  }

  // Runs Deferred work on its pool, within its lane's queue limit; this coroutine resumes on the
  // connection's context. Work whose client has gone is skipped if it has not started. Nullopt:
  // the work prepared the request (Deferred::prepare), which is to be handled again.
  awaitable<std::optional<Response>> run_deferred(const std::shared_ptr<tcp::socket>& stream,
                                                  const Request& request, Deferred& work) {
    const bool picture = work.lane == Deferred::Lane::picture;
    std::atomic<int>& queued = picture ? pictures_queued : app.metrics().queued;
    const int limit = picture ? config.picture_queue_limit : config.queue_limit;
    if (queued.fetch_add(1) >= limit) {
      queued.fetch_sub(1);
      app.metrics().rejected.fetch_add(1);
      Response busy = problem(request, http::status::service_unavailable, "Busy",
                              picture ? "too many pictures are waiting; retry shortly"
                                      : "the generation queue is full; retry shortly");
      busy.set(http::field::retry_after, "1");
      co_return busy;
    }
    watch_for_hangup(stream, work.abandoned);
    std::optional<Response> response;
    std::exception_ptr failure;
    try {
      auto task = [work = &work,
                   abandoned = work.abandoned]() -> awaitable<std::optional<Response>> {
        if (abandoned->load()) co_return Response{http::status::service_unavailable, 11};
        if (work->prepare) co_return work->prepare();
        co_return work->work();
      };
      // Two statements, not one conditional expression: GCC 12 destroys the temporaries of a
      // co_await inside ?: twice.
      if (picture) {
        response = co_await asio::co_spawn(pictures.io, task, use_awaitable);
      } else {
        response = co_await asio::co_spawn(generation, task, use_awaitable);
      }
    } catch (...) {
      failure = std::current_exception();
    }
    queued.fetch_sub(1);
    if (work.abandoned->load()) app.metrics().abandoned.fetch_add(1);
    boost::system::error_code ignored;
    stream->cancel(ignored);  // ends the hang-up watch: nothing else is pending on the socket
    if (failure) {
      std::string what = "generation failed";
      try {
        std::rethrow_exception(failure);
      } catch (const std::exception& e) {
        what = e.what();
      } catch (...) {
      }
      response = problem(request, http::status::internal_server_error, "Internal error", what);
    }
    co_return response;
  }

  // The answer to a request that could not be read: there is no method, target or Origin to
  // answer by, and the connection closes after it.
  static Response unreadable(http::status status, std::string_view title, std::string_view detail) {
    Request bare{http::verb::get, "/", 11};
    bare.keep_alive(false);
    return problem(bare, status, title, detail);
  }

  // Answers a request that is refused before its body is read, and closes (the unread body
  // would otherwise be read as the next request).
  awaitable<void> refuse(tcp::socket& socket, Deadline& deadline, const Request& request,
                         Response response) {
    app.add_cors(request, response);
    response.keep_alive(false);
    app.metrics().request(App::route_label(request), static_cast<int>(response.result_int()), 0.0);
    co_await write(socket, deadline, response);
  }

  void log_request(const Request& request, std::string_view route, int status, double seconds) {
    if (!log_enabled(LogLevel::info)) return;
    std::int64_t dropped = 0;
    // Server errors are always written; the rest at most log.requests_per_second a second.
    const bool admitted =
        log_rate.admit(std::chrono::steady_clock::now(), dropped) || status >= 500;
    if (dropped > 0) {
      log(LogLevel::info, "requests not logged",
          {{"count", dropped}, {"limit_per_second", config.log_requests_per_second}});
    }
    if (!admitted) return;
    log(LogLevel::info, "request",
        {{"method", std::string(request.method_string())},
         {"target",
          escape_invalid_utf8(std::string_view(request.target().data(), request.target().size()))},
         {"route", std::string(route)},
         {"status", status},
         {"ms", std::round(seconds * 1e5) / 100.0}});
  }

  // One HTTP connection: its stream, read buffer and deadline, and its places in the worker's
  // lists of open and idle streams, which it leaves when it ends (or turns into a live channel).
  class Connection {
   public:
    Connection(tcp::socket accepted, Worker& worker, std::chrono::milliseconds horizon)
        : stream(std::make_shared<tcp::socket>(std::move(accepted))),
          deadline(stream, horizon),
          worker_(worker),
          open_(worker.open.insert(worker.open.begin(), stream)),
          idle_(worker.idle.end()) {
      set_idle(true);
    }
    ~Connection() {
      set_idle(false);
      if (!left_http_) worker_.open.erase(open_);
      boost::system::error_code ignored;
      stream->shutdown(tcp::socket::shutdown_send, ignored);
      stream->close(ignored);
    }
    Connection(const Connection&) = delete;
    Connection& operator=(const Connection&) = delete;

    // Idle (waiting for a request) connections are closed at once by a shutdown; busy ones get
    // the grace period. Only this worker's thread touches its lists.
    void set_idle(bool is_idle) {
      if (idle_ != worker_.idle.end()) worker_.idle.erase(idle_);
      idle_ = is_idle ? worker_.idle.insert(worker_.idle.begin(), stream) : worker_.idle.end();
    }
    // The stream leaves HTTP for a live channel, which closes itself at shutdown.
    void leave_http() {
      set_idle(false);
      worker_.open.erase(open_);
      left_http_ = true;
    }

    std::shared_ptr<tcp::socket> stream;
    beast::flat_buffer buffer;
    Deadline deadline;
    bool first_request = true;

   private:
    Worker& worker_;
    std::list<std::weak_ptr<tcp::socket>>::iterator open_;
    std::list<std::weak_ptr<tcp::socket>>::iterator idle_;
    bool left_http_ = false;
  };

  // The answer owed to a header that could not be read; none when the client left or idled out
  // without sending a byte.
  std::optional<Response> unread_header_answer(const boost::system::error_code& ec, bool timed_out,
                                               bool had_bytes) const {
    if (timed_out) {
      if (stopping || !had_bytes) return std::nullopt;
      return unreadable(http::status::request_timeout, "Request timeout",
                        "the request header did not arrive in time");
    }
    if (ec == http::error::header_limit) {
      return unreadable(
          http::status::request_header_fields_too_large, "Header too large",
          "request headers are limited to " + std::to_string(config.header_limit) + " bytes");
    }
    if (ec == http::error::end_of_stream || ec == asio::error::operation_aborted ||
        ec == asio::error::eof || ec == asio::error::connection_reset ||
        ec == asio::error::bad_descriptor) {
      return std::nullopt;
    }
    return unreadable(http::status::bad_request, "Malformed request", ec.message());
  }

  // The answer owed to a body that could not be read; none when the client went away.
  static std::optional<Response> unread_body_answer(const boost::system::error_code& ec,
                                                    bool timed_out, std::int64_t limit) {
    if (ec == http::error::body_limit) {
      return unreadable(http::status::payload_too_large, "Body too large",
                        "this route accepts at most " + std::to_string(limit) + " bytes");
    }
    if (timed_out) {
      return unreadable(http::status::request_timeout, "Request timeout",
                        "the request body did not arrive in time");
    }
    if (ec.category() == http::make_error_code(http::error::bad_target).category() &&
        ec != http::error::partial_message && ec != http::error::end_of_stream) {
      // A malformed body (bad chunk framing, say).
      return unreadable(http::status::bad_request, "Malformed request", ec.message());
    }
    return std::nullopt;
  }

  // Turns the connection into a live channel (docs/live.md), or answers why not.
  awaitable<void> open_live(Connection& c, http::request_parser<http::empty_body>& parser,
                            std::chrono::steady_clock::time_point started) {
    Request upgrade(std::move(parser.release().base()));
    auto opened = app.live_open(upgrade);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (!opened) {
      Response refusal = std::move(opened).error();
      app.add_cors(upgrade, refusal);
      refusal.keep_alive(false);
      refusal.content_length(refusal.body().size());
      app.metrics().request("live", static_cast<int>(refusal.result_int()), seconds);
      co_await write(*c.stream, c.deadline, refusal);
      co_return;
    }
    app.metrics().request("live", 101, seconds);
    if (stopping) co_return;
    c.leave_http();
    co_await serve_live(std::move(*c.stream), std::move(upgrade), std::move(opened).value(), app,
                        live_sessions, live_messages.get_executor());
  }

  // Why a request may not send its body, decided before a byte of it is read: a route that takes
  // none, the write token, the route's limit, and room among all the bodies being received (a
  // client without a token pins no memory). Reserves the room when it may.
  std::optional<Response> refuse_body(const Request& request, const App::BodyPolicy& policy,
                                      boost::optional<std::uint64_t> declared,
                                      BodyBudget::Reservation& room) {
    if (policy.limit == 0) {
      // The route takes no body: its answer (a 404 or 405, say) if it has one.
      Outcome outcome = app.handle(request);
      if (auto* response = std::get_if<Response>(&outcome)) return std::move(*response);
      return problem(request, http::status::bad_request, "Unexpected body",
                     "this route takes no request body");
    }
    if (policy.write) {
      if (Response auth = app.authorize(request); auth.result() != http::status::ok) return auth;
    }
    if (declared && static_cast<std::int64_t>(*declared) > policy.limit) {
      return problem(request, http::status::payload_too_large, "Body too large",
                     "this route accepts at most " + std::to_string(policy.limit) + " bytes");
    }
    room = bodies.reserve(declared ? static_cast<std::int64_t>(*declared) : policy.limit);
    if (!room) {
      Response busy = problem(request, http::status::service_unavailable, "Busy",
                              "the server is receiving as many request bodies as it may (" +
                                  std::to_string(bodies.limit()) + " bytes); retry shortly");
      busy.set(http::field::retry_after, "1");
      return busy;
    }
    return std::nullopt;
  }

  // Why a request is answered before its body is read, if it is: framing that could smuggle a
  // request, then refuse_body's reasons. The answer goes with the header as a request.
  struct Refusal {
    Request request;
    Response response;
  };
  std::optional<Refusal> refuse_early(const http::request_parser<http::empty_body>& header,
                                      const App::BodyPolicy& policy,
                                      BodyBudget::Reservation& room) {
    if (const auto framing = check_framing(header.get())) {
      Request request(header.get().base());
      Response response = problem(request, framing->status, "Bad framing", framing->detail,
                                  "/headers/transfer-encoding");
      return Refusal{std::move(request), std::move(response)};
    }
    if (!header.chunked() && header.content_length().value_or(0) == 0) return std::nullopt;
    Request request(header.get().base());  // a copy, made only for a body
    if (auto refused = refuse_body(request, policy, header.content_length(), room)) {
      return Refusal{std::move(request), std::move(*refused)};
    }
    return std::nullopt;
  }

  // Reads a request's body within its deadline and limit; false when the connection is to close
  // (after the answer owed).
  awaitable<bool> read_body(Connection& c, http::request_parser<http::string_body>& parser,
                            std::int64_t limit) {
    boost::system::error_code ec;
    c.deadline.arm(config.body_timeout_ms, Deadline::Expiry::shut_receive);
    co_await http::async_read(*c.stream, c.buffer, parser, asio::redirect_error(use_awaitable, ec));
    const bool timed_out = c.deadline.expired();
    c.deadline.disarm();
    if (!ec) co_return true;
    if (auto owed = unread_body_answer(ec, timed_out, limit)) {
      co_await write(*c.stream, c.deadline, *owed);
    }
    co_return false;
  }

  // The answer of a request whose handling was deferred (a tile to make, a version to load):
  // the work runs on its pool, and a request whose version it loaded is handled again.
  awaitable<Response> answer_deferred(const std::shared_ptr<tcp::socket>& stream,
                                      const Request& request, Outcome outcome) {
    for (int pass = 0;; ++pass) {
      if (auto* done = std::get_if<Response>(&outcome)) co_return std::move(*done);
      Deferred& work = std::get<Deferred>(outcome);
      std::optional<Response> made = co_await run_deferred(stream, request, work);
      if (made) co_return std::move(*made);
      // Prepared, but its client hung up meanwhile (run_deferred counted it): the work the
      // request was loaded for is not started at all.
      if (work.abandoned->load()) co_return Response{http::status::service_unavailable, 11};
      // Prepared (its version loaded): handled again, now without loading. Twice at most, so
      // that a version evicted meanwhile cannot keep a request going round.
      if (pass == 1) {
        Response busy = problem(request, http::status::service_unavailable, "Busy",
                                "the scene version could not be kept loaded; retry shortly");
        busy.set(http::field::retry_after, "1");
        co_return busy;
      }
      outcome = app.handle(request);
    }
  }

  // What every handled answer gets before it is written: CORS (only here), the framing a
  // keep-alive client needs, HEAD's empty body, and whether the connection stays open.
  void finish(const Request& request, Response& response) const {
    app.add_cors(request, response);
    const auto code = response.result_int();
    if (!response.has_content_length() && code != 204 && code != 304 && code >= 200) {
      response.content_length(response.body().size());
    }
    if (request.method() == http::verb::head) {
      const auto length = response.body().size();
      response.body().clear();
      response.content_length(length);
    }
    response.keep_alive(response.keep_alive() && !stopping);
  }

  awaitable<void> session(tcp::socket accepted, Worker& worker) {
    const Counted counted(connections);
    Connection c(
        std::move(accepted), worker,
        std::chrono::milliseconds(std::min({config.header_timeout_ms, config.idle_timeout_ms,
                                            config.body_timeout_ms, config.request_timeout_ms})));
    // A cached answer's whole path stays in this coroutine: only bodies, deferred work and
    // writes await other coroutines (each costs a frame; three more per request were 5 % of
    // bench/http_bench.sh's cached throughput).
    while (!stopping) {
      http::request_parser<http::empty_body> header;
      header.header_limit(static_cast<std::uint32_t>(config.header_limit));
      // The route's body limit is checked once the target is known; the parser's default (1 MiB)
      // would refuse larger declared bodies as malformed before that.
      header.body_limit(boost::none);
      boost::system::error_code ec;
      c.deadline.arm(c.first_request ? config.header_timeout_ms : config.idle_timeout_ms,
                     Deadline::Expiry::shut_receive);
      co_await http::async_read_header(*c.stream, c.buffer, header,
                                       asio::redirect_error(use_awaitable, ec));
      const bool timed_out = c.deadline.expired();
      c.deadline.disarm();
      if (ec) {
        if (auto owed = unread_header_answer(ec, timed_out, c.buffer.size() > 0)) {
          co_await write(*c.stream, c.deadline, *owed);
        }
        break;
      }
      const auto started = std::chrono::steady_clock::now();
      c.first_request = false;
      c.set_idle(false);  // busy: not closed by a shutdown
      const std::string_view target(header.get().target().data(), header.get().target().size());
      if (beast::websocket::is_upgrade(header.get()) && App::is_live_target(target)) {
        co_await open_live(c, header, started);
        co_return;
      }
      const App::BodyPolicy policy = app.body_policy(header.get().method(), target);
      BodyBudget::Reservation room;  // held until the answer is written
      if (std::optional<Refusal> refusal = refuse_early(header, policy, room)) {
        co_await refuse(*c.stream, c.deadline, refusal->request, std::move(refusal->response));
        break;
      }
      http::request_parser<http::string_body> parser(std::move(header));
      parser.body_limit(static_cast<std::uint64_t>(std::max<std::int64_t>(policy.limit, 0)));
      // Most requests (GETs) have no body and need no second read.
      if (!parser.is_done() && !co_await read_body(c, parser, policy.limit)) break;
      const Request request = parser.release();
      Outcome outcome = app.handle(request);
      Response response;
      if (auto* done = std::get_if<Response>(&outcome)) {
        response = std::move(*done);
      } else {
        response = co_await answer_deferred(c.stream, request, std::move(outcome));
      }
      finish(request, response);
      const int status = static_cast<int>(response.result_int());
      // Counted before the write: a client that has its answer finds it in /metrics.
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      const std::string_view route = App::route_label(request);
      app.metrics().request(route, status, seconds);
      co_await write(*c.stream, c.deadline, response);
      log_request(request, route, status, seconds);
      if (!response.keep_alive()) break;
      c.set_idle(true);
    }
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
  std::jthread closer([s = state_.get()](std::stop_token stop) { s->close_after_grace(stop); });
  std::vector<std::thread> threads;
  for (std::size_t i = 1; i < workers.size(); ++i) {
    threads.emplace_back([&worker = *workers[i]] { worker.io.run(); });
  }
  workers[0]->io.run();
  for (std::thread& t : threads) t.join();
  state_->generation.join();
  state_->pictures.join();
  state_->live_messages.join();
  closer.request_stop();  // everything has drained: no grace period left to wait out
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
      State::close_streams(w->idle);
      w->keep_running.reset();  // run() returns once the sessions in flight have finished
    });
  }
  // In-flight requests get a grace period (close_after_grace); a client that does not read its
  // answer does not hold the shutdown for the whole write timeout.
  {
    std::lock_guard lock(s->shutdown_mutex);
    s->shutting_down = true;
  }
  s->shutdown_wake.notify_all();
}

}  // namespace server
