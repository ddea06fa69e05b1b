// The on-disk cache: entries survive a restart, the budget evicts the oldest, torn writes and
// foreign files are ignored.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "server/disk_cache.hpp"

namespace server {
namespace {

namespace fs = std::filesystem;

class DiskCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("terrain-disk-cache-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  static CachedProduct product(std::size_t size, char fill) {
    return {std::string(size, fill), "image/png", "", "\"etag\"", "cpu", nullptr};
  }
  fs::path dir_;
};

TEST_F(DiskCacheTest, EntriesSurviveARestart) {
  {
    DiskCache cache(dir_.string(), 1 << 20);
    cache.insert("a|key", product(1000, 'x'));
  }
  DiskCache again(dir_.string(), 1 << 20);
  auto hit = again.find("a|key");
  ASSERT_NE(hit, nullptr);
  EXPECT_EQ(hit->body, std::string(1000, 'x'));
  EXPECT_EQ(hit->media_type, "image/png");
  EXPECT_EQ(hit->etag, "\"etag\"");
  EXPECT_EQ(again.find("another"), nullptr);
}

TEST_F(DiskCacheTest, BudgetEvictsTheOldest) {
  DiskCache cache(dir_.string(), 5000);
  for (int i = 0; i < 10; ++i) cache.insert("k" + std::to_string(i), product(1000, 'a'));
  EXPECT_LE(cache.bytes(), 5000);
  EXPECT_EQ(cache.find("k0"), nullptr);
  EXPECT_NE(cache.find("k9"), nullptr);
}

TEST_F(DiskCacheTest, TornAndForeignFilesAreIgnored) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "half.0.tmp") << "partial";
  DiskCache cache(dir_.string(), 1 << 20);
  EXPECT_FALSE(fs::exists(dir_ / "half.0.tmp"));
  cache.insert("key", product(10, 'z'));
  // Corrupt the entry: it must read as a miss, never as wrong bytes.
  for (const auto& entry : fs::directory_iterator(dir_)) std::ofstream(entry.path()) << "junk";
  EXPECT_EQ(cache.find("key"), nullptr);
}

}  // namespace
}  // namespace server
