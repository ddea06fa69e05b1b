// What a session checks before it reads a body: framing that could smuggle a request, the body
// budget shared by all connections, and the rate of request log lines.
#include <gtest/gtest.h>

#include "server/admission.hpp"

namespace server {
namespace {

http::request_header<> header_with(std::vector<std::pair<std::string, std::string>> fields,
                                   unsigned version = 11) {
  http::request_header<> h;
  h.method(http::verb::put);
  h.target("/api/v1/scenes/x");
  h.version(version);
  for (const auto& [name, value] : fields) h.insert(name, value);
  return h;
}

TEST(CheckFraming, AcceptsNoTransferEncodingAndPlainChunked) {
  EXPECT_FALSE(check_framing(header_with({})));
  EXPECT_FALSE(check_framing(header_with({{"Content-Length", "12"}})));
  EXPECT_FALSE(check_framing(header_with({{"Transfer-Encoding", "chunked"}})));
  EXPECT_FALSE(check_framing(header_with({{"Transfer-Encoding", " Chunked "}})));
}

// RFC 9112 §6.3: a final coding other than chunked leaves the length unknown, so the rest of the
// bytes could be read as a request of someone else's.
TEST(CheckFraming, RefusesAFinalCodingOtherThanChunkedWith400) {
  for (const char* value : {"gzip", "identity", "chunked, gzip", "xchunked", "chunked;q=1", ","}) {
    const auto refusal = check_framing(header_with({{"Transfer-Encoding", value}}));
    ASSERT_TRUE(refusal) << value;
    EXPECT_EQ(refusal->status, http::status::bad_request) << value;
  }
  // Split over two lines, the final coding is still gzip.
  const auto split =
      check_framing(header_with({{"Transfer-Encoding", "chunked"}, {"Transfer-Encoding", "gzip"}}));
  ASSERT_TRUE(split);
  EXPECT_EQ(split->status, http::status::bad_request);
}

TEST(CheckFraming, RefusesCodingsItDoesNotImplementWith501) {
  for (const char* value : {"gzip, chunked", "chunked, chunked"}) {
    const auto refusal = check_framing(header_with({{"Transfer-Encoding", value}}));
    ASSERT_TRUE(refusal) << value;
    EXPECT_EQ(refusal->status, http::status::not_implemented) << value;
  }
}

TEST(CheckFraming, RefusesTransferEncodingBesideContentLengthOrInHttp10) {
  EXPECT_TRUE(
      check_framing(header_with({{"Transfer-Encoding", "chunked"}, {"Content-Length", "5"}})));
  EXPECT_TRUE(check_framing(header_with({{"Transfer-Encoding", "chunked"}}, 10)));
}

TEST(BodyBudget, ReservesUpToItsLimitAndReleasesOnDestruction) {
  BodyBudget budget(1000);
  {
    BodyBudget::Reservation a = budget.reserve(600);
    EXPECT_TRUE(a);
    EXPECT_FALSE(budget.reserve(500));  // 1100 > 1000
    EXPECT_EQ(budget.used(), 600);
    BodyBudget::Reservation b = budget.reserve(400);
    EXPECT_TRUE(b);
    EXPECT_EQ(budget.used(), 1000);
    BodyBudget::Reservation moved = std::move(b);
    EXPECT_EQ(budget.used(), 1000);
  }
  EXPECT_EQ(budget.used(), 0);
  EXPECT_TRUE(budget.reserve(1000));
  EXPECT_TRUE(budget.reserve(0));  // a request without a body always fits
}

TEST(LogRate, AdmitsItsRateAndReportsTheRestOnceInTheNextSecond) {
  LogRate rate(3);
  const auto t0 = std::chrono::steady_clock::time_point(std::chrono::seconds(100));
  std::int64_t dropped = -1;
  int admitted = 0;
  for (int i = 0; i < 10; ++i) {
    if (rate.admit(t0 + std::chrono::milliseconds(i), dropped)) ++admitted;
    EXPECT_EQ(dropped, 0);
  }
  EXPECT_EQ(admitted, 3);
  EXPECT_TRUE(rate.admit(t0 + std::chrono::milliseconds(1500), dropped));
  EXPECT_EQ(dropped, 7);
  EXPECT_TRUE(rate.admit(t0 + std::chrono::milliseconds(1600), dropped));
  EXPECT_EQ(dropped, 0);  // reported once
}

}  // namespace
}  // namespace server
