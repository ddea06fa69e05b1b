// terrain-server on the PostgreSQL store, end to end: two real server processes on one database
// serve the same scenes, and their concurrent PUTs become distinct consecutive versions; while
// PostgreSQL is down writes answer 503 with Retry-After and store nothing, and once it is back
// they succeed again.
#include <gtest/gtest.h>

#include <set>

#include "http_harness.hpp"
#include "postgres_cluster.hpp"

namespace http_test {
namespace {

std::vector<std::string> postgres_flags(const std::string& url) {
  return {"--write-token", kToken, "--store-backend", "postgres", "--postgres-url", url};
}

TEST(PostgresHttp, TwoReplicasShareScenesAndSerialiseVersions) {
  const std::string url = pg_test::shared_cluster().create_database();
  TempDir dir("pg-replicas");
  ServerProcess a(dir.path() / "a", postgres_flags(url));
  ServerProcess b(dir.path() / "b", postgres_flags(url));
  // The first replica loaded the built-in scenes; the second found them.
  const Response listed = get(b.port(), "/api/v1/scenes");
  ASSERT_EQ(listed.result_int(), 200u);
  EXPECT_EQ(body_json(listed), body_json(get(a.port(), "/api/v1/scenes")));
  EXPECT_FALSE(body_json(listed)["scenes"].empty()) << listed.body();

  const Response created =
      fetch(a.port(), "POST", "/api/v1/scenes?id=shared", with_token(), disc_scene(100, "Shared"));
  ASSERT_EQ(created.result_int(), 201u) << created.body();
  const Response read = get(b.port(), "/api/v1/scenes/shared");
  ASSERT_EQ(read.result_int(), 200u) << read.body();
  EXPECT_EQ(header(read, http::field::etag), header(created, http::field::etag));
  EXPECT_EQ(body_json(read)["name"], "Shared");

  // PUTs through both replicas at once: every one is stored, as its own version.
  constexpr int kEach = 5;
  std::vector<std::thread> writers;
  std::vector<unsigned> statuses(2 * kEach);
  for (int r = 0; r < 2; ++r) {
    writers.emplace_back([&, r] {
      const int port = r == 0 ? a.port() : b.port();
      for (int i = 0; i < kEach; ++i) {
        statuses[static_cast<std::size_t>(r * kEach + i)] =
            fetch(port, "PUT", "/api/v1/scenes/shared", with_token(),
                  disc_scene(200 + r * kEach + i, "Shared"))
                .result_int();
      }
    });
  }
  for (std::thread& w : writers) w.join();
  for (unsigned s : statuses) EXPECT_EQ(s, 200u);
  const json history = body_json(get(a.port(), "/api/v1/scenes/shared/versions"));
  ASSERT_EQ(history["versions"].size(), std::size_t{2 * kEach + 1});
  std::set<std::string> hashes;
  for (std::size_t i = 0; i < history["versions"].size(); ++i) {
    EXPECT_EQ(history["versions"][i]["version"], i + 1);
    hashes.insert(history["versions"][i]["hash"].get<std::string>());
  }
  EXPECT_EQ(hashes.size(), std::size_t{2 * kEach + 1});

  // If-Match holds across replicas: the head B reports is what A compares against.
  const std::string head = header(get(b.port(), "/api/v1/scenes/shared"), http::field::etag);
  ASSERT_EQ(fetch(a.port(), "PUT", "/api/v1/scenes/shared", with_token({{"If-Match", head}}),
                  disc_scene(1, "Shared"))
                .result_int(),
            200u);
  EXPECT_EQ(fetch(b.port(), "PUT", "/api/v1/scenes/shared", with_token({{"If-Match", head}}),
                  disc_scene(2, "Shared"))
                .result_int(),
            412u);
  a.stop();
  b.stop();
}

TEST(PostgresHttp, WritesAnswer503WhilePostgresIsDownAndResumeAfter) {
  pg_test::Cluster& cluster = pg_test::shared_cluster();
  const std::string url = cluster.create_database();
  TempDir dir("pg-restart");
  ServerProcess server(dir.path() / "data", postgres_flags(url));
  const int port = server.port();
  ASSERT_EQ(fetch(port, "POST", "/api/v1/scenes?id=down", with_token(), disc_scene(1)).result_int(),
            201u);

  cluster.stop();
  const Response refused = fetch(port, "PUT", "/api/v1/scenes/down", with_token(), disc_scene(2));
  const Response created =
      fetch(port, "POST", "/api/v1/scenes?id=other", with_token(), disc_scene(3));
  cluster.start();
  EXPECT_EQ(refused.result_int(), 503u) << refused.body();
  EXPECT_EQ(header(refused, http::field::retry_after), "1");
  EXPECT_EQ(header(refused, http::field::content_type), "application/problem+json");
  EXPECT_EQ(created.result_int(), 503u) << created.body();

  // Retrying as Retry-After says succeeds once PostgreSQL is back.
  Response retried = fetch(port, "PUT", "/api/v1/scenes/down", with_token(), disc_scene(2));
  for (int i = 0; i < 40 && retried.result_int() == 503u; ++i) {
    std::this_thread::sleep_for(Millis(250));
    retried = fetch(port, "PUT", "/api/v1/scenes/down", with_token(), disc_scene(2));
  }
  ASSERT_EQ(retried.result_int(), 200u) << retried.body();
  EXPECT_EQ(body_json(retried)["version"], 2);  // the refused PUT stored nothing
  EXPECT_EQ(get(port, "/api/v1/scenes/other").result_int(), 404u);
  server.stop();
}

}  // namespace
}  // namespace http_test
