// Test harness for the HTTP integration tests: the real terrain-server binary as a child process
// on a loopback port, and a small HTTP/1.1 client over raw POSIX sockets. Every read and write
// has a deadline, so a server bug fails a test instead of hanging it; child processes die with
// their fixture (and with the test binary, through PR_SET_PDEATHSIG).
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <boost/asio/buffer.hpp>
#include <boost/beast/http.hpp>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

extern char** environ;

namespace http_test {

namespace fs = std::filesystem;
namespace http = boost::beast::http;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;
using Millis = std::chrono::milliseconds;
using Response = http::response<http::string_body>;
using Headers = std::vector<std::pair<std::string, std::string>>;

inline constexpr Millis kIoTimeout{15'000};  ///< the longest any single response may take
inline const std::string kToken = "integration-test-token";

/// A free TCP port on 127.0.0.1 (free when asked; the caller retries when taken meanwhile).
inline int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof address;
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) != 0) {
    if (fd >= 0) ::close(fd);
    throw std::runtime_error("cannot find a free port");
  }
  ::close(fd);
  return ntohs(address.sin_port);
}

inline int remaining_ms(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<Millis>(deadline - Clock::now()).count();
  return left <= 0 ? 0 : static_cast<int>(left);
}

/// A fresh directory under the system temp directory, removed with everything in it.
class TempDir {
 public:
  explicit TempDir(const std::string& label) {
    static std::atomic<int> counter{0};
    path_ = fs::temp_directory_path() / ("terrain-http-" + std::to_string(::getpid()) + "-" +
                                         label + "-" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

/// terrain-server as a child process. Construction returns once it prints its port.
class ServerProcess {
 public:
  /// Starts the server on 127.0.0.1 with any free port, an empty config file (so only these
  /// flags and the built-in defaults apply), the repository's built-in scenes and planets and
  /// `data_dir`. `max_files` > 0 starts it under that descriptor limit (soft and hard).
  ServerProcess(const fs::path& data_dir, const std::vector<std::string>& flags,
                rlim_t max_files = 0) {
    const fs::path config = data_dir.parent_path() / (data_dir.filename().string() + ".toml");
    std::ofstream(config) << "# empty: flags only\n";
    std::vector<std::string> args = {TERRAIN_SERVER,
                                     "--config",
                                     config.string(),
                                     "--address",
                                     "127.0.0.1",
                                     "--port",
                                     "0",
                                     "--data-dir",
                                     data_dir.string(),
                                     "--scenes-dir",
                                     std::string(TERRAIN_SOURCE_DIR) + "/config/scenes",
                                     "--planets-dir",
                                     std::string(TERRAIN_SOURCE_DIR) + "/config/planets",
                                     "--backend",
                                     "cpu",
                                     "--io-threads",
                                     "2",
                                     "--log-level",
                                     "warn"};
    args.insert(args.end(), flags.begin(), flags.end());
    // Everything exec needs is prepared before fork: the child only calls async-signal-safe
    // functions. TERRAIN_* variables of the test's environment must not leak into the server.
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<char*> envp;
    for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
      if (std::strncmp(*e, "TERRAIN_", 8) != 0) envp.push_back(*e);
    }
    envp.push_back(nullptr);
    int out[2];
    if (::pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(126);
      if (max_files > 0) {
        const rlimit files{max_files, max_files};
        if (::setrlimit(RLIMIT_NOFILE, &files) != 0) ::_exit(125);
      }
      ::dup2(out[1], STDOUT_FILENO);
      ::execve(argv[0], argv.data(), envp.data());
      ::_exit(127);
    }
    ::close(out[1]);
    stdout_ = out[0];
    try {
      port_ = read_port();
    } catch (...) {
      kill_now();
      ::close(stdout_);
      throw;
    }
  }

  ~ServerProcess() {
    kill_now();
    if (stdout_ >= 0) ::close(stdout_);
  }
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  void signal(int sig) const {
    if (pid_ > 0) ::kill(pid_, sig);
  }

  /// The exit code once the process has exited normally within `timeout`; -signal when a signal
  /// ended it; nullopt while it still runs.
  std::optional<int> wait_exit(Millis timeout) {
    if (pid_ <= 0) return exit_code_;
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      int status = 0;
      const pid_t r = ::waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        pid_ = -1;
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
        return exit_code_;
      }
      if (r < 0 && errno != EINTR) return std::nullopt;
      if (Clock::now() >= deadline) return std::nullopt;
      std::this_thread::sleep_for(Millis(5));
    }
  }

  /// SIGKILL and reap (no-op once it has exited).
  void kill_now() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
    pid_ = -1;
  }

  /// SIGTERM, then SIGKILL when it has not exited within `grace`.
  void stop(Millis grace = Millis(5'000)) {
    signal(SIGTERM);
    if (!wait_exit(grace)) kill_now();
  }

 private:
  int read_port() {
    const auto deadline = Clock::now() + Millis(30'000);
    std::string text;
    const std::string marker = "listening on http://127.0.0.1:";
    for (;;) {
      const std::size_t at = text.find(marker);
      if (at != std::string::npos) {
        const std::size_t begin = at + marker.size();
        const std::size_t end = text.find_first_not_of("0123456789", begin);
        if (end != std::string::npos && end > begin) {
          return std::stoi(text.substr(begin, end - begin));
        }
      }
      pollfd p{stdout_, POLLIN, 0};
      const int ready = ::poll(&p, 1, remaining_ms(deadline));
      if (ready < 0 && errno == EINTR) continue;
      if (ready == 0) {
        kill_now();
        throw std::runtime_error("terrain-server printed no port in time; stdout: " + text);
      }
      char buffer[512];
      const ssize_t n = ::read(stdout_, buffer, sizeof buffer);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        const auto code = wait_exit(Millis(2'000));
        throw std::runtime_error("terrain-server exited before listening (status " +
                                 (code ? std::to_string(*code) : std::string("?")) +
                                 "); stdout: " + text);
      }
      text.append(buffer, static_cast<std::size_t>(n));
    }
  }

  pid_t pid_ = -1;
  int stdout_ = -1;
  int port_ = 0;
  std::optional<int> exit_code_;
};

/// One client connection with deadlines on every operation.
class Connection {
 public:
  explicit Connection(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw std::runtime_error("socket failed");
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      const int error = errno;
      ::close(fd_);
      fd_ = -1;
      throw std::runtime_error(std::string("connect failed: ") + std::strerror(error));
    }
  }
  ~Connection() {
    if (fd_ >= 0) ::close(fd_);
  }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  /// Sends all bytes; throws when the server closed the connection or the deadline passed.
  void send(std::string_view bytes, Millis timeout = kIoTimeout) {
    const auto deadline = Clock::now() + timeout;
    while (!bytes.empty()) {
      pollfd p{fd_, POLLOUT, 0};
      if (::poll(&p, 1, remaining_ms(deadline)) == 0) throw std::runtime_error("send timed out");
      const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n < 0) {
        if (errno == EINTR || errno == EAGAIN) continue;
        throw std::runtime_error(std::string("send failed: ") + std::strerror(errno));
      }
      bytes.remove_prefix(static_cast<std::size_t>(n));
    }
  }

  /// Reads one response (of a HEAD request when `head`: headers only).
  Response read(bool head = false, Millis timeout = kIoTimeout) {
    const auto deadline = Clock::now() + timeout;
    http::response_parser<http::string_body> parser;
    parser.body_limit(std::uint64_t{256} << 20);
    parser.eager(true);
    if (head) parser.skip(true);
    for (;;) {
      if (!pending_.empty()) {
        boost::system::error_code ec;
        const std::size_t used =
            parser.put(boost::asio::buffer(pending_.data(), pending_.size()), ec);
        pending_.erase(0, used);
        if (ec && ec != http::error::need_more) {
          throw std::runtime_error("malformed response: " + ec.message());
        }
        if (parser.is_done()) return parser.release();
        if (!ec && used > 0) continue;
      }
      if (!fill(deadline)) {
        if (!parser.got_some()) throw std::runtime_error("connection closed without a response");
        boost::system::error_code ec;
        parser.put_eof(ec);
        if (ec || !parser.is_done()) {
          throw std::runtime_error("connection closed before a complete response");
        }
        return parser.release();
      }
    }
  }

  /// True when the server closes the connection (EOF or reset) within `timeout`; whatever it
  /// sent first is kept in received().
  bool closed_within(Millis timeout) {
    const auto deadline = Clock::now() + timeout;
    try {
      while (fill(deadline)) {
      }
      return true;
    } catch (const std::runtime_error&) {
      return false;  // the deadline passed
    }
  }

  /// True when response bytes have arrived (or the server closed), without waiting.
  bool readable_now() const {
    pollfd p{fd_, POLLIN, 0};
    return !pending_.empty() || ::poll(&p, 1, 0) > 0;
  }

  const std::string& received() const { return pending_; }
  void shutdown_write() { ::shutdown(fd_, SHUT_WR); }

 private:
  // Appends what arrives before the deadline; false on EOF or reset; throws on timeout.
  bool fill(Clock::time_point deadline) {
    for (;;) {
      pollfd p{fd_, POLLIN, 0};
      const int ready = ::poll(&p, 1, remaining_ms(deadline));
      if (ready == 0) throw std::runtime_error("timed out waiting for the server");
      if (ready < 0) {
        if (errno == EINTR) continue;
        throw std::runtime_error("poll failed");
      }
      char buffer[16384];
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n > 0) {
        pending_.append(buffer, static_cast<std::size_t>(n));
        return true;
      }
      if (n == 0) return false;
      if (errno == EINTR || errno == EAGAIN) continue;
      if (errno == ECONNRESET || errno == EPIPE) return false;
      throw std::runtime_error(std::string("recv failed: ") + std::strerror(errno));
    }
  }

  int fd_ = -1;
  std::string pending_;
};

/// The text of a request; a Content-Length is added for a body and for POST and PUT.
inline std::string request_text(std::string_view method, std::string_view target,
                                const Headers& headers = {}, std::string_view body = {}) {
  std::string text = std::string(method) + " " + std::string(target) + " HTTP/1.1\r\n";
  text += "Host: 127.0.0.1\r\n";
  for (const auto& [name, value] : headers) text += name + ": " + value + "\r\n";
  if (!body.empty() || method == "POST" || method == "PUT") {
    text += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  }
  text += "\r\n";
  text += body;
  return text;
}

/// One request on a connection of its own.
inline Response fetch(int port, std::string_view method, std::string_view target,
                      const Headers& headers = {}, std::string_view body = {}) {
  Connection c(port);
  c.send(request_text(method, target, headers, body));
  return c.read(method == "HEAD");
}

inline Response get(int port, std::string_view target, const Headers& headers = {}) {
  return fetch(port, "GET", target, headers);
}

inline Headers with_token(Headers headers = {}) {
  headers.emplace_back("Authorization", "Bearer " + kToken);
  return headers;
}

/// A header's value, "" when absent.
inline std::string header(const Response& r, http::field field) {
  const auto it = r.find(field);
  return it == r.end() ? std::string() : std::string(it->value());
}
inline std::string header(const Response& r, std::string_view name) {
  const auto it = r.find(name);
  return it == r.end() ? std::string() : std::string(it->value());
}
inline bool has_header(const Response& r, http::field field) {
  return r.find(field) != r.end();
}

inline json body_json(const Response& r) {
  return json::parse(r.body());
}

/// The value of an unlabelled Prometheus sample, -1 when missing.
inline double metric(int port, std::string_view name) {
  const Response r = get(port, "/metrics");
  const std::string& text = r.body();
  std::size_t at = 0;
  while ((at = text.find(name, at)) != std::string::npos) {
    const bool line_start = at == 0 || text[at - 1] == '\n';
    const std::size_t after = at + name.size();
    if (line_start && after < text.size() && text[after] == ' ') {
      return std::stod(text.substr(after + 1, text.find('\n', after) - after - 1));
    }
    at = after;
  }
  return -1.0;
}

/// A small valid scene: one disc, its elevation a parameter so that versions differ.
inline std::string disc_scene(double elevation, const std::string& name = "Test disc") {
  return json{
      {"format", "terrain-scene/1"},
      {"name", name},
      {"seed", 1},
      {"extent", {{"min", {-1000, -1000}}, {"max", {1000, 1000}}}},
      {"root", {{"type", "disc"}, {"center", {0, 0}}, {"radius", 800}, {"elevation", elevation}}}}
      .dump();
}

/// A dome with a bowl dug into its top, drained on a 64² grid (quick to bake): the bowl holds a
/// lake. `eroded` puts a 64² erosion under the drainage.
inline std::string drained_dome_scene(bool eroded = false) {
  json land = {{"type", "add"},
               {"children",
                {{{"type", "disc"}, {"center", {0, 0}}, {"radius", 1400}, {"elevation", 400}},
                 {{"type", "disc"}, {"center", {0, 0}}, {"radius", 400}, {"elevation", -80}}}}};
  if (eroded) {
    land = {{"type", "erosion"},
            {"resolution", 64},
            {"center", {0, 0}},
            {"size", 2000},
            {"children", {land}}};
  }
  return json{{"format", "terrain-scene/1"},
              {"root",
               {{"type", "drainage"},
                {"resolution", 64},
                {"center", {0, 0}},
                {"size", 2000},
                {"channel_area", 20000},
                {"children", {land}}}}}
      .dump();
}

inline std::string etag_of(const std::string& s) {
  return "\"" + s + "\"";
}

/// A suite whose tests share one server: started before its first test, in a folder of its own
/// (`Suite::kFolder`) with `Suite::server_arguments()`, stopped after its last; each test fails
/// at once when it did not start.
template <class Suite>
class SharedServerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = std::make_unique<TempDir>(Suite::kFolder);
    try {
      server_ = std::make_unique<ServerProcess>(dir_->path() / "data", Suite::server_arguments());
    } catch (const std::exception& e) {
      startup_error_ = e.what();
    }
  }
  static void TearDownTestSuite() {
    if (server_) server_->stop();
    server_.reset();
    dir_.reset();
  }
  void SetUp() override {
    if (!server_) GTEST_FAIL() << "terrain-server did not start: " << startup_error_;
    port_ = server_->port();
  }
  Response get(std::string_view target, const Headers& headers = {}) const {
    return http_test::get(port_, target, headers);
  }
  Response fetch(std::string_view method, std::string_view target, const Headers& headers = {},
                 std::string_view body = {}) const {
    return http_test::fetch(port_, method, target, headers, body);
  }

  static inline std::unique_ptr<TempDir> dir_;
  static inline std::unique_ptr<ServerProcess> server_;
  static inline std::string startup_error_;
  int port_ = 0;
};

}  // namespace http_test
