// The documentation covers every registered node type and every material parameter.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "terrain/material.hpp"
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

TEST(MaterialDocs, DescribeEveryParameter) {
  std::ifstream in(std::filesystem::path(TERRAIN_SOURCE_DIR) / "docs" / "material.md");
  ASSERT_TRUE(in.good());
  std::stringstream text;
  text << in.rdbuf();
  for (const MaterialField& field : kMaterialFields) {
    EXPECT_NE(text.str().find("\n| `" + std::string(field.name) + "` |"), std::string::npos)
        << "docs/material.md has no row for " << field.name;
  }
}

}  // namespace
}  // namespace terrain
