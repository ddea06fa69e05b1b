// A throwaway redis-server for integration tests, on a free loopback port, started and stopped
// by the test itself (Debian's redis-server package; scripts/install-deps.sh --tests installs it).
#pragma once

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <thread>
#include <vector>

#include "http_harness.hpp"

namespace http_test {

/// redis-server on 127.0.0.1:port without persistence, for as long as the object lives.
class RedisProcess {
 public:
  explicit RedisProcess(int port) : port_(port) { start(); }
  ~RedisProcess() { stop(); }
  RedisProcess(const RedisProcess&) = delete;
  RedisProcess& operator=(const RedisProcess&) = delete;

  void start() {
    std::vector<std::string> args = {
        "redis-server", "--port", std::to_string(port_), "--bind", "127.0.0.1", "--save", "",
        "--appendonly", "no",     "--loglevel",          "warning"};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(1);
      ::execvp("redis-server", argv.data());
      ::_exit(127);
    }
    // Ready when it accepts connections.
    const auto deadline = Clock::now() + Millis(10'000);
    while (Clock::now() < deadline) {
      try {
        Connection probe(port_);
        return;
      } catch (const std::exception&) {
        std::this_thread::sleep_for(Millis(20));
      }
    }
    throw std::runtime_error("redis-server did not start (is it installed?)");
  }

  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

  std::string url() const { return "redis://127.0.0.1:" + std::to_string(port_); }

 private:
  int port_;
  pid_t pid_ = -1;
};

}  // namespace http_test
