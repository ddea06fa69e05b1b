// A throwaway PostgreSQL cluster for the tests: Debian's initdb and postgres binaries, a data
// directory under the system temp directory, a free loopback port, trust authentication for the
// superuser `terrain`, and durability switched off (nothing here must survive a power cut).
//
// initdb takes about a second, and CTest runs every test in a process of its own, so one
// initdb'd directory per user is kept as a template (built under a temporary name, then renamed
// into place, so concurrent test processes never see half of one) and each cluster copies it.
//
// PostgreSQL refuses to run as root. Under root the forked child switches to the `postgres`
// system user before it execs (the data directory belongs to that user); otherwise the
// binaries run as the current user. The postmaster is a direct child with PR_SET_PDEATHSIG, so
// a crashing test binary takes it along: start and stop the cluster from the main thread, since
// the death signal follows the thread that forked.
#pragma once

#include <fcntl.h>
#include <grp.h>
#include <libpq-fe.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "http_harness.hpp"

namespace pg_test {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using Millis = std::chrono::milliseconds;

/// Where initdb and postgres live: TERRAIN_PG_BINDIR from the environment, else the directory
/// CMake found (tests/CMakeLists.txt).
inline std::string bindir() {
  if (const char* env = std::getenv("TERRAIN_PG_BINDIR"); env != nullptr && *env != '\0') {
    return env;
  }
  return TERRAIN_PG_BINDIR;
}

/// Who runs the PostgreSQL binaries: the current user, or `postgres` when that is root.
struct RunAs {
  bool switch_user = false;
  uid_t uid = 0;
  gid_t gid = 0;
};

inline RunAs server_user() {
  RunAs as;
  as.uid = ::geteuid();
  as.gid = ::getegid();
  if (as.uid != 0) return as;
  const passwd* pw = ::getpwnam("postgres");
  if (pw == nullptr) {
    throw std::runtime_error(
        "the tests run as root and PostgreSQL refuses root, but there is no 'postgres' system "
        "user to run it as (scripts/install-deps.sh --tests installs postgresql, which adds it)");
  }
  as.switch_user = true;
  as.uid = pw->pw_uid;
  as.gid = pw->pw_gid;
  return as;
}

/// Forks and execs `args` as `as` in `cwd`, stdout and stderr appended to `log`; the child
/// gets SIGKILL when the calling thread ends.
inline pid_t spawn(const std::vector<std::string>& args, const RunAs& as, const fs::path& cwd,
                   const fs::path& log) {
  const int log_fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log_fd < 0) throw std::runtime_error("cannot open " + log.string());
  // Everything exec needs is prepared before fork: the child only calls async-signal-safe
  // functions.
  std::vector<std::string> copy = args;
  std::vector<char*> argv;
  for (std::string& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string dir = cwd.string();
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(log_fd);
    throw std::runtime_error("fork failed");
  }
  if (pid == 0) {
    if (as.switch_user &&
        (::setgroups(0, nullptr) != 0 || ::setgid(as.gid) != 0 || ::setuid(as.uid) != 0)) {
      ::_exit(125);
    }
    // After the switch: changing credentials clears the death signal.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(126);
    const int null_fd = ::open("/dev/null", O_RDONLY);
    ::dup2(null_fd, STDIN_FILENO);
    ::dup2(log_fd, STDOUT_FILENO);
    ::dup2(log_fd, STDERR_FILENO);
    if (::chdir(dir.c_str()) != 0) ::_exit(124);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(log_fd);
  return pid;
}

/// The exit code of a child (-signal when a signal ended it), or nullopt when it still runs
/// after `timeout`.
inline std::optional<int> wait_child(pid_t pid, Millis timeout) {
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
    if (r < 0 && errno != EINTR) return -1;
    if (Clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(Millis(10));
  }
}

/// Runs a command to completion (two minutes at most); throws with its log when it fails.
inline void run(const std::vector<std::string>& args, const RunAs& as, const fs::path& cwd,
                const fs::path& log) {
  const pid_t pid = spawn(args, as, cwd, log);
  const std::optional<int> code = wait_child(pid, Millis(120'000));
  if (!code) {
    ::kill(pid, SIGKILL);
    wait_child(pid, Millis(5'000));
  }
  if (code != 0) {
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    throw std::runtime_error(args[0] + " failed (" + (code ? std::to_string(*code) : "timeout") +
                             "): " + text.str());
  }
}

/// A directory owned by whoever runs the PostgreSQL binaries, private to them.
inline void make_owned_dir(const fs::path& dir, const RunAs& as) {
  fs::create_directories(dir);
  fs::permissions(dir, fs::perms::owner_all, fs::perm_options::replace);
  if (as.switch_user && ::chown(dir.c_str(), as.uid, as.gid) != 0) {
    throw std::runtime_error("cannot hand " + dir.string() + " to the postgres user");
  }
}

using http_test::free_port;

/// The initdb'd template of this user and these binaries, made when missing.
inline fs::path data_template(const RunAs& as) {
  // "v2" names the initdb options below: change it with them.
  const fs::path done =
      fs::temp_directory_path() / ("terrain-pg-template-v2-" + std::to_string(as.uid) + "-" +
                                   std::to_string(std::hash<std::string>{}(bindir())));
  if (fs::exists(done / "data" / "PG_VERSION")) return done / "data";
  const fs::path building = done.string() + ".tmp-" + std::to_string(::getpid());
  fs::remove_all(building);
  make_owned_dir(building, as);
  run({bindir() + "/initdb", "-D", (building / "data").string(), "-U", "terrain", "--auth=trust",
       "-E", "UTF8", "--locale=C", "--no-sync", "--wal-segsize=1"},
      as, building, building / "initdb.log");
  // Another process may have finished first: then its template is used and this one dropped.
  std::error_code ec;
  fs::rename(building, done, ec);
  if (ec) fs::remove_all(building);
  if (!fs::exists(done / "data" / "PG_VERSION")) {
    throw std::runtime_error("no PostgreSQL template in " + done.string());
  }
  return done / "data";
}

/// Removes the cluster directories (and half-built templates) of test processes that died
/// without cleaning up (a crash, a kill -9: their postmasters died with them).
inline void remove_orphans() {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(fs::temp_directory_path(), ec)) {
    const std::string name = entry.path().filename().string();
    if (!name.starts_with("terrain-pg-")) continue;
    std::size_t pid_at = std::string_view("terrain-pg-").size();
    if (name.starts_with("terrain-pg-template-")) {
      pid_at = name.find(".tmp-");
      if (pid_at == std::string::npos) continue;  // a finished template
      pid_at += std::string_view(".tmp-").size();
    }
    const pid_t owner = static_cast<pid_t>(std::atoi(name.c_str() + pid_at));
    if (owner > 0 && ::kill(owner, 0) != 0 && errno == ESRCH) fs::remove_all(entry.path(), ec);
  }
}

/// One cluster: created and started by the constructor, stopped and removed by the destructor.
class Cluster {
 public:
  Cluster() : as_(server_user()) {
    remove_orphans();
    static std::atomic<int> counter{0};
    base_ = fs::temp_directory_path() /
            ("terrain-pg-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    fs::remove_all(base_);
    make_owned_dir(base_, as_);
    run({"/bin/cp", "-a", data_template(as_).string(), data().string()}, as_, base_,
        base_ / "copy.log");
    // The port is chosen once, so a restarted cluster is where its clients expect it.
    for (int attempt = 0;; ++attempt) {
      port_ = free_port();
      if (try_start()) break;
      if (attempt == 4) throw std::runtime_error("PostgreSQL did not start: " + log_tail());
    }
  }
  ~Cluster() {
    // The data is thrown away: no shutdown checkpoint needed.
    stop(SIGQUIT);
    std::error_code ec;
    fs::remove_all(base_, ec);
  }
  Cluster(const Cluster&) = delete;
  Cluster& operator=(const Cluster&) = delete;

  int port() const { return port_; }
  bool running() const { return pid_ > 0; }

  /// A libpq URI for database `db` as the superuser.
  std::string url(const std::string& db = "postgres") const {
    return "postgresql://terrain@127.0.0.1:" + std::to_string(port_) + "/" + db;
  }

  /// A new empty database of its own, for one test; its URI.
  std::string create_database() {
    static std::atomic<int> counter{0};
    const std::string name = "test_" + std::to_string(counter++);
    // FILE_COPY: a copy of the template's files, several times faster than WAL_LOG here.
    exec("postgres", "CREATE DATABASE " + name + " STRATEGY = FILE_COPY");
    return url(name);
  }

  /// Runs SQL on database `db`; throws with the server's message when it fails. Rows come back
  /// as text, one string per value, row after row.
  std::vector<std::string> exec(const std::string& db, const std::string& sql) const {
    PGconn* c = PQconnectdb(url(db).c_str());
    std::vector<std::string> values;
    std::string error;
    if (PQstatus(c) != CONNECTION_OK) {
      error = PQerrorMessage(c);
    } else {
      PGresult* r = PQexec(c, sql.c_str());
      const ExecStatusType s = PQresultStatus(r);
      if (s == PGRES_TUPLES_OK) {
        for (int i = 0; i < PQntuples(r); ++i) {
          for (int j = 0; j < PQnfields(r); ++j) values.emplace_back(PQgetvalue(r, i, j));
        }
      } else if (s != PGRES_COMMAND_OK) {
        error = PQresultErrorMessage(r);
      }
      PQclear(r);
    }
    PQfinish(c);
    if (!error.empty()) throw std::runtime_error(sql + ": " + error);
    return values;
  }

  /// Fast shutdown by default (clients are disconnected, a checkpoint is written), SIGQUIT for an
  /// immediate one; waits for the postmaster to exit.
  void stop(int signal = SIGINT) {
    if (pid_ <= 0) return;
    ::kill(pid_, signal);
    if (!wait_child(pid_, Millis(20'000))) {
      ::kill(pid_, SIGKILL);
      wait_child(pid_, Millis(5'000));
    }
    pid_ = -1;
  }

  /// Starts the stopped cluster again on the same port and data.
  void start() {
    if (pid_ > 0) return;
    for (int attempt = 0; !try_start(); ++attempt) {
      if (attempt == 4) throw std::runtime_error("PostgreSQL did not restart: " + log_tail());
      std::this_thread::sleep_for(Millis(200));
    }
  }

  std::string log_tail() const {
    std::ifstream in(base_ / "postgres.log");
    std::stringstream text;
    text << in.rdbuf();
    const std::string all = text.str();
    return all.size() > 4000 ? all.substr(all.size() - 4000) : all;
  }

 private:
  fs::path data() const { return base_ / "data"; }

  // Starts the postmaster and waits until it accepts connections; false when it exited first
  // (the port was taken meanwhile, say).
  bool try_start() {
    pid_ = spawn({bindir() + "/postgres", "-D", data().string(), "-p", std::to_string(port_), "-k",
                  base_.string(), "-c", "listen_addresses=127.0.0.1", "-c", "fsync=off", "-c",
                  "synchronous_commit=off", "-c", "full_page_writes=off", "-c",
                  "shared_buffers=16MB", "-c", "max_connections=200"},
                 as_, base_, base_ / "postgres.log");
    const std::string ping = url() + "?connect_timeout=2";
    const auto deadline = Clock::now() + Millis(60'000);
    while (Clock::now() < deadline) {
      if (PQping(ping.c_str()) == PQPING_OK) return true;
      if (wait_child(pid_, Millis(0))) {
        pid_ = -1;
        return false;
      }
      std::this_thread::sleep_for(Millis(20));
    }
    stop();
    return false;
  }

  RunAs as_;
  fs::path base_;
  int port_ = 0;
  pid_t pid_ = -1;
};

/// The cluster this test process shares between its tests, started on first use (call it from
/// the main thread) and running again if a test left it stopped.
inline Cluster& shared_cluster() {
  static std::unique_ptr<Cluster> cluster = std::make_unique<Cluster>();
  cluster->start();
  return *cluster;
}

}  // namespace pg_test
