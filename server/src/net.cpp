#include "server/net.hpp"

#include <cmath>

#include "server/log.hpp"

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include <chrono>
#include <iostream>
#include <list>
#include <mutex>
#include <thread>

namespace server {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
using tcp = asio::ip::tcp;
using asio::awaitable;
using asio::use_awaitable;

unsigned thread_count(int configured) {
  return configured > 0 ? static_cast<unsigned>(configured)
                        : std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace

struct HttpServer::State {
  App& app;
  Config config;
  asio::io_context io;
  asio::thread_pool generation;
  tcp::acceptor acceptor{io};
  // The accept loop and the close at shutdown both run here: an acceptor is not thread-safe.
  asio::strand<asio::io_context::executor_type> accept_strand{asio::make_strand(io)};
  std::atomic<bool> stopping{false};
  std::mutex sessions_mutex;
  // Streams of connections waiting for a request: closed at shutdown so they end at once.
  std::list<std::weak_ptr<beast::tcp_stream>> idle;

  State(App& a, const Config& c)
      : app(a), config(c), generation(thread_count(c.generation_threads)) {}

  awaitable<void> accept_loop() {
    while (!stopping) {
      boost::system::error_code ec;
      // Each connection lives on a strand of its own: its session, its read deadlines and a
      // shutdown's close never run concurrently, whichever I/O thread picks them up.
      tcp::socket socket = co_await acceptor.async_accept(asio::make_strand(io),
                                                          asio::redirect_error(use_awaitable, ec));
      if (ec) {
        if (stopping || ec == asio::error::operation_aborted) break;
        continue;  // e.g. too many open files: keep serving the others
      }
      const auto executor = socket.get_executor();
      asio::co_spawn(executor, session(std::move(socket)), asio::detached);
    }
  }

  awaitable<void> write(beast::tcp_stream& stream, Response response) {
    stream.expires_after(std::chrono::milliseconds(config.request_timeout_ms));
    boost::system::error_code ec;
    co_await http::async_write(stream, response, asio::redirect_error(use_awaitable, ec));
  }

  // A deadline for reading a request. tcp_stream's own timeout closes the socket, which would
  // leave no way to answer 408; this one shuts the receiving side instead (the pending read ends,
  // and so does any read started after it), so the answer can still be sent. Its handler runs on
  // the connection's strand, like the session, and does nothing once the deadline is gone.
  class ReadDeadline {
   public:
    ReadDeadline(const std::shared_ptr<beast::tcp_stream>& stream, int ms)
        : timer_(stream->get_executor()), state_(std::make_shared<State>()) {
      timer_.expires_after(std::chrono::milliseconds(ms));
      timer_.async_wait([state = state_, weak = std::weak_ptr<beast::tcp_stream>(stream)](
                            const boost::system::error_code& ec) {
        if (ec || !state->active) return;
        state->expired = true;
        if (auto s = weak.lock()) {
          boost::system::error_code ignored;
          s->socket().shutdown(tcp::socket::shutdown_receive, ignored);
        }
      });
    }
    ~ReadDeadline() {
      state_->active = false;
      timer_.cancel();
    }
    ReadDeadline(const ReadDeadline&) = delete;
    ReadDeadline& operator=(const ReadDeadline&) = delete;
    bool expired() const { return state_->expired; }

   private:
    struct State {
      bool active = true;
      bool expired = false;
    };
    asio::steady_timer timer_;
    std::shared_ptr<State> state_;
  };

  awaitable<void> session(tcp::socket socket) {
    auto stream = std::make_shared<beast::tcp_stream>(std::move(socket));
    beast::flat_buffer buffer;
    std::list<std::weak_ptr<beast::tcp_stream>>::iterator registration;
    {
      std::lock_guard lock(sessions_mutex);
      idle.push_front(stream);
      registration = idle.begin();
    }
    auto unregister = [&] {
      std::lock_guard lock(sessions_mutex);
      if (registration != idle.end()) idle.erase(registration);
      registration = idle.end();
    };
    bool first = true;
    while (!stopping) {
      http::request_parser<http::empty_body> header_parser;
      header_parser.header_limit(static_cast<std::uint32_t>(config.header_limit));
      // The route's body limit is checked below, once the target is known; the parser's default
      // (1 MiB) would refuse larger declared bodies as malformed before that.
      header_parser.body_limit(boost::none);
      stream->expires_never();
      boost::system::error_code ec;
      bool header_timed_out = false;
      {
        const ReadDeadline deadline(stream,
                                    first ? config.header_timeout_ms : config.idle_timeout_ms);
        co_await http::async_read_header(*stream, buffer, header_parser,
                                         asio::redirect_error(use_awaitable, ec));
        header_timed_out = deadline.expired();
      }
      const auto started = std::chrono::steady_clock::now();
      if (ec) {
        Request bare{http::verb::get, "/", 11};
        bare.keep_alive(false);
        if (header_timed_out && !stopping && buffer.size() > 0) {
          co_await write(*stream, problem(bare, http::status::request_timeout, "Request timeout",
                                          "the request header did not arrive in time"));
        } else if (ec == http::error::header_limit) {
          co_await write(*stream, problem(bare, http::status::request_header_fields_too_large,
                                          "Header too large",
                                          "request headers are limited to " +
                                              std::to_string(config.header_limit) + " bytes"));
        } else if (!header_timed_out && ec != http::error::end_of_stream &&
                   ec != asio::error::operation_aborted && ec != asio::error::eof &&
                   ec != asio::error::connection_reset && ec != asio::error::bad_descriptor) {
          co_await write(
              *stream, problem(bare, http::status::bad_request, "Malformed request", ec.message()));
        }
        break;
      }
      first = false;
      {
        std::lock_guard lock(sessions_mutex);  // busy: not closed by a shutdown
        if (registration != idle.end()) idle.erase(registration);
        registration = idle.end();
      }
      // Body limits depend on the route; refuse before reading a byte of an oversized body.
      const auto& header = header_parser.get();
      const std::string_view target(header.target().data(), header.target().size());
      const std::int64_t limit =
          target.starts_with("/api/v1/images") ? config.image_body_limit : config.scene_body_limit;
      const auto declared = header_parser.content_length();
      if (declared && static_cast<std::int64_t>(*declared) > limit) {
        Request bare{header.method(), header.target(), header.version()};
        bare.keep_alive(false);
        co_await write(*stream,
                       problem(bare, http::status::payload_too_large, "Body too large",
                               "this route accepts at most " + std::to_string(limit) + " bytes"));
        break;
      }
      http::request_parser<http::string_body> parser(std::move(header_parser));
      parser.body_limit(static_cast<std::uint64_t>(limit));
      bool body_timed_out = false;
      {
        const ReadDeadline deadline(stream, config.body_timeout_ms);
        co_await http::async_read(*stream, buffer, parser, asio::redirect_error(use_awaitable, ec));
        body_timed_out = deadline.expired();
      }
      if (ec) {
        Request bare{http::verb::get, "/", 11};
        bare.keep_alive(false);
        if (ec == http::error::body_limit) {
          co_await write(*stream,
                         problem(bare, http::status::payload_too_large, "Body too large",
                                 "this route accepts at most " + std::to_string(limit) + " bytes"));
        } else if (body_timed_out) {
          co_await write(*stream, problem(bare, http::status::request_timeout, "Request timeout",
                                          "the request body did not arrive in time"));
        } else if (ec.category() == http::make_error_code(http::error::bad_target).category() &&
                   ec != http::error::partial_message && ec != http::error::end_of_stream) {
          // A malformed body (bad chunk framing, say); a client that went away gets nothing.
          co_await write(
              *stream, problem(bare, http::status::bad_request, "Malformed request", ec.message()));
        }
        break;
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
          // Work on the generation pool; this coroutine resumes on the connection's strand.
          // (Posting the coroutine itself to the pool would resume it on its own executor,
          // the I/O threads, and generate there.)
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
      if (request.method() == http::verb::head) {
        const auto length = response.body().size();
        response.body().clear();
        response.content_length(length);
      }
      const bool keep_alive = response.keep_alive() && !stopping;
      response.keep_alive(keep_alive);
      const int status = static_cast<int>(response.result_int());
      co_await write(*stream, std::move(response));
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      const std::string route = App::route_label(request);
      app.metrics().request(route, status, seconds);
      if (log_enabled(LogLevel::info)) {
        log(LogLevel::info, "request",
            {{"method", std::string(request.method_string())},
             {"target", std::string(request.target())},
             {"route", route},
             {"status", status},
             {"ms", std::round(seconds * 1e5) / 100.0}});
      }
      if (!keep_alive) break;
      {
        std::lock_guard lock(sessions_mutex);
        idle.push_front(stream);
        registration = idle.begin();
      }
    }
    unregister();
    boost::system::error_code ignored;
    stream->socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream->close();
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
  asio::co_spawn(state_->accept_strand, state_->accept_loop(), asio::detached);
  const unsigned n = thread_count(state_->config.io_threads);
  std::vector<std::thread> threads;
  for (unsigned i = 1; i < n; ++i) threads.emplace_back([this] { state_->io.run(); });
  state_->io.run();
  for (std::thread& t : threads) t.join();
  state_->generation.join();
}

void HttpServer::stop() {
  asio::post(state_->accept_strand, [s = state_.get()] {
    s->stopping = true;
    boost::system::error_code ignored;
    s->acceptor.close(ignored);
  });
  asio::post(state_->io, [s = state_.get()] {
    s->stopping = true;
    std::lock_guard lock(s->sessions_mutex);
    for (auto& weak : s->idle) {
      if (auto stream = weak.lock()) {
        // On the connection's strand: the session may be running on another thread.
        asio::post(stream->get_executor(), [stream] {
          boost::system::error_code ignored_too;
          stream->socket().close(ignored_too);
        });
      }
    }
  });
}

}  // namespace server
