// terrain-server against an attacker (issue 16): each hole an attack run found, answered. JSON
// nested to overflow the stack, request smuggling through Transfer-Encoding, unauthenticated
// bodies pinning memory, connections beyond the descriptors, pictures that starve tiles or
// outlive their client, scenes stored that cannot be served, bytes that are not UTF-8, a forged
// Host, and a shutdown held by a client that does not read.
#include <gtest/gtest.h>

#include <fstream>
#include <future>
#include <memory>

#include "live_client.hpp"
#include "server/store.hpp"
#include "server_per_test.hpp"
#include "terrain/image_io.hpp"
#include "terrain/scene.hpp"

namespace http_test {
namespace {

/// A server of its own with the given extra flags, started per test.
class HostileClients : public ServerPerTest {
 protected:
  HostileClients() : ServerPerTest("hostile") {}
  bool alive() { return get(port_, "/healthz").result_int() == 200; }
};

std::string nested_arrays(std::size_t depth) {
  return std::string(depth, '[') + std::string(depth, ']');
}

// Whether a new connection is served (not refused at the cap) within `timeout`: the server
// counts a connection out once it has seen it close, a moment after the client did.
bool answered_within(int port, Millis timeout) {
  const auto deadline = Clock::now() + timeout;
  do {
    Connection c(port);
    c.send(request_text("GET", "/healthz"));
    if (c.read().result_int() == 200u) return true;
    std::this_thread::sleep_for(Millis(20));
  } while (Clock::now() < deadline);
  return false;
}

// CPU seconds (user + system) the process has used so far.
double cpu_seconds(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  std::istringstream fields(text.substr(text.rfind(')') + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && fields >> field; ++i) {
    if (i == 14 || i == 15) ticks += std::stod(field);
  }
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

// ---------------------------------------------------------------------------------------------
// 1. JSON nested deep enough to overflow the stack

TEST_F(HostileClients, DeeplyNestedJsonIsRefusedNamingTheLimitAndTheServerLives) {
  start({"--scene-body-limit", "8M"});
  const std::string deep = nested_arrays(400'000);
  const Response scene = fetch(port_, "PUT", "/api/v1/scenes/deep", with_token(),
                               R"({"format": "terrain-scene/1", "root": )" + deep + "}");
  EXPECT_EQ(scene.result_int(), 400u);
  EXPECT_NE(scene.body().find("more than 192 levels"), std::string::npos) << scene.body();
  const Response planet =
      fetch(port_, "POST", "/api/v1/planets", with_token(), R"({"seed": )" + deep + "}");
  EXPECT_EQ(planet.result_int(), 400u);
  EXPECT_NE(planet.body().find("more than 192 levels"), std::string::npos) << planet.body();

  // Live messages: in the request and in an edit op's value, without any token.
  LiveClient live(port_, "hills-river");
  live.send_text(R"({"type": "edit", "request": )" + deep + "}");
  const json refused = live.next_of("error");
  EXPECT_EQ(refused["status"], 400);
  EXPECT_NE(refused["detail"].get<std::string>().find("more than 192 levels"), std::string::npos)
      << refused.dump();
  live.send_text(R"({"type": "edit", "base": 1, "ops": [{"op": "add", "path": "/x", "value": )" +
                 deep + "}]}");
  EXPECT_EQ(live.next_of("error")["status"], 400);
  live.send(json{{"type", "ping"}});
  EXPECT_EQ(live.next_of("pong")["type"], "pong");  // the connection is still served
  EXPECT_TRUE(alive());
  // Nesting a scene really uses is still read.
  const std::string shallow = nested_arrays(150);
  EXPECT_EQ(fetch(port_, "PUT", "/api/v1/scenes/shallow", with_token(),
                  R"({"format": "terrain-scene/1", "x": )" + shallow + "}")
                .body()
                .find("levels deep"),
            std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// 2. Request smuggling through Transfer-Encoding

TEST_F(HostileClients, TransferEncodingNotFinallyChunkedIs400AndNothingIsSmuggled) {
  start({});
  const std::string smuggled = "GET /api/v1/scenes HTTP/1.1\r\nHost: x\r\n\r\n";
  for (const char* coding : {"gzip", "identity", "chunked, gzip", "xchunked"}) {
    Connection c(port_);
    c.send("PUT /api/v1/scenes/smuggle HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken +
           "\r\nTransfer-Encoding: " + coding + "\r\n\r\n" + smuggled);
    const Response r = c.read();
    EXPECT_EQ(r.result_int(), 400u) << coding;
    EXPECT_EQ(header(r, http::field::content_type), "application/problem+json");
    EXPECT_TRUE(c.closed_within(Millis(2'000))) << coding;
    EXPECT_TRUE(c.received().empty()) << coding << ": a second answer, to the smuggled request";
  }
  Connection both(port_);
  both.send(
      "PUT /api/v1/scenes/smuggle HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n"
      "Content-Length: 5\r\n\r\n0\r\n\r\n");
  EXPECT_EQ(both.read().result_int(), 400u);
  Connection gzip_chunked(port_);
  gzip_chunked.send(
      "PUT /api/v1/scenes/smuggle HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: gzip, chunked\r\n\r\n"
      "0\r\n\r\n");
  EXPECT_EQ(gzip_chunked.read().result_int(), 501u);
  EXPECT_EQ(get(port_, "/api/v1/scenes/smuggle").result_int(), 404u);
}

// ---------------------------------------------------------------------------------------------
// 4. Bodies that pin memory

TEST_F(HostileClients, AWriteWithoutItsTokenIsRefusedBeforeTheBodyIsRead) {
  start({});
  for (const auto& [auth, status] :
       std::vector<std::pair<std::string, unsigned>>{{"", 401u}, {"Bearer wrong", 403u}}) {
    Connection c(port_);
    // A 30 MB upload announced, none of it sent: the answer comes from the header alone.
    c.send("POST /api/v1/images HTTP/1.1\r\nHost: x\r\n" +
           (auth.empty() ? std::string() : "Authorization: " + auth + "\r\n") +
           "Content-Type: image/png\r\nContent-Length: 30000000\r\n\r\n");
    EXPECT_EQ(c.read(false, Millis(3'000)).result_int(), status) << auth;
    EXPECT_TRUE(c.closed_within(Millis(2'000)));
  }
}

TEST_F(HostileClients, BodiesInFlightAreBoundedAcrossConnections) {
  start({"--bodies-in-flight-limit", "1M", "--scene-body-limit", "1M"});
  // One slow upload holds 600 kB of the budget; another of 600 kB does not fit beside it.
  Connection slow(port_);
  slow.send("POST /api/v1/scenes?id=slow HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken +
            "\r\nContent-Length: 600000\r\n\r\n" + std::string(1000, ' '));
  std::this_thread::sleep_for(Millis(200));
  Connection second(port_);
  second.send("POST /api/v1/scenes?id=second HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " +
              kToken + "\r\nContent-Length: 600000\r\n\r\n");
  const Response busy = second.read(false, Millis(3'000));
  EXPECT_EQ(busy.result_int(), 503u);
  EXPECT_EQ(header(busy, http::field::retry_after), "1");
  EXPECT_TRUE(second.closed_within(Millis(2'000)));
  // A small one still fits, and once the slow one gives up the room is back.
  EXPECT_EQ(
      fetch(port_, "POST", "/api/v1/scenes?id=small", with_token(), disc_scene(5)).result_int(),
      201u);
  slow.shutdown_write();
  EXPECT_TRUE(slow.closed_within(Millis(3'000)));
  std::string padded = disc_scene(6);
  padded.append(600000 - padded.size(), ' ');
  EXPECT_EQ(fetch(port_, "POST", "/api/v1/scenes?id=big", with_token(), padded).result_int(), 201u);
}

// ---------------------------------------------------------------------------------------------
// 5. Connections beyond the cap and the descriptors

TEST_F(HostileClients, ConnectionsBeyondTheCapAre503AndClosedAtOnce) {
  start({"--max-connections", "4"});
  std::vector<std::unique_ptr<Connection>> held;
  for (int i = 0; i < 4; ++i) {
    held.push_back(std::make_unique<Connection>(port_));
    held.back()->send(request_text("GET", "/healthz"));
    EXPECT_EQ(held.back()->read().result_int(), 200u);
  }
  Connection extra(port_);
  const Response refused = extra.read(false, Millis(3'000));
  EXPECT_EQ(refused.result_int(), 503u);
  EXPECT_EQ(header(refused, http::field::retry_after), "1");
  EXPECT_TRUE(extra.closed_within(Millis(2'000)));
  // Asked on a connection already served: a new one might still find the server full.
  held.front()->send(request_text("GET", "/metrics"));
  EXPECT_NE(held.front()->read().body().find("\nterrain_connections_refused_total 1\n"),
            std::string::npos);
  held.pop_back();
  EXPECT_TRUE(answered_within(port_, Millis(3'000))) << "no room after a connection closed";
}

TEST_F(HostileClients, ConnectionsBeyondTheDescriptorsGetAnAnswerAndTheServerStaysIdle) {
  // The server is started under a limit of 96 descriptors: the cap becomes half of them, so a
  // flood of connections is answered instead of running the process out of descriptors.
  server_ = std::make_unique<ServerProcess>(dir_.path() / "data",
                                            std::vector<std::string>{"--write-token", kToken}, 96);
  port_ = server_->port();
  std::vector<std::unique_ptr<Connection>> flood;
  for (int i = 0; i < 150; ++i) flood.push_back(std::make_unique<Connection>(port_));
  std::this_thread::sleep_for(Millis(500));
  int refused = 0;
  for (auto& c : flood) {
    if (c->readable_now() && c->closed_within(Millis(100))) ++refused;
  }
  EXPECT_GE(refused, 150 - 48);
  // With the flood still open, the accept loop does not spin.
  const double before = cpu_seconds(server_->pid());
  std::this_thread::sleep_for(Millis(1'000));
  EXPECT_LT(cpu_seconds(server_->pid()) - before, 0.2);
  flood.clear();
  EXPECT_TRUE(answered_within(port_, Millis(3'000)));
}

// ---------------------------------------------------------------------------------------------
// 3. Pictures: costed by their steps, cached, cancelled, and behind tiles

TEST_F(HostileClients, APictureIsCostedByItsStepsAndStoppedAtItsBudget) {
  start({"--picture-steps-per-pixel", "2"});
  // Two steps a pixel cannot trace mountains: the picture stops there and says why.
  const Response stopped =
      get(port_, "/api/v1/scenes/mountain-range@1/render.png?width=64&height=40");
  EXPECT_EQ(stopped.result_int(), 422u) << stopped.body();
  EXPECT_EQ(body_json(stopped)["pointer"], "/width");
  EXPECT_NE(stopped.body().find("sphere-tracing steps"), std::string::npos);
  server_->stop();
  // The estimate counts the steps: refused before any work, naming the field.
  start({});
  const Response refused =
      get(port_, "/api/v1/scenes/mountain-range@1/render.png?width=1920&height=1080");
  EXPECT_EQ(refused.result_int(), 422u);
  EXPECT_NE(refused.body().find("steps x program size"), std::string::npos) << refused.body();
  EXPECT_EQ(metric(port_, "terrain_generation_abandoned_total"), 0.0);
}

TEST_F(HostileClients, PicturesAreCachedLikeProducts) {
  start({});
  const std::string target = "/api/v1/scenes/butte@1/render.png?width=48&height=32&fov=40";
  const Response first = get(port_, target);
  ASSERT_EQ(first.result_int(), 200u) << first.body();
  const Response again = get(port_, target);
  EXPECT_EQ(again.body(), first.body());
  EXPECT_EQ(header(again, http::field::etag), header(first, http::field::etag));
  EXPECT_EQ(get(port_, target, {{"If-None-Match", header(first, http::field::etag)}}).result_int(),
            304u);
  const Response depth = get(port_, "/api/v1/scenes/butte@1/depth.bin?width=48&height=32&fov=40");
  ASSERT_EQ(depth.result_int(), 200u);
  EXPECT_EQ(depth.body().size(), 48u * 32u * 4u);
  EXPECT_EQ(header(depth, "X-Picture-Size"), "48x32");
  EXPECT_EQ(get(port_, "/api/v1/scenes/butte@1/depth.bin?width=48&height=32&fov=40").body(),
            depth.body());
  const Response metrics = get(port_, "/metrics");
  const std::string line = "terrain_generation_seconds_count{product=\"render\",backend=\"cpu\"} 1";
  EXPECT_NE(metrics.body().find(line), std::string::npos) << "rendered more than once";
}

// A picture that would take minutes: mountains, full size, with room to trace them all.
const std::vector<std::string> kLongPictures = {"--max-picture-cost", "1e15",
                                                "--picture-steps-per-pixel", "65536"};
std::string long_picture(int n) {
  return "/api/v1/scenes/mountain-range@1/render.png?width=1280&height=720&fov=" +
         std::to_string(30 + n);
}

TEST_F(HostileClients, APictureWhoseClientLeftStopsAndLeavesTheCoresToOthers) {
  std::vector<std::string> flags = kLongPictures;
  flags.insert(flags.end(), {"--picture-threads", "1", "--generation-threads", "1"});
  start(flags);
  {
    Connection c(port_);
    c.send(request_text("GET", long_picture(0)));
    std::this_thread::sleep_for(Millis(500));
  }  // the client hangs up
  const auto deadline = Clock::now() + Millis(10'000);
  while (metric(port_, "terrain_generation_abandoned_total") < 1.0 && Clock::now() < deadline) {
    std::this_thread::sleep_for(Millis(50));
  }
  EXPECT_EQ(metric(port_, "terrain_generation_abandoned_total"), 1.0);
  // The picture thread is free again: another picture is answered at once.
  EXPECT_EQ(get(port_, "/api/v1/scenes/butte@1/render.png?width=32&height=24").result_int(), 200u);
}

TEST_F(HostileClients, PicturesInFlightNeverQueueATileBehindThem) {
  std::vector<std::string> flags = kLongPictures;
  flags.insert(flags.end(), {"--picture-threads", "2", "--generation-threads", "1"});
  start(flags);
  std::vector<std::unique_ptr<Connection>> pictures;
  for (int i = 0; i < 8; ++i) {
    pictures.push_back(std::make_unique<Connection>(port_));
    pictures.back()->send(request_text("GET", long_picture(i)));
  }
  std::this_thread::sleep_for(Millis(300));
  // Eight pictures of minutes each are rendering or queued; an uncached tile is answered while
  // they are (within the I/O timeout, far less than one picture takes).
  const Response tile =
      get(port_, "/api/v1/scenes/mountain-range@1/tiles/1/0/1.png?scheme=local&size=256");
  EXPECT_EQ(tile.result_int(), 200u);
  for (auto& p : pictures) EXPECT_FALSE(p->readable_now()) << "a picture finished already";
  pictures.clear();  // all eight hang up and stop
  const auto deadline = Clock::now() + Millis(10'000);
  while (metric(port_, "terrain_generation_abandoned_total") < 8.0 && Clock::now() < deadline) {
    std::this_thread::sleep_for(Millis(50));
  }
  EXPECT_EQ(metric(port_, "terrain_generation_abandoned_total"), 8.0);
}

// ---------------------------------------------------------------------------------------------
// 6. Scenes that could not be served, and image work

TEST_F(HostileClients, ASceneWhoseImagesExceedTheBoundIsRefusedAndNothingIsStored) {
  start({"--scene-image-pixels", "20000"});
  const std::vector<std::uint16_t> flat(100 * 100, 30000);  // 10,000 pixels
  const auto png = terrain::encode_png16(100, 100, flat.data());
  ASSERT_TRUE(png);
  const Response uploaded =
      fetch(port_, "POST", "/api/v1/images", with_token({{"Content-Type", "image/png"}}),
            std::string(png->begin(), png->end()));
  ASSERT_EQ(uploaded.result_int(), 201u) << uploaded.body();
  const std::string hash = body_json(uploaded)["hash"];
  auto scene_with = [&](int images) {
    json children = json::array();
    for (int i = 0; i < images; ++i) {
      children.push_back({{"type", "image"},
                          {"image", hash},
                          {"corners", {{0, 100}, {100, 100}, {100, 0}, {0, 0}}},
                          {"height_scale", 10 + i}});
    }
    return json{{"format", "terrain-scene/1"},
                {"name", "images"},
                {"root", {{"type", "blend"}, {"children", children}}}}
        .dump();
  };
  EXPECT_EQ(fetch(port_, "POST", "/api/v1/scenes?id=two", with_token(), scene_with(2)).result_int(),
            201u);
  const Response three =
      fetch(port_, "POST", "/api/v1/scenes?id=three", with_token(), scene_with(3));
  EXPECT_EQ(three.result_int(), 400u);
  EXPECT_NE(three.body().find("limits.scene_image_pixels"), std::string::npos) << three.body();
  EXPECT_EQ(get(port_, "/api/v1/scenes/three").result_int(), 404u);
  EXPECT_EQ(get(port_, "/api/v1/scenes/two@1/tiles/0/0/0.png?scheme=local&size=64").result_int(),
            200u);
}

// Limits added later (a scene name's length) refuse new input, never what is stored already.
TEST_F(HostileClients, AVersionStoredBeforeANewLimitStaysReadable) {
  {
    auto store = server::open_sqlite_store((dir_.path() / "data").string());
    ASSERT_TRUE(store);
    json document = json::parse(disc_scene(5));
    document["name"] = std::string(1000, 'n');
    terrain::ParseOptions lenient;
    lenient.limits.max_name_bytes = 100'000;
    const auto scene = terrain::parse_scene_text(document.dump(), lenient);
    ASSERT_TRUE(scene) << scene.error().message;
    server::SceneVersion first;
    first.name = scene->name;
    first.hash = scene->hash;
    first.canonical_json = scene->canonical_text();
    first.author = "before the limit";
    ASSERT_TRUE((*store)->create_scene("long-name", first));
  }
  start({});
  EXPECT_EQ(get(port_, "/api/v1/scenes/long-name@1").result_int(), 200u);
  EXPECT_EQ(
      get(port_, "/api/v1/scenes/long-name@1/tiles/0/0/0.png?scheme=local&size=64").result_int(),
      200u);
  // A new version must meet today's limits.
  const Response again = fetch(port_, "PUT", "/api/v1/scenes/long-name", with_token(),
                               json::parse(get(port_, "/api/v1/scenes/long-name@1").body()).dump());
  EXPECT_EQ(again.result_int(), 400u);
  EXPECT_EQ(body_json(again)["pointer"], "/name");
}

TEST_F(HostileClients, VersionRefsOfOneVersionAreOneAndMalformedOnesAre400) {
  start({});
  const Response plain = get(port_, "/api/v1/scenes/butte@1");
  ASSERT_EQ(plain.result_int(), 200u);
  for (const char* spelling : {"butte@01", "butte@0001"}) {
    const Response r = get(port_, std::string("/api/v1/scenes/") + spelling);
    EXPECT_EQ(r.result_int(), 200u) << spelling;
    EXPECT_EQ(r.body(), plain.body()) << spelling;
  }
  for (const char* bad : {"butte@0", "butte@-1", "butte@sha256:ABC", "butte@sha256:12"}) {
    EXPECT_EQ(get(port_, std::string("/api/v1/scenes/") + bad).result_int(), 400u) << bad;
  }
}

// ---------------------------------------------------------------------------------------------
// 7, 8. Bytes that are not UTF-8, a forged Host, 426 with close, a shutdown held by a reader

TEST_F(HostileClients, BytesThatAreNotUtf8Are400WithTheByteEscaped) {
  start({});
  const Response r = fetch(port_, "PUT", "/api/v1/scenes/bad-bytes", with_token(),
                           "{\"format\": \"terrain-scene/1\", \"name\": \"\xff\xfe\"}");
  EXPECT_EQ(r.result_int(), 400u) << r.body();
  const json problem = body_json(r);  // valid JSON, whatever the bytes were
  EXPECT_NE(problem["detail"].get<std::string>().find("\\xFF"), std::string::npos) << r.body();
  const Response query = get(port_, "/api/v1/scenes/butte@1/tiles/0/0/0.png?scheme=%FF%FE&size=64");
  EXPECT_EQ(query.result_int(), 400u) << query.body();
  EXPECT_NO_THROW(body_json(query));
}

TEST_F(HostileClients, TileJsonUrlsComeFromAValidatedHostOrThePublicUrl) {
  start({});
  auto with_host = [&](const std::string& target, const std::string& host) {
    Connection c(port_);
    c.send("GET " + target + " HTTP/1.1\r\nHost: " + host + "\r\n\r\n");
    return c.read();
  };
  const Response forged =
      with_host("/api/v1/scenes/butte/tilejson.json", "evil.example/x?y=<script>");
  EXPECT_EQ(forged.result_int(), 400u);
  EXPECT_EQ(body_json(forged)["pointer"], "/headers/host");
  Connection twice(port_);
  twice.send(
      "GET /api/v1/scenes/butte/tilejson.json HTTP/1.1\r\nHost: 127.0.0.1\r\n"
      "Host: evil.example\r\n\r\n");
  EXPECT_EQ(twice.read().result_int(), 400u);
  const Response named = get(port_, "/api/v1/scenes/butte/tilejson.json");
  ASSERT_EQ(named.result_int(), 200u);
  EXPECT_EQ(body_json(named)["tiles"][0].get<std::string>().rfind("http://127.0.0.1/", 0), 0u);
  const Response v6 = with_host("/api/v1/planets/default/tilejson.json", "[::1]:8080");
  ASSERT_EQ(v6.result_int(), 200u);
  EXPECT_EQ(body_json(v6)["tiles"][0].get<std::string>().rfind("http://[::1]:8080/", 0), 0u);
  server_->stop();
  start({"--public-url", "https://tiles.example.com/"});
  const Response configured = with_host("/api/v1/scenes/butte/tilejson.json", "evil.example");
  ASSERT_EQ(configured.result_int(), 200u);
  EXPECT_EQ(body_json(configured)["tiles"][0].get<std::string>().rfind(
                "https://tiles.example.com/api/v1/", 0),
            0u);
}

TEST_F(HostileClients, UpgradeRequiredHonoursConnectionClose) {
  start({});
  Connection c(port_);
  c.send(request_text("GET", "/api/v1/scenes/butte/live", {{"Connection", "close"}}));
  const Response r = c.read();
  EXPECT_EQ(r.result_int(), 426u);
  EXPECT_NE(header(r, http::field::connection).find("close"), std::string::npos);
  EXPECT_TRUE(c.closed_within(Millis(2'000)));
}

TEST_F(HostileClients, SigtermDoesNotWaitLongerThanTheGracePeriodForAClientThatDoesNotRead) {
  start({"--shutdown-timeout-ms", "500"});
  Connection c(port_);
  // Pipelined requests whose answers fill both socket buffers: the server's write blocks.
  std::string requests;
  for (int i = 0; i < 1000; ++i) requests += request_text("GET", "/api/v1/openapi.json");
  c.send(requests, Millis(5'000));
  std::this_thread::sleep_for(Millis(300));
  const auto signalled = Clock::now();
  server_->signal(SIGTERM);
  const auto code = server_->wait_exit(Millis(5'000));
  ASSERT_TRUE(code.has_value()) << "still running 5 s after SIGTERM";
  EXPECT_EQ(*code, 0);
  EXPECT_LT(Clock::now() - signalled, Millis(3'000));
  server_.reset();
}

}  // namespace
}  // namespace http_test
