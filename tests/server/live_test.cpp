// Live editing over WebSockets (docs/live.md), against the real server on loopback: versions in
// one order for every subscriber, rebasing and conflicts, catch-up after a reconnect, refused
// edits that change nothing, and the limits (1009, slow readers, rate, subscribers, timeouts).
#include <gtest/gtest.h>

#include <set>
#include <thread>

#include "http_harness.hpp"
#include "live_client.hpp"

namespace {

using namespace http_test;

// Four discs in a blend, one per quadrant: edits of different discs do not conflict.
std::string quad_scene() {
  json children = json::array();
  for (const auto& [x, y] : {std::pair{-1000, -1000}, {1000, -1000}, {-1000, 1000}, {1000, 1000}}) {
    children.push_back({{"type", "disc"}, {"center", {x, y}}, {"radius", 500}, {"elevation", 100}});
  }
  return json{{"format", "terrain-scene/1"},
              {"name", "Live quad"},
              {"seed", 1},
              {"extent", {{"min", {-2000, -2000}}, {"max", {2000, 2000}}}},
              {"root", {{"type", "blend"}, {"children", children}}}}
      .dump();
}

json set_elevation(int disc, int elevation) {
  return json::array({{{"op", "replace"},
                       {"path", "/root/children/" + std::to_string(disc) + "/elevation"},
                       {"value", elevation}}});
}

json edit(std::int64_t base, const json& ops, const std::string& request = "") {
  json m = {{"type", "edit"}, {"base", base}, {"ops", ops}};
  if (!request.empty()) m["request"] = request;
  return m;
}

class LiveEditing : public ::testing::Test {
 protected:
  static void start(const std::vector<std::string>& extra = {}) {
    dir_ = std::make_unique<TempDir>("live");
    std::vector<std::string> flags = {"--write-token", kToken};
    flags.insert(flags.end(), extra.begin(), extra.end());
    server_ = std::make_unique<ServerProcess>(dir_->path() / "data", flags);
  }
  static void SetUpTestSuite() {
    start({"--live-edits-per-second", "1000", "--live-edit-burst", "1000", "--live-queue-bytes",
           "262144", "--live-handshake-timeout-ms", "1500", "--live-max-message-bytes", "262144",
           "--live-max-subscribers", "12", "--live-read-bytes-per-second", "67108864"});
  }
  static void TearDownTestSuite() {
    if (server_) server_->stop();
    server_.reset();
    dir_.reset();
  }
  int port() const { return server_->port(); }
  /// terrain_live_oversize_total once it passed `before` (a connection is counted when the
  /// server has finished with it), or after 5 s.
  double oversize_counted(double before) const {
    const auto deadline = Clock::now() + Millis(5000);
    double now = before;
    while ((now = metric(port(), "terrain_live_oversize_total")) <= before &&
           Clock::now() < deadline) {
      std::this_thread::sleep_for(Millis(20));
    }
    return now;
  }

  /// Creates a fresh scene (one per test keeps tests independent).
  std::string create_scene(const std::string& id) const {
    const Response r = fetch(port(), "POST", "/api/v1/scenes?id=" + id, with_token(), quad_scene());
    EXPECT_EQ(r.result_int(), 201u) << r.body();
    return id;
  }
  std::string head_hash(const std::string& id) const {
    const Response r = get(port(), "/api/v1/scenes/" + id);
    const std::string etag = header(r, http::field::etag);
    return etag.size() > 2 ? etag.substr(1, etag.size() - 2) : etag;
  }
  std::int64_t head_version(const std::string& id) const {
    return std::stoll(header(get(port(), "/api/v1/scenes/" + id), "X-Scene-Version"));
  }

  static inline std::unique_ptr<TempDir> dir_;
  static inline std::unique_ptr<ServerProcess> server_;
};

TEST_F(LiveEditing, SubscriberIsWelcomedWithTheHead) {
  const std::string id = create_scene("welcome");
  LiveClient viewer(port(), id);
  const json welcome = viewer.subscribe(false);
  EXPECT_EQ(welcome["scene"], id);
  EXPECT_EQ(welcome["head"], 1);
  EXPECT_EQ(welcome["hash"], head_hash(id));
  EXPECT_EQ(welcome["can_edit"], false);
  viewer.send({{"type", "ping"}});
  EXPECT_EQ(viewer.next()["type"], "pong");
}

TEST_F(LiveEditing, AnEditBecomesAVersionThatEverySubscriberReceives) {
  const std::string id = create_scene("one-edit");
  LiveClient author(port(), id);
  LiveClient viewer(port(), id);
  author.subscribe(true, std::nullopt, "alice");
  viewer.subscribe(false);
  author.send(edit(1, set_elevation(0, 250), "r1"));
  const json seen = viewer.next_of("version");
  const json own = author.next_of("version");
  const json ack = author.next_of("ack");
  EXPECT_EQ(seen, own);
  EXPECT_EQ(seen["version"], 2);
  EXPECT_EQ(seen["previous"], 1);
  EXPECT_EQ(seen["author"], "alice");
  EXPECT_EQ(seen["ops"], set_elevation(0, 250));
  EXPECT_EQ(seen["hash"], head_hash(id));
  EXPECT_EQ(ack["request"], "r1");
  EXPECT_EQ(ack["version"], 2);
  EXPECT_EQ(ack["hash"], seen["hash"]);
  EXPECT_EQ(ack["rebased"], false);
  // The version is a version like any other: its JSON has the new elevation.
  const json scene = body_json(get(port(), "/api/v1/scenes/" + id + "@2"));
  EXPECT_EQ(scene["root"]["children"][0]["elevation"], 250);
}

TEST_F(LiveEditing, ConcurrentEditsConvergeInOneOrderEverywhere) {
  const std::string id = create_scene("converge");
  LiveClient a(port(), id), b(port(), id), observer(port(), id);
  a.subscribe(true, std::nullopt, "a");
  b.subscribe(true, std::nullopt, "b");
  observer.subscribe(false);
  // Enough edits for the writers' threads to interleave: with the fan-out's old ordering bug
  // (live_socket.cpp, deliver), 12 each failed in 0 of 15 runs on a loaded 2-core machine and
  // 30 each in 3 of 15.
  constexpr int kEdits = 30;
  // Both writers append discs without waiting for answers, always against version 1: all but
  // the first edit are rebased onto versions the writer has not seen.
  auto writer = [&](LiveClient& client, int row) {
    for (int i = 0; i < kEdits; ++i) {
      client.send(edit(1, json::array({{{"op", "add"},
                                        {"path", "/root/children/-"},
                                        {"value",
                                         {{"type", "disc"},
                                          {"center", {-1500 + 250 * i, row * 600}},
                                          {"radius", 100},
                                          {"elevation", 50}}}}})));
    }
  };
  std::thread ta([&] { writer(a, 0); });
  std::thread tb([&] { writer(b, 1); });
  ta.join();
  tb.join();
  auto versions_seen = [&](LiveClient& client) {
    std::vector<std::pair<std::int64_t, std::string>> seen;
    while (seen.size() < 2 * kEdits) {
      const json m = client.next();
      if (m["type"] == "version") seen.emplace_back(m["version"], m["hash"]);
      if (m["type"] == "reject") ADD_FAILURE() << m.dump();
    }
    return seen;
  };
  const auto at_a = versions_seen(a);
  const auto at_b = versions_seen(b);
  const auto at_observer = versions_seen(observer);
  EXPECT_EQ(at_a, at_observer);
  EXPECT_EQ(at_b, at_observer);
  for (std::size_t i = 0; i < at_observer.size(); ++i) {
    EXPECT_EQ(at_observer[i].first, static_cast<std::int64_t>(i) + 2);
  }
  EXPECT_EQ(at_observer.back().second, head_hash(id));
  const json scene = body_json(get(port(), "/api/v1/scenes/" + id));
  EXPECT_EQ(scene["root"]["children"].size(), 4u + 2 * kEdits);
}

TEST_F(LiveEditing, AnOldBaseIsRebasedWhenItsOpsStillApply) {
  const std::string id = create_scene("rebase");
  LiveClient a(port(), id), b(port(), id);
  a.subscribe(true);
  b.subscribe(true);
  a.send(edit(1, set_elevation(0, 300)));
  EXPECT_EQ(a.next_of("ack")["version"], 2);
  b.send(edit(1, set_elevation(3, 40), "late"));  // written against version 1
  const json ack = b.next_of("ack");
  EXPECT_EQ(ack["version"], 3);
  EXPECT_EQ(ack["rebased"], true);
  const json scene = body_json(get(port(), "/api/v1/scenes/" + id));
  EXPECT_EQ(scene["root"]["children"][0]["elevation"], 300);
  EXPECT_EQ(scene["root"]["children"][3]["elevation"], 40);
}

TEST_F(LiveEditing, AnOldBaseThatTouchesAChangedValueIsRejected) {
  const std::string id = create_scene("conflict");
  LiveClient a(port(), id), b(port(), id);
  a.subscribe(true);
  b.subscribe(true);
  a.send(edit(1, set_elevation(2, 300)));
  EXPECT_EQ(a.next_of("ack")["version"], 2);
  b.send(edit(1, set_elevation(2, 10), "stale"));
  const json reject = b.next_of("reject");
  EXPECT_EQ(reject["status"], 409);
  EXPECT_EQ(reject["request"], "stale");
  EXPECT_EQ(reject["pointer"], "/ops/0/path");
  EXPECT_NE(reject["detail"].get<std::string>().find("/root/children/2/elevation"),
            std::string::npos);
  // Removing an earlier disc moves the later ones: their paths conflict too.
  a.send(edit(2, json::array({{{"op", "remove"}, {"path", "/root/children/0"}}})));
  EXPECT_EQ(a.next_of("ack")["version"], 3);
  b.send(edit(2, set_elevation(3, 10)));
  EXPECT_EQ(b.next_of("reject")["status"], 409);
  EXPECT_EQ(head_version(id), 3);
}

TEST_F(LiveEditing, AReconnectingClientCatchesUpInOrder) {
  const std::string id = create_scene("catch-up");
  std::int64_t known = 0;
  {
    LiveClient viewer(port(), id);
    known = viewer.subscribe(false)["head"];
    viewer.close();
  }
  {
    LiveClient author(port(), id);
    author.subscribe(true);
    for (int i = 0; i < 3; ++i) {
      author.send(edit(known + i, set_elevation(i, 200 + i)));
      author.next_of("ack");
    }
  }
  // A PUT lands among the edits: it is a version like the others, without ops.
  const Response put = fetch(port(), "PUT", "/api/v1/scenes/" + id, with_token(), quad_scene());
  ASSERT_EQ(put.result_int(), 200u) << put.body();
  LiveClient back(port(), id);
  const json welcome = back.subscribe(false, known);
  EXPECT_EQ(welcome["head"], known + 4);
  for (std::int64_t v = known + 1; v <= known + 4; ++v) {
    const json m = back.next_of("version");
    EXPECT_EQ(m["version"], v);
    EXPECT_EQ(m["previous"], v - 1);
    if (v <= known + 3) {
      EXPECT_EQ(m["ops"], set_elevation(static_cast<int>(v - known - 1),
                                        static_cast<int>(200 + v - known - 1)));
    } else {
      EXPECT_TRUE(m["ops"].is_null());
      EXPECT_EQ(m["author"], "api");
    }
  }
  EXPECT_FALSE(back.message_within(Millis(200)));
}

TEST_F(LiveEditing, InvalidEditsAreRejectedAndChangeNothing) {
  const std::string id = create_scene("invalid");
  LiveClient author(port(), id), observer(port(), id);
  author.subscribe(true);
  observer.subscribe(false);
  const std::string before = head_hash(id);
  struct Case {
    json message;
    int status;
    std::string pointer;
  };
  const std::vector<Case> cases = {
      {edit(1, json::array({{{"op", "explode"}, {"path", "/name"}}})), 400, "/ops/0/op"},
      {edit(1, json::array({{{"op", "replace"}, {"value", 1}}})), 400, "/ops/0/path"},
      {edit(1, json::array({{{"op", "replace"}, {"path", "no-slash"}, {"value", 1}}})), 400,
       "/ops/0/path"},
      {edit(1, json::array({{{"op", "add"}, {"path", "/root/children/0/x"}}})), 400,
       "/ops/0/value"},
      {edit(1,
            json::array({{{"op", "replace"}, {"path", "/root/children/9/radius"}, {"value", 1}}})),
       400, "/ops/0"},
      {edit(1,
            json::array({{{"op", "replace"}, {"path", "/root/children/0/radius"}, {"value", -5}}})),
       400, "/ops"},
      {edit(1, json::array()), 400, "/ops"},
      {edit(7, set_elevation(0, 1)), 409, "/base"},
      {{{"type", "edit"}, {"ops", set_elevation(0, 1)}}, 400, "/base"},
      {{{"type", "edit"}, {"base", 1}, {"ops", "replace"}}, 400, "/ops"},
  };
  for (const Case& c : cases) {
    author.send(c.message);
    const json reject = author.next_of("reject");
    EXPECT_EQ(reject["status"], c.status) << c.message.dump() << " → " << reject.dump();
    EXPECT_EQ(reject.value("pointer", ""), c.pointer) << reject.dump();
  }
  // A scene that does not validate names the scene's field.
  author.send(edit(
      1, json::array({{{"op", "replace"}, {"path", "/root/children/0/radius"}, {"value", -5}}})));
  EXPECT_NE(author.next_of("reject")["detail"].get<std::string>().find("radius"),
            std::string::npos);
  // Messages that are not edits get an error and leave the connection open.
  author.send_text("not json");
  EXPECT_EQ(author.next_of("error")["status"], 400);
  author.send({{"type", "dance"}});
  EXPECT_EQ(author.next_of("error")["pointer"], "/type");
  EXPECT_EQ(head_hash(id), before);
  EXPECT_EQ(head_version(id), 1);
  EXPECT_FALSE(observer.message_within(Millis(200)));  // no version event went out
}

TEST_F(LiveEditing, EditsNeedTheWriteToken) {
  const std::string id = create_scene("token");
  LiveClient viewer(port(), id);
  viewer.subscribe(false);
  viewer.send(edit(1, set_elevation(0, 5)));
  EXPECT_EQ(viewer.next_of("reject")["status"], 401);
  LiveClient wrong(port(), id);
  wrong.send({{"type", "subscribe"}, {"token", "guess"}});
  EXPECT_EQ(wrong.next_of("error")["status"], 403);
  EXPECT_EQ(LiveClient::try_open(port(), id, {{"Authorization", "Bearer guess"}}), 403);
  // The header works for clients that can send one.
  LiveClient header_editor(port(), id, with_token());
  EXPECT_EQ(header_editor.subscribe(false)["can_edit"], true);
  EXPECT_EQ(head_version(id), 1);
}

TEST_F(LiveEditing, UpgradesAreRefusedClearly) {
  create_scene("refusals");
  EXPECT_EQ(LiveClient::try_open(port(), "no-such-scene"), 404);
  EXPECT_EQ(LiveClient::try_open(port(), "refusals@1"), 400);
  const Response plain = get(port(), "/api/v1/scenes/refusals/live");
  EXPECT_EQ(plain.result_int(), 426u);
  EXPECT_EQ(header(plain, http::field::content_type), "application/problem+json");
}

TEST_F(LiveEditing, OversizeMessagesCloseWith1009) {
  const std::string id = create_scene("oversize");
  // On the wire, so that what the server sends is seen byte for byte: an upgrade, then one
  // masked text frame that announces more than the 256 kB the test server accepts.
  Connection c(port());
  c.send(request_text("GET", "/api/v1/scenes/" + id + "/live",
                      {{"Upgrade", "websocket"},
                       {"Connection", "Upgrade"},
                       {"Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="},
                       {"Sec-WebSocket-Version", "13"}}));
  ASSERT_EQ(c.read().result_int(), 101u);
  std::string frame = {'\x81', '\xff'};  // FIN + text; masked, 64-bit length
  const std::uint64_t length = 300000;
  for (int shift = 56; shift >= 0; shift -= 8) frame += static_cast<char>((length >> shift) & 0xff);
  frame += std::string(4, '\0');    // mask key
  frame += std::string(1000, 'x');  // the start of the payload
  const double oversize_before = metric(port(), "terrain_live_oversize_total");
  c.send(frame);
  c.shutdown_write();
  EXPECT_TRUE(c.closed_within(Millis(5000)));
  // A close frame with code 1009 (0x03f1): "message too big".
  EXPECT_EQ(c.received().substr(0, 4), std::string("\x88\x02\x03\xf1", 4));
  EXPECT_EQ(oversize_counted(oversize_before), oversize_before + 1);
  EXPECT_EQ(head_version(id), 1);
}

// Hand-made frames: what one message may take on the wire, frame headers included.
// The test server's budget: 2 × its 256 KiB message size + 16 KiB (docs/live.md, "Limits").
constexpr std::size_t kWireBudget = 2 * 262144 + 16384;
const std::string kPing = R"({"type":"ping"})";

// Empty continuation frames (6 bytes each on the wire), `bytes` of them at most.
std::string empty_frames(std::size_t bytes) {
  const std::string one = client_frame(false, 0);
  std::string frames;
  frames.reserve(bytes);
  while (frames.size() + one.size() <= bytes) frames += one;
  return frames;
}

TEST_F(LiveEditing, AMessageInManyFramesWithinItsWireBudgetArrives) {
  const std::string id = create_scene("many-frames");
  LiveClient client(port(), id);
  client.subscribe(false);
  // Nearly the largest message, in 16-byte frames: 1.4 times its size on the wire.
  const std::string text = kPing + std::string(250000 - kPing.size(), ' ');
  std::string frames;
  for (std::size_t at = 0; at < text.size(); at += 16) {
    frames += client_frame(at + 16 >= text.size(), at == 0 ? 1 : 0, text.substr(at, 16));
  }
  ASSERT_TRUE(client.send_raw(frames));
  EXPECT_EQ(client.next()["type"], "pong");
  // Empty frames up to just below the budget, then the end of the message.
  ASSERT_TRUE(client.send_raw(client_frame(false, 1, "{") + empty_frames(kWireBudget - 4096) +
                              client_frame(true, 0, kPing.substr(1))));
  EXPECT_EQ(client.next()["type"], "pong");
}

TEST_F(LiveEditing, AMessageBeyondItsWireBudgetCutsTheConnection) {
  const std::string id = create_scene("wire-budget");
  LiveClient client(port(), id);
  client.subscribe(false);
  const double oversize_before = metric(port(), "terrain_live_oversize_total");
  // The server may cut the connection before the last frames are written.
  (void)client.send_raw(client_frame(false, 1, "{") + empty_frames(kWireBudget + 4096) +
                        client_frame(true, 0, kPing.substr(1)));
  EXPECT_EQ(client.close_code(Millis(5000)), 0);  // no pong, no close frame
  EXPECT_EQ(oversize_counted(oversize_before), oversize_before + 1);
}

// The attack as it was seen: one message that never ends, 26 million empty frames in 8 s, each
// parsed by the server.
TEST_F(LiveEditing, AnEndlessMessageOfEmptyFramesIsCut) {
  const std::string id = create_scene("endless");
  LiveClient client(port(), id);
  client.subscribe(false);
  ASSERT_TRUE(client.send_raw(client_frame(false, 1, "{")));
  const std::string burst = empty_frames(60000);
  std::size_t sent = 0;
  const auto deadline = Clock::now() + Millis(10000);
  while (Clock::now() < deadline && client.send_raw(burst, Millis(2000))) sent += burst.size();
  ASSERT_LT(Clock::now(), deadline) << "the server still reads after " << sent << " bytes";
  // What got out: the budget, plus what the loopback's socket buffers hold.
  EXPECT_LT(sent, kWireBudget + (16u << 20));
  EXPECT_EQ(client.close_code(Millis(5000)), 0);
}

TEST_F(LiveEditing, AClientThatNeverSubscribesIsClosed) {
  const std::string id = create_scene("silent");
  LiveClient client(port(), id);
  EXPECT_EQ(client.close_code(Millis(5000)), 1008);
}

TEST_F(LiveEditing, ANonReadingClientIsCutOffWhileMemoryStaysBounded) {
  const std::string id = create_scene("slow-reader");
  LiveClient slow(port(), id, {}, 4096);
  slow.subscribe(false);  // and then never reads again
  LiveClient author(port(), id), fast(port(), id);
  author.subscribe(true);
  fast.subscribe(false);
  const double cut_before = metric(port(), "terrain_live_slow_readers_total");
  double most_owed = 0;
  // Each version event carries its ops: 200 kB of node label per edit, 60 edits = 12 MB of
  // events for each subscriber, far beyond the 256 kB backlog the test server allows one
  // connection.
  const std::string padding(200000, 'n');
  for (int i = 0; i < 60; ++i) {
    author.send(edit(1 + i, json::array({{{"op", "add"},
                                          {"path", "/root/children/0/id"},
                                          {"value", padding + std::to_string(i)}}})));
    author.next_of("ack");
    EXPECT_EQ(fast.next_of("version")["version"], 2 + i);
    most_owed = std::max(most_owed, metric(port(), "terrain_live_backlog_bytes"));
  }
  EXPECT_EQ(metric(port(), "terrain_live_slow_readers_total"), cut_before + 1);
  // What the server holds for its live connections never passed their limits (256 kB each, one
  // message of slack), although the slow reader was owed 12 MB.
  EXPECT_LE(most_owed, 3 * (262144 + 200100));
  // What the slow reader finds when it finally reads: some events, then the end.
  int received = 0;
  while (slow.message_within(Millis(1000))) ++received;
  EXPECT_LT(received, 60);
}

TEST(LiveLimits, EditsAreRateLimitedPerConnection) {
  TempDir dir("live-rate");
  ServerProcess server(dir.path() / "data", {"--write-token", kToken, "--live-edits-per-second",
                                             "1", "--live-edit-burst", "3"});
  const Response created =
      fetch(server.port(), "POST", "/api/v1/scenes?id=rate", with_token(), quad_scene());
  ASSERT_EQ(created.result_int(), 201u) << created.body();
  LiveClient author(server.port(), "rate");
  author.subscribe(true);
  for (int i = 0; i < 3; ++i) {
    author.send(edit(1 + i, set_elevation(0, 10 + i)));
    EXPECT_EQ(author.next_of("ack")["version"], 2 + i);
  }
  author.send(edit(4, set_elevation(0, 99)));
  EXPECT_EQ(author.next_of("reject")["status"], 429);
  EXPECT_EQ(header(get(server.port(), "/api/v1/scenes/rate"), "X-Scene-Version"), "4");
  server.stop();
}

// Reads are paced: 112 kB of pings on a server that reads 64 KiB a second of one connection, in
// bursts of one second's worth (more than one message's wire budget, 2 × 16 KiB + 16 KiB).
TEST(LiveLimits, WhatOneConnectionSendsIsReadAtTheConfiguredRate) {
  TempDir dir("live-read-rate");
  ServerProcess server(dir.path() / "data", {"--write-token", kToken, "--live-max-message-bytes",
                                             "16384", "--live-read-bytes-per-second", "65536"});
  const Response created =
      fetch(server.port(), "POST", "/api/v1/scenes?id=paced", with_token(), quad_scene());
  ASSERT_EQ(created.result_int(), 201u) << created.body();
  LiveClient client(server.port(), "paced");
  client.subscribe(false);
  const std::string padded_ping = R"({"type":"ping"})" + std::string(16000, ' ');
  const auto start = Clock::now();
  for (int i = 0; i < 7; ++i) client.send_text(padded_ping);
  for (int i = 0; i < 7; ++i) EXPECT_EQ(client.next()["type"], "pong");
  // 64 KiB at once (a full bucket), the rest at 64 KiB/s: at least (sent - 64 KiB) / rate, about
  // 0.71 s. Unpaced, a few milliseconds. (Not a full second: the bucket refills while the first
  // burst is read, and basic_stream's one-second ticks run from the connection's start.)
  const double sent = 7.0 * static_cast<double>(padded_ping.size());
  const auto paced = std::chrono::duration<double>((sent - 65536.0) / 65536.0);
  EXPECT_GE(std::chrono::duration<double>(Clock::now() - start).count(), 0.9 * paced.count());
  server.stop();
}

TEST_F(LiveEditing, SubscribersPerSceneAreBounded) {
  const std::string id = create_scene("crowd");
  std::vector<std::unique_ptr<LiveClient>> crowd;
  for (int i = 0; i < 12; ++i) {
    crowd.push_back(std::make_unique<LiveClient>(port(), id));
    crowd.back()->subscribe(false);
  }
  EXPECT_EQ(LiveClient::try_open(port(), id), 503);
  crowd.pop_back();
  // The channel notices the departure once the server has read the close.
  const auto deadline = Clock::now() + Millis(5000);
  int status = 0;
  while ((status = LiveClient::try_open(port(), id)) != 101 && Clock::now() < deadline) {
    std::this_thread::sleep_for(Millis(50));
  }
  EXPECT_EQ(status, 101);
}

}  // namespace

namespace {

using namespace http_test;

class LiveInvalidation : public LiveEditing {};

TEST_F(LiveInvalidation, VersionEventsBoundWhatTheEditChanged) {
  const std::string id = create_scene("changed-box");
  LiveClient author(port(), id);
  author.subscribe(true);
  author.send(edit(1, set_elevation(0, 250)));
  const json changed = author.next_of("version")["changed"];
  EXPECT_EQ(changed["everything"], false) << changed.dump();
  // Disc 0: centre (-1000, -1000), radius 500.
  ASSERT_TRUE(changed["box"].is_object()) << changed.dump();
  EXPECT_LE(changed["box"]["min"][0].get<double>(), -1500.0);
  EXPECT_LE(changed["box"]["min"][1].get<double>(), -1500.0);
  EXPECT_GE(changed["box"]["max"][0].get<double>(), -500.0);
  EXPECT_GE(changed["box"]["max"][1].get<double>(), -500.0);
  EXPECT_LT(changed["box"]["max"][0].get<double>(), 0.0);
  EXPECT_LT(changed["box"]["max"][1].get<double>(), 0.0);
  // Changing the seed changes every tile.
  author.send(edit(2, json::array({{{"op", "replace"}, {"path", "/seed"}, {"value", 7}}})));
  EXPECT_EQ(author.next_of("version")["changed"]["everything"], true);
}

TEST_F(LiveInvalidation, TheInvalidatedTilesAreExactlyTheTilesWhoseBytesChanged) {
  const std::string id = create_scene("exact");
  LiveClient author(port(), id);
  author.subscribe(true);
  // Move disc 1 (centre (1000, -1000)) and raise disc 2.
  author.send(edit(
      1,
      json::array({{{"op", "replace"}, {"path", "/root/children/1/center"}, {"value", {700, -600}}},
                   {{"op", "replace"}, {"path", "/root/children/2/elevation"}, {"value", 180}}})));
  ASSERT_EQ(author.next_of("ack")["version"], 2);
  for (const std::string format : {"png", "tif"}) {
    for (int z : {2, 3}) {
      const std::string shape = "scheme=local&size=64&format=" + format;
      const Response changes =
          get(port(),
              "/api/v1/scenes/" + id + "/changes?from=1&to=2&z=" + std::to_string(z) + "&" + shape);
      ASSERT_EQ(changes.result_int(), 200u) << changes.body();
      const json body = body_json(changes);
      EXPECT_EQ(body["truncated"], false);
      std::set<std::pair<std::int64_t, std::int64_t>> predicted;
      for (const json& t : body["tiles"]) predicted.emplace(t[0], t[1]);
      std::set<std::pair<std::int64_t, std::int64_t>> actual;
      const std::int64_t n = std::int64_t{1} << z;
      for (std::int64_t x = 0; x < n; ++x) {
        for (std::int64_t y = 0; y < n; ++y) {
          const std::string tile = "/tiles/" + std::to_string(z) + "/" + std::to_string(x) + "/" +
                                   std::to_string(y) + "." + format + "?scheme=local&size=64";
          const Response before = get(port(), "/api/v1/scenes/" + id + "@1" + tile);
          const Response after = get(port(), "/api/v1/scenes/" + id + "@2" + tile);
          ASSERT_EQ(before.result_int(), 200u) << before.body();
          ASSERT_EQ(after.result_int(), 200u) << after.body();
          if (before.body() != after.body()) actual.emplace(x, y);
        }
      }
      EXPECT_FALSE(actual.empty());
      EXPECT_EQ(predicted, actual) << format << " z=" << z;
    }
  }
}

TEST_F(LiveInvalidation, UntouchedTilesOfANewVersionKeepTheirCachedBytes) {
  const std::string id = create_scene("reuse");
  LiveClient author(port(), id);
  author.subscribe(true);
  author.send(edit(1, set_elevation(0, 250)));  // one disc of four
  ASSERT_EQ(author.next_of("ack")["version"], 2);
  const json changes =
      body_json(get(port(), "/api/v1/scenes/" + id + "/changes?from=1&to=2&z=2&scheme=local"));
  ASSERT_FALSE(changes["tiles"].empty());
  std::set<std::pair<std::int64_t, std::int64_t>> changed;
  for (const json& t : changes["tiles"]) changed.emplace(t[0], t[1]);
  std::pair<std::int64_t, std::int64_t> untouched{-1, -1};
  for (std::int64_t x = 0; x < 4 && untouched.first < 0; ++x) {
    for (std::int64_t y = 0; y < 4 && untouched.first < 0; ++y) {
      if (!changed.contains({x, y})) untouched = {x, y};
    }
  }
  ASSERT_GE(untouched.first, 0);
  auto tile = [&](int version, std::pair<std::int64_t, std::int64_t> at) {
    return get(port(), "/api/v1/scenes/" + id + "@" + std::to_string(version) + "/tiles/2/" +
                           std::to_string(at.first) + "/" + std::to_string(at.second) +
                           ".png?scheme=local&size=64");
  };
  const Response before = tile(1, untouched);
  const Response edited_before = tile(1, *changed.begin());
  const double reused = metric(port(), "terrain_cache_reused_across_versions_total");
  const Response after = tile(2, untouched);
  EXPECT_EQ(after.body(), before.body());
  EXPECT_EQ(header(after, http::field::etag), header(before, http::field::etag));
  EXPECT_EQ(metric(port(), "terrain_cache_reused_across_versions_total"), reused + 1);
  // A tile the edit reaches is generated anew.
  EXPECT_NE(tile(2, *changed.begin()).body(), edited_before.body());
  EXPECT_EQ(metric(port(), "terrain_cache_reused_across_versions_total"), reused + 1);
}

TEST_F(LiveInvalidation, BadChangeQueriesNameTheirField) {
  const std::string id = create_scene("changes-bad");
  auto status_and_pointer = [&](const std::string& query) {
    const Response r = get(port(), "/api/v1/scenes/" + id + "/changes?" + query);
    return std::pair{r.result_int(), json::parse(r.body(), nullptr, false).value("pointer", "")};
  };
  EXPECT_EQ(status_and_pointer("to=1&z=2"), (std::pair{400u, std::string("/from")}));
  EXPECT_EQ(status_and_pointer("from=1&to=x&z=2"), (std::pair{400u, std::string("/to")}));
  EXPECT_EQ(status_and_pointer("from=1&to=9&z=2"), (std::pair{404u, std::string("/to")}));
  EXPECT_EQ(status_and_pointer("from=1&to=1"), (std::pair{400u, std::string("/z")}));
  EXPECT_EQ(status_and_pointer("from=1&to=1&z=2&format=bmp"),
            (std::pair{404u, std::string("/format")}));
  EXPECT_EQ(status_and_pointer("from=1&to=1&z=2&scheme=mars").first, 400u);
  const Response same = get(port(), "/api/v1/scenes/" + id + "/changes?from=1&to=1&z=2");
  EXPECT_EQ(body_json(same)["tiles"], json::array());
}

}  // namespace

namespace {

using namespace http_test;

TEST_F(LiveEditing, AConnectionsOwnQuickEditsDoNotConflict) {
  const std::string id = create_scene("own-edits");
  LiveClient author(port(), id);
  author.subscribe(true);
  // Three changes of one field sent at once, all against version 1: each is rebased onto the
  // author's own previous one.
  for (int i = 0; i < 3; ++i) author.send(edit(1, set_elevation(0, 110 + i)));
  for (int i = 0; i < 3; ++i) {
    const json ack = author.next_of("ack");
    EXPECT_EQ(ack["version"], 2 + i) << ack.dump();
  }
  EXPECT_EQ(body_json(get(port(), "/api/v1/scenes/" + id))["root"]["children"][0]["elevation"],
            112);
}

}  // namespace

namespace {

using namespace http_test;

TEST(LiveLimits, SilentConnectionsArePingedAndDroppedWhenTheyDoNotAnswer) {
  TempDir dir("live-idle");
  ServerProcess server(dir.path() / "data",
                       {"--write-token", kToken, "--live-ping-interval-ms", "100"});
  const Response created =
      fetch(server.port(), "POST", "/api/v1/scenes?id=idle", with_token(), quad_scene());
  ASSERT_EQ(created.result_int(), 201u) << created.body();
  LiveClient answering(server.port(), "idle");
  answering.subscribe(false);
  LiveClient silent(server.port(), "idle");
  silent.subscribe(false);
  EXPECT_EQ(metric(server.port(), "terrain_live_connections"), 2);
  // A client that reads answers the server's pings (WebSocket pongs) and stays through many idle
  // periods; the one that never reads cannot, and is dropped after 200 ms of silence.
  std::thread later([&] {
    std::this_thread::sleep_for(Millis(1000));
    fetch(server.port(), "PUT", "/api/v1/scenes/idle", with_token(), quad_scene());
  });
  const json version = answering.next_of("version", Millis(10000));
  later.join();
  EXPECT_EQ(version["version"], 2);
  EXPECT_EQ(metric(server.port(), "terrain_live_connections"), 1);
  server.stop();
}

}  // namespace
