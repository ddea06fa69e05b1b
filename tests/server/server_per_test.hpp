// A GoogleTest fixture whose tests each start a server of their own, with the write token and
// extra flags: for tests of limits and failures, which need their own configuration or kill
// their server.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "http_harness.hpp"

namespace http_test {

class ServerPerTest : public ::testing::Test {
 protected:
  explicit ServerPerTest(const std::string& label) : dir_(label) {}

  void start(std::vector<std::string> flags) {
    flags.insert(flags.end(), {"--write-token", kToken});
    server_ = std::make_unique<ServerProcess>(dir_.path() / "data", flags);
    port_ = server_->port();
  }
  void TearDown() override {
    if (server_) server_->stop();
  }

  TempDir dir_;
  std::unique_ptr<ServerProcess> server_;
  int port_ = 0;
};

}  // namespace http_test
