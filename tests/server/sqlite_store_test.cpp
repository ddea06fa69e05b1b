// The SQLite store's file at start: only a missing file (or folder) is a new store; an empty,
// foreign or damaged file is refused, naming the file, and terrain-server does not start on it.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "server/store.hpp"
#include "store_fixtures.hpp"

namespace server {
namespace {

namespace fs = std::filesystem;
using store_fixtures::body;

class SqliteStoreFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("terrain-sqlite-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path data_dir() const { return dir_ / "data"; }
  fs::path file() const { return data_dir() / "terrain.sqlite3"; }

  /// A closed store whose file spans several pages: 40 scenes of about 400 bytes each.
  void write_store() const {
    auto store = open_sqlite_store(data_dir().string());
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (int i = 0; i < 40; ++i) {
      const std::string json =
          "{\"v\":" + std::to_string(i) + ",\"pad\":\"" + std::string(400, 'x') + "\"}";
      ASSERT_TRUE((*store)->create_scene("s" + std::to_string(i), body(json)).ok());
    }
  }

  std::string read_file() const {
    std::ifstream in(file(), std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  void write_file(const std::string& bytes) const {
    std::ofstream(file(), std::ios::binary | std::ios::trunc) << bytes;
  }

  /// The message open_sqlite_store refuses with ("" when it opens).
  std::string refusal() const {
    auto store = open_sqlite_store(data_dir().string());
    return store.ok() ? "" : store.error().message;
  }

  fs::path dir_;
};

// The offset of the middle of the first table leaf page (b-tree page type 13) after the schema
// page whose cells reach past its middle: bytes there belong to rows, not to free space.
std::size_t middle_of_a_full_table_page(const std::string& bytes) {
  const auto byte = [&](std::size_t at) { return static_cast<unsigned char>(bytes.at(at)); };
  std::size_t page_size = byte(16) << 8 | byte(17);
  if (page_size == 1) page_size = 65536;
  for (std::size_t start = page_size; start + page_size <= bytes.size(); start += page_size) {
    const std::size_t content_start = byte(start + 5) << 8 | byte(start + 6);
    if (byte(start) == 13 && content_start != 0 && content_start < page_size / 2) {
      return start + page_size / 2;
    }
  }
  return 0;
}

TEST_F(SqliteStoreFile, AMissingFolderOrFileStartsANewStore) {
  auto fresh = open_sqlite_store(data_dir().string());
  ASSERT_TRUE(fresh.ok()) << fresh.error().message;
  EXPECT_TRUE(*(*fresh)->empty());
  fresh->reset();
  fs::remove(file());
  EXPECT_EQ(refusal(), "");
}

TEST_F(SqliteStoreFile, AHealthyStoreReopensWithItsScenes) {
  write_store();
  auto store = open_sqlite_store(data_dir().string());
  ASSERT_TRUE(store.ok()) << store.error().message;
  EXPECT_EQ((*store)->list_scenes()->size(), 40u);
}

// Damaged files, together: each is refused naming the file and what is wrong, and is left as
// it was (nothing seeded into it, nothing written).
TEST_F(SqliteStoreFile, AnEmptyFileIsRefusedNotSeeded) {
  fs::create_directories(data_dir());
  write_file("");
  const std::string why = refusal();
  EXPECT_NE(why.find(file().string()), std::string::npos) << why;
  EXPECT_NE(why.find("empty (0 bytes)"), std::string::npos) << why;
  EXPECT_EQ(fs::file_size(file()), 0u);
}

TEST_F(SqliteStoreFile, ADamagedHeaderIsRefused) {
  write_store();
  std::string bytes = read_file();
  bytes.replace(0, 16, "not a database!!");
  write_file(bytes);
  const std::string why = refusal();
  EXPECT_NE(why.find(file().string()), std::string::npos) << why;
  EXPECT_NE(why.find("is damaged (file is not a database)"), std::string::npos) << why;
  EXPECT_EQ(read_file(), bytes);
}

TEST_F(SqliteStoreFile, DamageInsideATablePageIsRefused) {
  write_store();
  std::string bytes = read_file();
  const std::size_t middle = middle_of_a_full_table_page(bytes);
  ASSERT_GT(middle, 0u) << "no full table page in " << bytes.size() << " bytes";
  bytes.replace(middle, 64, std::string(64, '\xff'));
  write_file(bytes);
  const std::string why = refusal();
  EXPECT_NE(why.find(file().string()), std::string::npos) << why;
  EXPECT_NE(why.find("is damaged ("), std::string::npos) << why;
  EXPECT_EQ(read_file(), bytes);
}

// terrain-server itself: it exits with status 1 and says why, instead of serving.
TEST_F(SqliteStoreFile, TheServerDoesNotStartOnAnEmptyFile) {
  fs::create_directories(data_dir());
  write_file("");
  const fs::path config = dir_ / "empty.toml";
  std::ofstream(config) << "# empty: flags only\n";
  // Without the check the server would serve (and seed) the file: `timeout` ends it then.
  const std::string command = "timeout 20 env -i '" + std::string(TERRAIN_SERVER) + "' --config '" +
                              config.string() + "' --port 0 --data-dir '" + data_dir().string() +
                              "' --scenes-dir '" TERRAIN_SOURCE_DIR "/config/scenes' 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buffer[512];
  while (const std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
  const int status = ::pclose(pipe);
  ASSERT_TRUE(WIFEXITED(status)) << output;
  EXPECT_EQ(WEXITSTATUS(status), 1) << output;
  EXPECT_NE(output.find("terrain-server: store: '" + file().string() + "' is empty (0 bytes)"),
            std::string::npos)
      << output;
  EXPECT_EQ(output.find("listening"), std::string::npos) << output;
  EXPECT_EQ(fs::file_size(file()), 0u);
}

}  // namespace
}  // namespace server
