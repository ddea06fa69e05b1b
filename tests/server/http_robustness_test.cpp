// terrain-server under abuse and failure, end to end: oversized, slow and malformed requests are
// answered (or closed) within their limits; costly requests are refused before work; a full
// generation queue sheds load with 503 instead of hanging; SIGTERM lets in-flight requests
// finish; kill -9 loses no acknowledged write and leaves a consistent database.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <map>
#include <memory>
#include <mutex>

#include "server_per_test.hpp"
#include "terrain/image_io.hpp"

namespace http_test {
namespace {

// A tile that takes a noticeable while to generate: the largest size of a scene with thirty
// instanced mountains, at the zoom where the whole scene is in view. `n` makes it uncached.
std::string heavy_tile(int n) {
  return "/api/v1/scenes/mountain-range@1/tiles/1/" + std::to_string(n % 2) + "/" +
         std::to_string((n / 2) % 2) +
         ".png?scheme=local&size=512&border=" + std::to_string((n / 4) % 2);
}

/// A server of its own with the given extra flags, started per test.
class HttpLimits : public ServerPerTest {
 protected:
  HttpLimits() : ServerPerTest("limits") {}
};

// ---------------------------------------------------------------------------------------------
// Oversized, slow and malformed requests

TEST_F(HttpLimits, HeaderOver8KiBIs431) {
  start({});
  Connection c(port_);
  c.send(request_text("GET", "/healthz", {{"X-Fill", std::string(9 * 1024, 'a')}}));
  const Response r = c.read();
  EXPECT_EQ(r.result_int(), 431u);
  EXPECT_EQ(header(r, http::field::content_type), "application/problem+json");
  EXPECT_TRUE(c.closed_within(Millis(2'000)));
  // Many small fields adding up count too; a header just under the limit passes.
  Connection many(port_);
  Headers fields;
  for (int i = 0; i < 200; ++i) {
    fields.emplace_back("X-F" + std::to_string(i), std::string(60, 'b'));
  }
  many.send(request_text("GET", "/healthz", fields));
  EXPECT_EQ(many.read().result_int(), 431u);
  EXPECT_EQ(get(port_, "/healthz", {{"X-Fill", std::string(7 * 1024, 'a')}}).result_int(), 200u);
}

TEST_F(HttpLimits, ContentLengthAboveTheSceneLimitIs413BeforeTheBodyIsSent) {
  start({"--scene-body-limit", "4096"});
  Connection c(port_);
  // Only the header: the server must answer without waiting for a body it will not accept.
  c.send("POST /api/v1/scenes?id=big HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken +
         "\r\nContent-Type: application/json\r\nContent-Length: 5000000\r\n\r\n");
  const Response r = c.read(false, Millis(3'000));
  EXPECT_EQ(r.result_int(), 413u);
  EXPECT_EQ(header(r, http::field::content_type), "application/problem+json");
  EXPECT_TRUE(c.closed_within(Millis(2'000)));
  // A client that sends the body right away gets the same answer.
  Connection eager(port_);
  eager.send(request_text("POST", "/api/v1/scenes?id=big", with_token(), std::string(8000, ' ')));
  EXPECT_EQ(eager.read(false, Millis(3'000)).result_int(), 413u);
  EXPECT_EQ(get(port_, "/api/v1/scenes/big").result_int(), 404u);
}

TEST_F(HttpLimits, ChunkedBodyAboveTheSceneLimitIs413) {
  start({"--scene-body-limit", "4096"});
  Connection c(port_);
  std::string chunk(3000, ' ');
  std::string text =
      "PUT /api/v1/scenes/hills-river HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken +
      "\r\nTransfer-Encoding: chunked\r\n\r\n";
  for (int i = 0; i < 2; ++i) text += "bb8\r\n" + chunk + "\r\n";
  text += "0\r\n\r\n";
  c.send(text);
  EXPECT_EQ(c.read(false, Millis(3'000)).result_int(), 413u);
  const Response versions = get(port_, "/api/v1/scenes/hills-river/versions");
  EXPECT_EQ(body_json(versions)["versions"].size(), 1u);
}

TEST_F(HttpLimits, SlowHeaderIs408AndClosedWithinTheTimeout) {
  start({"--header-timeout-ms", "300"});
  const auto started = Clock::now();
  Connection half(port_);
  half.send("GET /healthz HTTP/1.1\r\nHost: x\r\nX-Slow: ");  // ... and nothing more
  Connection silent(port_);                                   // sends nothing at all
  ASSERT_TRUE(half.closed_within(Millis(3'000)));
  EXPECT_LT(Clock::now() - started, Millis(2'500));
  EXPECT_TRUE(half.received().starts_with("HTTP/1.1 408")) << half.received();
  EXPECT_NE(half.received().find("application/problem+json"), std::string::npos);
  // A connection that never sent a byte is closed without an answer.
  EXPECT_TRUE(silent.closed_within(Millis(3'000)));
  EXPECT_TRUE(silent.received().empty()) << silent.received();
  EXPECT_EQ(get(port_, "/healthz").result_int(), 200u);  // the server is still fine
}

TEST_F(HttpLimits, SlowBodyIs408) {
  start({"--body-timeout-ms", "300"});
  Connection c(port_);
  c.send("PUT /api/v1/scenes/hills-river HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken +
         "\r\nContent-Length: 1000\r\n\r\n{\"format\":");
  const Response r = c.read(false, Millis(3'000));
  EXPECT_EQ(r.result_int(), 408u);
  EXPECT_TRUE(c.closed_within(Millis(2'000)));
  EXPECT_EQ(body_json(get(port_, "/api/v1/scenes/hills-river/versions"))["versions"].size(), 1u);
}

// A keep-alive connection waits the idle timeout for its next request, not the (shorter) header
// timeout of its first, and is closed once the idle timeout has passed.
TEST_F(HttpLimits, KeepAliveConnectionWaitsTheIdleTimeoutThenCloses) {
  start({"--header-timeout-ms", "200", "--idle-timeout-ms", "1500"});
  Connection c(port_);
  c.send(request_text("GET", "/healthz"));
  EXPECT_EQ(c.read().result_int(), 200u);
  std::this_thread::sleep_for(Millis(700));  // more than three header timeouts
  c.send(request_text("GET", "/healthz"));
  EXPECT_EQ(c.read().result_int(), 200u);
  const auto answered = Clock::now();
  ASSERT_TRUE(c.closed_within(Millis(5'000)));
  EXPECT_GE(Clock::now() - answered, Millis(1'300));
  EXPECT_LT(Clock::now() - answered, Millis(4'000));
}

TEST_F(HttpLimits, MalformedRequestsAre400) {
  start({});
  for (const char* text :
       {"GARBAGE\r\n\r\n", "GET /healthz HTTP/1.1 extra\r\nHost: x\r\n\r\n",
        "GET /healthz HTTX/1.1\r\nHost: x\r\n\r\n", "GET\r\n\r\n",
        "GET /healthz HTTP/1.1\r\nHost x\r\n\r\n", "GET /healthz HTTP/1.1\r\nHo st: x\r\n\r\n",
        "GET /healthz HTTP/1.1\r\nContent-Length: abc\r\n\r\n",
        "GET /healthz HTTP/1.1\r\nContent-Length: 1\r\nContent-Length: 2\r\n\r\n",
        // With the token: a write without it is refused before its body is read (401).
        "POST /api/v1/scenes HTTP/1.1\r\nAuthorization: Bearer integration-test-token\r\n"
        "Transfer-Encoding: chunked\r\n\r\nzz\r\n",
        "GET healthz HTTP/1.1\r\nHost: x\r\n\r\n",
        "GET http://elsewhere.example/healthz HTTP/1.1\r\nHost: x\r\n\r\n"}) {
    SCOPED_TRACE(text);
    Connection c(port_);
    c.send(text);
    const Response r = c.read(false, Millis(3'000));
    EXPECT_EQ(r.result_int(), 400u);
  }
  EXPECT_EQ(get(port_, "/healthz").result_int(), 200u);
}

TEST_F(HttpLimits, BodiesAboveOneMebibyteWithinTheRouteLimitAreAccepted) {
  start({});  // default limits: 4 MiB scenes, 32 MiB images
  // A scene padded with whitespace to 2 MiB.
  std::string scene = disc_scene(42);
  scene.insert(1, std::string(2u << 20, ' '));
  const Response created = fetch(port_, "POST", "/api/v1/scenes?id=padded", with_token(), scene);
  EXPECT_EQ(created.result_int(), 201u) << created.body();
  // A 16-bit PNG of noise: incompressible, so well above 1 MiB.
  constexpr int kSide = 1024;
  std::vector<std::uint16_t> noise(kSide * kSide);
  std::uint32_t state = 12345;
  for (std::uint16_t& v : noise) {
    state = state * 1664525u + 1013904223u;
    v = static_cast<std::uint16_t>(state >> 16);
  }
  const auto png = terrain::encode_png16(kSide, kSide, noise.data());
  ASSERT_TRUE(png.ok());
  ASSERT_GT(png->size(), std::size_t{1} << 20);
  const Response uploaded =
      fetch(port_, "POST", "/api/v1/images", with_token(), std::string(png->begin(), png->end()));
  EXPECT_EQ(uploaded.result_int(), 201u) << uploaded.body();
  EXPECT_EQ(body_json(uploaded)["width"], kSide);
}

TEST_F(HttpLimits, CostAboveTheLimitIs422BeforeAnyWork) {
  start({"--max-cost", "100000"});
  const Response r = get(port_, "/api/v1/scenes/mountain-range@1/tiles/0/0/0.png?size=512");
  EXPECT_EQ(r.result_int(), 422u) << r.body();
  EXPECT_EQ(header(r, http::field::content_type), "application/problem+json");
  EXPECT_EQ(metric(port_, "terrain_cache_misses_total"), 0.0);  // refused before the cache
  // A small product of the same scene is within the limit.
  const Response small = get(port_, "/api/v1/scenes/mountain-range@1/mesh/0/0/0.glb?grid=3");
  EXPECT_EQ(small.result_int(), 200u) << small.body();
}

TEST_F(HttpLimits, FullGenerationQueueIs503WithRetryAfterAndNothingHangs) {
  start({"--generation-threads", "1", "--queue-limit", "1", "--max-cost", "1e10"});
  constexpr int kClients = 6;
  std::vector<unsigned> status(kClients, 0);
  std::vector<std::string> retry_after(kClients);
  std::vector<std::string> errors(kClients);
  std::vector<std::thread> clients;
  for (int i = 0; i < kClients; ++i) {
    clients.emplace_back([&, i] {
      try {
        const Response r = get(port_, heavy_tile(i));
        status[static_cast<std::size_t>(i)] = r.result_int();
        retry_after[static_cast<std::size_t>(i)] = header(r, http::field::retry_after);
      } catch (const std::exception& e) {
        errors[static_cast<std::size_t>(i)] = e.what();  // e.g. a timeout: a hang
      }
    });
  }
  for (std::thread& t : clients) t.join();
  int busy = 0, ok = 0;
  for (int i = 0; i < kClients; ++i) {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_TRUE(errors[k].empty()) << errors[k];
    if (status[k] == 503u) {
      ++busy;
      EXPECT_FALSE(retry_after[k].empty());
    } else {
      EXPECT_EQ(status[k], 200u);
      ++ok;
    }
  }
  EXPECT_GE(busy, 1);
  EXPECT_GE(ok, 1);
  EXPECT_GE(metric(port_, "terrain_generation_rejected_total"), 1.0);
  EXPECT_EQ(metric(port_, "terrain_generation_queue"), 0.0);
  EXPECT_EQ(get(port_, heavy_tile(7)).result_int(), 200u);  // served once the queue drained
}

// ---------------------------------------------------------------------------------------------
// Shutdown and crashes

TEST_F(HttpLimits, IoThreadsAnswerWhileTilesGenerateOnThePool) {
  start({"--io-threads", "1", "--generation-threads", "1", "--max-cost", "1e10"});
  Connection heavy(port_);
  heavy.send(request_text("GET", heavy_tile(3)));
  const auto deadline = Clock::now() + Millis(5'000);
  while (metric(port_, "terrain_generation_queue") < 1.0 && !heavy.readable_now() &&
         Clock::now() < deadline) {
  }
  // The only I/O thread must not be the one generating: a cheap request is answered at once.
  const auto asked = Clock::now();
  EXPECT_EQ(get(port_, "/healthz").result_int(), 200u);
  EXPECT_LT(Clock::now() - asked, Millis(250));
  EXPECT_FALSE(heavy.readable_now())
      << "the tile was done before /healthz was answered: generation held the I/O thread";
  EXPECT_EQ(heavy.read().result_int(), 200u);
}

TEST_F(HttpLimits, SigtermLetsAnInFlightRequestFinishThenExitsZero) {
  // The grace period is long enough for a sanitised build; what is tested is that the request in
  // flight is answered, not how long the default grace is. The version is loaded first so that
  // what is in flight is the tile alone, not the scene's compilation as well.
  start({"--generation-threads", "1", "--max-cost", "1e10", "--shutdown-timeout-ms", "60000"});
  ASSERT_EQ(get(port_, "/api/v1/scenes/mountain-range@1").result_int(), 200u);
  Connection c(port_);
  c.send(request_text("GET", heavy_tile(0)));
  // As soon as the request is on the generation pool, ask the server to stop.
  const auto deadline = Clock::now() + Millis(5'000);
  while (metric(port_, "terrain_generation_queue") < 1.0 && Clock::now() < deadline) {
  }
  server_->signal(SIGTERM);
  const Response r = c.read();
  EXPECT_EQ(r.result_int(), 200u);
  EXPECT_FALSE(r.keep_alive());
  const auto raster = terrain::decode_heightfield(
      std::vector<std::uint8_t>(r.body().begin(), r.body().end()), "png");
  ASSERT_TRUE(raster.ok()) << raster.error().message;
  EXPECT_EQ(raster->width, 512);
  EXPECT_EQ(server_->wait_exit(Millis(5'000)), std::optional<int>(0));
}

TEST_F(HttpLimits, SigtermClosesIdleConnectionsAndExitsPromptly) {
  start({});
  Connection idle(port_);  // keep-alive, between requests
  idle.send(request_text("GET", "/healthz"));
  ASSERT_EQ(idle.read().result_int(), 200u);
  Connection fresh(port_);  // connected, nothing sent
  const auto started = Clock::now();
  server_->signal(SIGTERM);
  EXPECT_TRUE(idle.closed_within(Millis(3'000)));
  EXPECT_TRUE(fresh.closed_within(Millis(3'000)));
  EXPECT_EQ(server_->wait_exit(Millis(5'000)), std::optional<int>(0));
  EXPECT_LT(Clock::now() - started, Millis(3'000));
}

std::string sqlite_integrity(const fs::path& file) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    sqlite3_close(db);
    return "cannot open";
  }
  std::string result;
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(db, "PRAGMA integrity_check", -1, &stmt, nullptr) == SQLITE_OK) {
    while (sqlite3_step(stmt) == SQLITE_ROW) {
      result += reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0));
    }
  }
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  return result;
}

TEST_F(HttpLimits, KillNineLosesNoAcknowledgedVersion) {
  start({});
  constexpr int kWriters = 4;
  std::mutex mutex;
  std::map<std::int64_t, std::string> acknowledged;  // version -> hash
  std::atomic<bool> stop{false};
  std::atomic<int> acks{0};
  std::vector<std::thread> writers;
  for (int w = 0; w < kWriters; ++w) {
    writers.emplace_back([&, w] {
      for (int i = 0; !stop; ++i) {
        try {
          const Response r = fetch(port_, "PUT", "/api/v1/scenes/hills-river", with_token(),
                                   disc_scene(w * 100'000 + i));
          if (r.result_int() != 200u) continue;
          const json body = json::parse(r.body());
          std::lock_guard lock(mutex);
          acknowledged[body["version"].get<std::int64_t>()] = body["hash"].get<std::string>();
          ++acks;
        } catch (const std::exception&) {
          return;  // the server is gone: this write was never acknowledged
        }
      }
    });
  }
  const auto deadline = Clock::now() + Millis(10'000);
  while (acks < 20 && Clock::now() < deadline) std::this_thread::sleep_for(Millis(2));
  server_->kill_now();  // SIGKILL while writes are in flight
  stop = true;
  for (std::thread& t : writers) t.join();
  ASSERT_GE(acknowledged.size(), 20u);
  EXPECT_EQ(acknowledged.size(), static_cast<std::size_t>(acks.load()));  // no number twice

  start({});  // the same data directory
  for (const auto& [version, hash] : acknowledged) {
    SCOPED_TRACE(version);
    const Response r = get(port_, "/api/v1/scenes/hills-river@" + std::to_string(version));
    ASSERT_EQ(r.result_int(), 200u) << r.body();
    EXPECT_EQ(header(r, http::field::etag), etag_of(hash));
  }
  const json versions = body_json(get(port_, "/api/v1/scenes/hills-river/versions"));
  EXPECT_GE(versions["versions"].size(), acknowledged.size() + 1);  // + the built-in version 1
  server_->stop();
  EXPECT_EQ(sqlite_integrity(dir_.path() / "data" / "terrain.sqlite3"), "ok");
}

}  // namespace
}  // namespace http_test

namespace http_test {
namespace {

// generation.backend: gpu evaluates tiles and sphere-traces pictures on any EGL device (llvmpipe
// here) and says so per response; image nodes (butte) run on the GPU too. A program the device
// cannot run falls back to the CPU without failing the request: on llvmpipe, one whose
// evaluation would exceed its shader loop limit (2 400 instanced discs; plain ones, so that the
// CPU's fallback stays quick).
TEST_F(HttpLimits, GpuBackendServesGpuTilesAndPicturesAndFallsBackWhenItCannot) {
#if defined(__SANITIZE_THREAD__)
  // The tsan preset's server runs llvmpipe's threads, whose synchronisation (in uninstrumented
  // Mesa) ThreadSanitizer cannot see: it would report races that are not ours.
  GTEST_SKIP() << "llvmpipe under ThreadSanitizer";
#endif
  start({"--backend", "gpu"});
  const Response gpu_tile =
      get(port_, "/api/v1/scenes/craters@1/tiles/1/1/0.png?scheme=local&size=64");
  ASSERT_EQ(gpu_tile.result_int(), 200u);
  const std::string device = header(gpu_tile, "X-Terrain-Backend");
  EXPECT_EQ(device.rfind("gpu: ", 0), 0u) << device;
  const Response image = get(port_, "/api/v1/scenes/butte@1/tiles/1/1/0.png?scheme=local&size=64");
  ASSERT_EQ(image.result_int(), 200u);
  EXPECT_EQ(header(image, "X-Terrain-Backend"), device);
  const Response picture = get(port_, "/api/v1/scenes/butte@1/render.png?width=32&height=24");
  ASSERT_EQ(picture.result_int(), 200u);
  EXPECT_EQ(header(picture, "X-Terrain-Backend"), device);
  EXPECT_EQ(header(picture, http::field::content_type), "image/png");
  if (device.find("llvmpipe") == std::string::npos) return;  // no loop limit to run into

  std::string children;
  for (int i = 0; i < 2400; ++i) children += std::string(i == 0 ? "" : ",") + R"({"ref": "d"})";
  const std::string scene =
      R"({"format": "terrain-scene/1", "name": "many", "seed": 1, "definitions": {"d": {"type":
 "disc", "center": [0, 0], "radius": 500, "elevation": 10}}, "root": {"type": "blend",
 "children": [)" +
      children + "]}}";
  const Response created = fetch(port_, "POST", "/api/v1/scenes?id=many", with_token(), scene);
  ASSERT_EQ(created.result_int(), 201u) << created.body();
  const Response fallback = get(port_, "/api/v1/scenes/many/tiles/0/0/0.png?scheme=local&size=64");
  ASSERT_EQ(fallback.result_int(), 200u);
  EXPECT_EQ(header(fallback, "X-Terrain-Backend").rfind("cpu (fallback: ", 0), 0u)
      << header(fallback, "X-Terrain-Backend");
  const Response cpu_picture = get(port_, "/api/v1/scenes/many/render.png?width=16&height=16");
  ASSERT_EQ(cpu_picture.result_int(), 200u);
  EXPECT_EQ(header(cpu_picture, "X-Terrain-Backend").rfind("cpu (fallback: ", 0), 0u)
      << header(cpu_picture, "X-Terrain-Backend");
  const Response metrics = get(port_, "/metrics");
  EXPECT_NE(metrics.body().find("backend=\"gpu\""), std::string::npos);
  EXPECT_NE(metrics.body().find("backend=\"cpu-fallback\""), std::string::npos);
}

TEST_F(HttpLimits, AutoBackendNeverPicksASoftwareRasteriser) {
  start({"--backend", "auto"});
  const Response r = get(port_, "/api/v1/scenes/craters@1/tiles/1/1/0.png?scheme=local&size=64");
  ASSERT_EQ(r.result_int(), 200u);
  const std::string backend = header(r, "X-Terrain-Backend");
  EXPECT_TRUE(backend == "cpu" || backend.rfind("gpu: ", 0) == 0) << backend;
  EXPECT_EQ(backend.find("llvmpipe"), std::string::npos);
}

}  // namespace
}  // namespace http_test
