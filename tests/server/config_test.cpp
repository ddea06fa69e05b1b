// Configuration sources and their precedence: defaults < TOML file < TERRAIN_* < flags.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "server/config.hpp"

namespace server {
namespace {

namespace fs = std::filesystem;

struct TempFile {
  fs::path path;
  explicit TempFile(const std::string& text) {
    path = fs::temp_directory_path() / ("terrain-config-" + std::to_string(::getpid()) + "-" +
                                        std::to_string(counter++) + ".toml");
    std::ofstream(path) << text;
  }
  ~TempFile() { fs::remove(path); }
  static inline int counter = 0;
};

Config load_or_die(std::vector<std::string_view> args, std::map<std::string, std::string> env = {},
                   const std::string& default_file = "") {
  Result<Startup> s = load_config(args, env, default_file);
  if (!s) throw std::runtime_error(s.error().pointer + ": " + s.error().message);
  return s->config;
}

TEST(Config, DefaultsWithoutAnySource) {
  const Config c = load_or_die({});
  EXPECT_EQ(c.port, 8080);
  EXPECT_EQ(c.address, "127.0.0.1");
  EXPECT_EQ(c.backend, Backend::automatic);
  EXPECT_EQ(c.header_limit, 8192);
}

TEST(Config, LaterSourcesWin) {
  TempFile file(
      "[server]\nport = 9000\naddress = \"0.0.0.0\"\n[auth]\nwrite_token = \"file\"\n"
      "[cache]\nmemory_bytes = 1048576\n");
  const std::string path = file.path.string();
  Config c = load_or_die({"--config", path});
  EXPECT_EQ(c.port, 9000);
  EXPECT_EQ(c.address, "0.0.0.0");
  EXPECT_EQ(c.write_token, "file");
  EXPECT_EQ(c.cache_bytes, 1 << 20);
  EXPECT_EQ(c.config_file, path);
  c = load_or_die({"--config", path}, {{"TERRAIN_PORT", "9100"}, {"TERRAIN_WRITE_TOKEN", "env"}});
  EXPECT_EQ(c.port, 9100);
  EXPECT_EQ(c.write_token, "env");
  c = load_or_die({"--config=" + path, "--port", "9200", "--write-token=flag"},
                  {{"TERRAIN_PORT", "9100"}});
  EXPECT_EQ(c.port, 9200);
  EXPECT_EQ(c.write_token, "flag");
}

TEST(Config, ReadsListsSuffixesAndBackends) {
  TempFile file("[server]\ncors_origins = [\"https://a.example\", \"https://b.example\"]\n");
  Config c =
      load_or_die({"--config", file.path.string(), "--cache-bytes", "64M", "--backend", "cpu"});
  EXPECT_EQ(c.cors_origins, (std::vector<std::string>{"https://a.example", "https://b.example"}));
  EXPECT_EQ(c.cache_bytes, 64ll << 20);
  EXPECT_EQ(c.backend, Backend::cpu);
  c = load_or_die({}, {{"TERRAIN_CORS_ORIGINS", "*, https://c.example"}});
  EXPECT_EQ(c.cors_origins, (std::vector<std::string>{"*", "https://c.example"}));
}

TEST(Config, ReadsTheStoreBackend) {
  EXPECT_EQ(load_or_die({}).store_backend, StoreBackend::sqlite);
  TempFile file(
      "[store]\nbackend = \"postgres\"\npostgres_url = \"postgresql://t@db/terrain\"\n"
      "postgres_pool_size = 3\n");
  Config c = load_or_die({"--config", file.path.string()});
  EXPECT_EQ(c.store_backend, StoreBackend::postgres);
  EXPECT_EQ(c.postgres_url, "postgresql://t@db/terrain");
  EXPECT_EQ(c.postgres_pool_size, 3);
  c = load_or_die({"--config", file.path.string(), "--postgres-url", "host=x dbname=y"},
                  {{"TERRAIN_POSTGRES_POOL_SIZE", "5"}});
  EXPECT_EQ(c.postgres_url, "host=x dbname=y");
  EXPECT_EQ(c.postgres_pool_size, 5);
  c = load_or_die({"--config", file.path.string()}, {{"TERRAIN_STORE_BACKEND", "sqlite"}});
  EXPECT_EQ(c.store_backend, StoreBackend::sqlite);
}

TEST(Config, DefaultFileIsReadWhenPresentAndSkippedWhenNot) {
  TempFile file("[server]\nport = 7000\n");
  EXPECT_EQ(load_or_die({}, {}, file.path.string()).port, 7000);
  EXPECT_EQ(load_or_die({}, {}, "/nonexistent/server.toml").port, 8080);
}

TEST(Config, HelpListsEveryOption) {
  Result<Startup> s = load_config(std::vector<std::string_view>{"--help"}, {}, "");
  ASSERT_TRUE(s.ok());
  EXPECT_TRUE(s->show_help);
  const std::string help = help_text();
  for (const char* needle : {"--port", "TERRAIN_PORT", "--data-dir", "--write-token", "--config",
                             "--backend", "--cors-origins", "--cache-bytes", "default: 8080",
                             "--store-backend", "TERRAIN_POSTGRES_URL", "default: sqlite"}) {
    EXPECT_NE(help.find(needle), std::string::npos) << needle;
  }
}

TEST(Config, TheShippedConfigFileLoads) {
  const std::string shipped = std::string(TERRAIN_SOURCE_DIR) + "/config/server.toml";
  Result<Startup> s = load_config(std::vector<std::string_view>{"--config", shipped}, {}, "");
  ASSERT_TRUE(s.ok()) << s.error().message;
}

// Bad configuration: every case refused with the option named.
TEST(ConfigErrors, NameTheOptionAndTheSource) {
  struct Case {
    std::vector<std::string_view> args;
    std::map<std::string, std::string> env;
    std::string toml;
    std::string pointer;
  };
  const std::vector<Case> cases = {
      {{"--port", "70000"}, {}, "", "/server.port"},
      {{"--port", "eighty"}, {}, "", "/server.port"},
      {{"--port"}, {}, "", "/server.port"},
      {{}, {{"TERRAIN_QUEUE_LIMIT", "0"}}, "", "/generation.queue_limit"},
      {{"--backend", "quantum"}, {}, "", "/generation.backend"},
      {{"--frobnicate", "1"}, {}, "", ""},
      {{}, {}, "[server]\nprot = 1\n", "/server.prot"},
      {{}, {}, "[server]\nport = \"x\"\n", "/server.port"},
      {{}, {}, "[server]\nport = 1.5\n", "/server.port"},
      {{}, {}, "port = 1\n", "/port"},
      {{}, {}, "[server\nport = 1\n", ""},
      {{"--config", "/nonexistent/x.toml"}, {}, "", "/config"},
      {{"--log-level", "chatty"}, {}, "", "/log.level"},
      {{"--store-backend", "mysql"}, {}, "", "/store.backend"},
      {{"--store-backend", "postgres"}, {}, "", "/store.postgres_url"},
      {{}, {{"TERRAIN_POSTGRES_POOL_SIZE", "0"}}, "", "/store.postgres_pool_size"},
  };
  for (const Case& c : cases) {
    std::vector<std::string_view> args = c.args;
    std::unique_ptr<TempFile> file;
    std::string path;
    if (!c.toml.empty()) {
      file = std::make_unique<TempFile>(c.toml);
      path = file->path.string();
      args.insert(args.begin(), {"--config", path});
    }
    Result<Startup> s = load_config(args, c.env, "");
    ASSERT_FALSE(s.ok()) << c.toml;
    EXPECT_EQ(s.error().pointer, c.pointer) << s.error().message;
    EXPECT_FALSE(s.error().message.empty());
  }
}

}  // namespace
}  // namespace server
