// The scene-format documentation covers every registered node type.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "terrain/node.hpp"

namespace terrain {
namespace {

TEST(SceneFormatDocs, DescribeEveryNodeType) {
  std::ifstream in(std::filesystem::path(TERRAIN_SOURCE_DIR) / "docs" / "scene-format.md");
  ASSERT_TRUE(in.good());
  std::stringstream text;
  text << in.rdbuf();
  for (const NodeType* t : node_types()) {
    EXPECT_NE(text.str().find("### `" + std::string(t->name) + "`"), std::string::npos)
        << "docs/scene-format.md has no section for " << t->name;
  }
}

}  // namespace
}  // namespace terrain
