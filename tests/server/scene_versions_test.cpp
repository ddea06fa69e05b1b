// Scene refs resolved to compiled versions (server/scene_versions.hpp), on a real SQLite store:
// pinned refs stay resolved, head refs follow the store after a second or a forget_head,
// re-spellings share an entry, a version is compiled once, and bad refs are classified.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <thread>

#include "server/scene_versions.hpp"
#include "store_fixtures.hpp"

namespace server {
namespace {

namespace fs = std::filesystem;
using Kind = SceneVersions::Failure::Kind;
using store_fixtures::body;

class SceneVersionsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("terrain-versions-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    store_ = std::move(open_sqlite_store(dir_.string())).value();
    ASSERT_TRUE(store_->create_scene("a", body("{\"v\":1}")).ok());
  }
  void TearDown() override {
    versions_.reset();
    store_.reset();
    fs::remove_all(dir_);
  }
  /// Compiles nothing: counts, and refuses texts containing "broken" (as a lowered limit would).
  SceneVersions& versions() {
    if (!versions_) {
      versions_ = std::make_unique<SceneVersions>(
          *store_, [this](const std::string& text) -> terrain::Result<LoadedVersion> {
            ++compiled_;
            if (text.find("broken") != std::string::npos) {
              return terrain::Error{"too costly now", "/root/resolution",
                                    terrain::ErrorKind::unsupported};
            }
            return LoadedVersion{};
          });
    }
    return *versions_;
  }
  std::int64_t version_of(const std::string& ref) {
    auto loaded = versions().resolve(ref);
    return loaded ? loaded->version.version : -1;
  }

  fs::path dir_;
  std::unique_ptr<Store> store_;
  std::unique_ptr<SceneVersions> versions_;
  std::atomic<int> compiled_{0};
};

TEST_F(SceneVersionsTest, AHeadRefFollowsTheStoreOnceForgottenOrAfterASecond) {
  EXPECT_EQ(version_of("a"), 1);
  ASSERT_TRUE(store_->add_version("a", body("{\"v\":2}"), std::nullopt).ok());
  EXPECT_EQ(version_of("a"), 1) << "remembered for a second";
  versions().forget_head("a");
  EXPECT_EQ(version_of("a"), 2);
  ASSERT_TRUE(store_->add_version("a", body("{\"v\":3}"), std::nullopt).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  EXPECT_EQ(version_of("a"), 3);
}

TEST_F(SceneVersionsTest, PinnedRefsStayResolvedAndReSpellingsShareOneVersion) {
  ASSERT_TRUE(store_->add_version("a", body("{\"v\":2}"), std::nullopt).ok());
  const std::string hash = store_->version("a", 1)->hash;
  EXPECT_EQ(version_of("a@1"), 1);
  EXPECT_EQ(version_of("a@01"), 1);
  EXPECT_EQ(version_of("a@" + hash), 1);
  EXPECT_EQ(version_of("a@2"), 2);
  // Two versions, each compiled once however it was spelt.
  EXPECT_EQ(compiled_.load(), 2);
  EXPECT_TRUE(versions().is_loaded("a@001"));
  EXPECT_TRUE(versions().is_loaded("a@" + hash));
}

TEST_F(SceneVersionsTest, IsLoadedOnlyOnceResolvedAndWhileAHeadIsFresh) {
  EXPECT_FALSE(versions().is_loaded("a"));
  EXPECT_FALSE(versions().is_loaded("a@1"));
  EXPECT_EQ(version_of("a"), 1);
  EXPECT_TRUE(versions().is_loaded("a"));
  EXPECT_FALSE(versions().is_loaded("a@1")) << "resolved by head, not yet by number";
  versions().forget_head("a");
  EXPECT_FALSE(versions().is_loaded("a"));
}

TEST_F(SceneVersionsTest, AVersionKeptByAWriteIsNotCompiledAgain) {
  LoadedVersion written;
  written.version = *store_->head("a");
  versions().keep(written);
  EXPECT_EQ(version_of("a"), 1);
  EXPECT_EQ(compiled_.load(), 0);
}

// Refs that do not resolve, together.
TEST_F(SceneVersionsTest, BadRefsAreClassified) {
  const auto kind_of = [&](const std::string& ref) {
    auto loaded = versions().resolve(ref);
    EXPECT_FALSE(loaded.ok()) << ref;
    return loaded ? Kind::store : loaded.error().kind;
  };
  EXPECT_EQ(kind_of("A!"), Kind::bad_id);
  EXPECT_EQ(kind_of(""), Kind::bad_id);
  EXPECT_EQ(kind_of("a@0"), Kind::bad_version);
  EXPECT_EQ(kind_of("a@sha256:xyz"), Kind::bad_version);
  EXPECT_EQ(kind_of("nope"), Kind::store);
  EXPECT_EQ(versions().resolve("nope").error().store.kind, StoreError::Kind::not_found);
  EXPECT_EQ(kind_of("a@9"), Kind::store);
  ASSERT_TRUE(store_->add_version("a", body("{\"broken\":1}"), std::nullopt).ok());
  EXPECT_EQ(kind_of("a@2"), Kind::compile);
  EXPECT_EQ(versions().resolve("a@2").error().compile.pointer, "/root/resolution");
  // A failure is not remembered: the next resolution asks again.
  EXPECT_FALSE(versions().is_loaded("a@2"));
}

}  // namespace
}  // namespace server
