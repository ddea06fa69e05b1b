// The deployment of docs/scaling.md on loopback, started and stopped by the test: PostgreSQL (the
// store), Redis (shared products and live fan-out), two terrain-server replicas and nginx in front
// (deploy/nginx.conf rendered by deploy/render-nginx.sh). Every replica and nginx answer with the
// same bytes; an edit through one replica reaches a viewer on the other; killing a replica under
// load loses no acknowledged version while nginx routes around it; stopping Redis under load
// costs no request.
#include <gtest/gtest.h>

#include <fstream>
#include <mutex>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "live_client.hpp"
#include "postgres_cluster.hpp"
#include "redis_harness.hpp"

namespace http_test {
namespace {

/// Runs a program to completion with its output in `log` (for short helpers: render, wrk).
int run_program(std::vector<std::string> args, const fs::path& log,
                const std::vector<std::string>& environment = {}) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_copy = environment;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) env_copy.emplace_back(*e);
  std::vector<char*> envp;
  for (std::string& e : env_copy) envp.push_back(e.data());
  envp.push_back(nullptr);
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execvpe(argv[0], argv.data(), envp.data());
    ::_exit(127);
  }
  ::close(fd);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// nginx in the foreground, as a child of the test, on deploy/nginx.conf rendered for `replicas`.
class NginxProcess {
 public:
  NginxProcess(const fs::path& dir, const std::vector<int>& replicas, bool cache)
      : port_(free_port()) {
    fs::create_directories(dir);
    std::vector<std::string> render = {std::string(TERRAIN_SOURCE_DIR) + "/deploy/render-nginx.sh",
                                       "127.0.0.1:" + std::to_string(port_), dir.string(),
                                       (dir / "cache").string(), "256m"};
    for (int p : replicas) render.push_back("127.0.0.1:" + std::to_string(p));
    const fs::path conf = dir / "nginx.conf";
    if (run_program(render, conf,
                    {cache ? "TERRAIN_NGINX_CACHE=terrain_products" : "TERRAIN_NGINX_CACHE=off"}) !=
        0) {
      throw std::runtime_error("render-nginx.sh failed: " + read_file(conf));
    }
    std::vector<std::string> args = {"nginx",      "-c", conf.string(), "-p",
                                     dir.string(), "-g", "daemon off;"};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      ::execvp("nginx", argv.data());
      ::_exit(127);
    }
    const auto deadline = Clock::now() + Millis(10'000);
    while (Clock::now() < deadline) {
      try {
        if (get(port_, "/healthz").result_int() == 200) return;
      } catch (const std::exception&) {
      }
      std::this_thread::sleep_for(Millis(50));
    }
    throw std::runtime_error("nginx did not start: " + read_file(dir / "error.log"));
  }
  ~NginxProcess() {
    // SIGTERM: the master stops its workers, then exits (a SIGKILL would orphan the workers).
    ::kill(pid_, SIGTERM);
    const auto deadline = Clock::now() + Millis(5000);
    while (::waitpid(pid_, nullptr, WNOHANG) == 0) {
      if (Clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, nullptr, 0);
        break;
      }
      std::this_thread::sleep_for(Millis(10));
    }
  }
  NginxProcess(const NginxProcess&) = delete;
  NginxProcess& operator=(const NginxProcess&) = delete;
  int port() const { return port_; }

 private:
  int port_;
  pid_t pid_ = -1;
};

/// What wrk reported: requests, non-2xx answers and socket errors.
struct LoadReport {
  long requests = 0;
  long non_2xx = 0;
  long socket_errors = 0;  ///< connect, read, write and timeout errors together
  long read_errors = 0;    ///< responses cut off (the connection closed mid-response)
  std::string text;
};

LoadReport parse_wrk(const std::string& text) {
  LoadReport r;
  r.text = text;
  std::smatch m;
  if (std::regex_search(text, m, std::regex(R"((\d+) requests in)"))) r.requests = std::stol(m[1]);
  if (std::regex_search(text, m, std::regex(R"(Non-2xx or 3xx responses: (\d+))"))) {
    r.non_2xx = std::stol(m[1]);
  }
  if (std::regex_search(
          text, m,
          std::regex(R"(Socket errors: connect (\d+), read (\d+), write (\d+), timeout (\d+))"))) {
    r.socket_errors = std::stol(m[1]) + std::stol(m[2]) + std::stol(m[3]) + std::stol(m[4]);
    r.read_errors = std::stol(m[2]);
  }
  return r;
}

class Cluster : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string store = pg_test::shared_cluster().create_database();
    redis_ = std::make_unique<RedisProcess>(free_port());
    const std::vector<std::string> flags = {
        "--write-token", kToken,        "--store-backend", "postgres",         "--postgres-url",
        store,           "--redis-url", redis_->url(),     "--live-redis-url", redis_->url()};
    a_ = std::make_unique<ServerProcess>(dir_.path() / "a", flags);
    b_ = std::make_unique<ServerProcess>(dir_.path() / "b", flags);
  }
  void TearDown() override {
    nginx_.reset();
    a_.reset();
    b_.reset();
    redis_.reset();
  }
  void start_nginx(bool cache) {
    nginx_ = std::make_unique<NginxProcess>(dir_.path() / "nginx",
                                            std::vector{a_->port(), b_->port()}, cache);
  }
  /// Runs wrk against nginx for `seconds`, with a Lua script when given; returns at once.
  std::thread load(const std::string& target, int seconds, LoadReport& report,
                   const std::string& lua = "") {
    const fs::path out = dir_.path() / ("wrk-" + std::to_string(loads_++) + ".txt");
    std::vector<std::string> args = {"wrk", "-t2", "-c" + std::to_string(kLoadConnections),
                                     "-d" + std::to_string(seconds) + "s"};
    if (!lua.empty()) {
      const fs::path script = dir_.path() / "load.lua";
      std::ofstream(script) << lua;
      args.insert(args.end(), {"-s", script.string()});
    }
    args.push_back("http://127.0.0.1:" + std::to_string(nginx_->port()) + target);
    return std::thread([args, out, &report] {
      run_program(args, out);
      report = parse_wrk(read_file(out));
    });
  }

  static constexpr int kLoadConnections = 16;  ///< wrk's connections to nginx
  TempDir dir_{"cluster"};
  std::unique_ptr<RedisProcess> redis_;
  std::unique_ptr<ServerProcess> a_, b_;
  std::unique_ptr<NginxProcess> nginx_;
  int loads_ = 0;
};

TEST_F(Cluster, EveryReplicaAndNginxAnswerTheSameBytes) {
  start_nginx(true);
  std::vector<std::string> targets;
  for (std::int64_t x = 0; x < 8; ++x) {
    for (std::int64_t y = 0; y < 8; ++y) {
      const std::string address = "3/" + std::to_string(x) + "/" + std::to_string(y);
      targets.push_back("/api/v1/scenes/hills-river@1/tiles/" + address +
                        ".png?scheme=local&size=64");
      targets.push_back("/api/v1/scenes/winding-road@1/tiles/" + address +
                        ".tif?scheme=local&size=64");
    }
  }
  for (std::int64_t x = 0; x < 8; ++x) {
    for (std::int64_t y = 0; y < 4; ++y) {
      const std::string address = "2/" + std::to_string(x) + "/" + std::to_string(y);
      targets.push_back("/api/v1/planets/default/tiles/" + address + ".png?size=64");
      targets.push_back("/api/v1/planets/default/mesh/" + address + ".terrain?grid=17");
    }
  }
  ASSERT_GE(targets.size(), 190u);
  for (const std::string& target : targets) {
    const Response from_a = get(a_->port(), target);
    ASSERT_EQ(from_a.result_int(), 200u) << target << ": " << from_a.body();
    const Response from_b = get(b_->port(), target);
    const Response through_nginx = get(nginx_->port(), target);
    EXPECT_EQ(from_b.body(), from_a.body()) << target;
    EXPECT_EQ(through_nginx.body(), from_a.body()) << target;
    EXPECT_EQ(header(from_b, http::field::etag), header(from_a, http::field::etag)) << target;
  }
  // B generated none of them: A's products reached it through Redis.
  EXPECT_GE(metric(b_->port(), "terrain_redis_hits_total"), static_cast<double>(targets.size()));
}

TEST_F(Cluster, AnEditThroughOneReplicaReachesAViewerOnTheOtherThroughNginx) {
  start_nginx(true);
  LiveClient viewer(b_->port(), "hills-river");
  const std::int64_t head = viewer.subscribe(false)["head"];
  LiveClient author(nginx_->port(), "hills-river");  // through nginx, to whichever replica
  author.subscribe(true, std::nullopt, "alice");
  author.send({{"type", "edit"},
               {"base", head},
               {"ops", {{{"op", "replace"}, {"path", "/name"}, {"value", "Hills, edited"}}}}});
  const json ack = author.next_of("ack");
  const json seen = viewer.next_of("version", Millis(5000));
  EXPECT_EQ(seen["version"], head + 1);
  EXPECT_EQ(seen["hash"], ack["hash"]);
}

TEST_F(Cluster, KillingAReplicaUnderLoadLosesNoAcknowledgedVersion) {
  start_nginx(false);  // every read reaches a replica
  LoadReport report;
  std::thread wrk = load("/api/v1/scenes/hills-river@1/tiles/2/1/1.png?scheme=local", 6, report);
  // Writes through nginx while a replica dies: what was acknowledged must be stored. The kill
  // and the end of the writes wait for acknowledgements rather than for fixed times, so that a
  // slow machine (CI with the browser tests beside) still writes before and after the kill.
  std::mutex acknowledged_mutex;
  std::vector<std::pair<std::int64_t, std::string>> acknowledged;
  const auto acknowledged_count = [&] {
    std::lock_guard lock(acknowledged_mutex);
    return acknowledged.size();
  };
  std::atomic<bool> writing{true};
  std::thread writer([&] {
    for (int i = 0; writing; ++i) {
      try {
        json scene = json::parse(get(nginx_->port(), "/api/v1/scenes/hills-river").body());
        scene["name"] = "Hills " + std::to_string(i);
        const Response r =
            fetch(nginx_->port(), "PUT", "/api/v1/scenes/hills-river", with_token(), scene.dump());
        if (r.result_int() == 200) {
          const json body = body_json(r);
          std::lock_guard lock(acknowledged_mutex);
          acknowledged.emplace_back(body["version"], body["hash"]);
        }
      } catch (const std::exception&) {
        // the connection died with the replica: not acknowledged
      }
      std::this_thread::sleep_for(Millis(20));
    }
  });
  const auto wait_for_acknowledged = [&](std::size_t count, Millis longest) {
    const auto deadline = Clock::now() + longest;
    while (acknowledged_count() < count && Clock::now() < deadline) {
      std::this_thread::sleep_for(Millis(20));
    }
  };
  std::this_thread::sleep_for(Millis(1000));
  wait_for_acknowledged(4, Millis(1500));
  const std::size_t before_kill = acknowledged_count();
  a_->kill_now();  // SIGKILL, while wrk still has seconds to run
  wait_for_acknowledged(before_kill + 4, Millis(10'000));
  writing = false;
  writer.join();
  wrk.join();
  EXPECT_GT(report.requests, 200) << report.text;
  EXPECT_EQ(report.non_2xx, 0) << report.text;
  // nginx retries a read on the other replica until it has begun sending the response; a
  // response the SIGKILL cuts off mid-body can only be cut off (the client sees its connection
  // close). So at most the reads in flight at the kill, one per connection, may fail, and only
  // that way: none may be refused, time out or fail later (about one run in seven cut one).
  EXPECT_EQ(report.socket_errors - report.read_errors, 0) << report.text;
  EXPECT_LE(report.read_errors, kLoadConnections) << report.text;
  EXPECT_GT(before_kill, 0u) << "no write was acknowledged before the kill";
  ASSERT_GE(acknowledged.size(), before_kill + 4) << "writes after the kill were not acknowledged";
  const json versions = body_json(get(b_->port(), "/api/v1/scenes/hills-river/versions"));
  std::set<std::pair<std::int64_t, std::string>> stored;
  for (const json& v : versions["versions"]) stored.emplace(v["version"], v["hash"]);
  for (const auto& version : acknowledged) {
    EXPECT_TRUE(stored.contains(version)) << "lost version " << version.first;
  }
}

TEST_F(Cluster, StoppingRedisUnderLoadCostsNoRequest) {
  start_nginx(false);
  // Every request a different tile, so that every one asks Redis (then generates).
  const std::string lua = R"(
counter = 0
request = function()
  counter = counter + 1
  local id = (counter * 7919 + math.random(0, 100000)) % 65536
  return wrk.format("GET", "/api/v1/scenes/hills-river@1/tiles/8/" .. (id % 256) .. "/" ..
                    math.floor(id / 256) .. ".png?scheme=local&size=64")
end
)";
  LoadReport report;
  std::thread wrk = load("", 4, report, lua);
  std::this_thread::sleep_for(Millis(1500));
  redis_->stop();
  wrk.join();
  EXPECT_GT(report.requests, 100) << report.text;
  EXPECT_EQ(report.non_2xx, 0) << report.text;
  EXPECT_EQ(report.socket_errors, 0) << report.text;
  EXPECT_EQ(metric(a_->port(), "terrain_redis_up"), 0);
}

}  // namespace
}  // namespace http_test
