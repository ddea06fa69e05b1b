// Reading JSON text that may be hostile: depth and size are refused before nlohmann builds a
// document whose copies and dumps would recurse once per level.
#include <gtest/gtest.h>

#include "terrain/json_text.hpp"

namespace terrain {
namespace {

std::string nested(std::size_t depth) {
  return std::string(depth, '[') + std::string(depth, ']');
}

TEST(JsonText, ReadsDocumentsWithinTheLimits) {
  Result<nlohmann::json> ok = parse_json_text(R"({"a": [1, {"b": "[[[["}]})", "the text");
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ((*ok)["a"][1]["b"], "[[[[");  // brackets inside strings do not nest
  EXPECT_TRUE(parse_json_text(nested(192), "the text"));
}

TEST(JsonText, CountsNestingOfArraysAndObjectsOutsideStrings) {
  EXPECT_EQ(json_nesting_depth("[]", 10), 1);
  EXPECT_EQ(json_nesting_depth(R"({"a": [{"b": 1}], "c": "]]]{{{"})", 10), 3);
  EXPECT_EQ(json_nesting_depth(R"(["\"[[["])", 10), 1);  // an escaped quote stays in the string
  EXPECT_EQ(json_nesting_depth(nested(1000), 5), 6);     // stops once above
}

// Malformed and hostile texts, together.
TEST(JsonTextErrors, TooDeepIsRefusedNamingTheLimitAndTheMember) {
  Result<nlohmann::json> deep =
      parse_json_text(R"({"format": 1, "name": )" + nested(400'000) + "}", "the scene");
  ASSERT_FALSE(deep);
  EXPECT_NE(deep.error().message.find("more than 192 levels deep"), std::string::npos);
  EXPECT_EQ(deep.error().pointer, "/name");
  Result<nlohmann::json> inside =
      parse_json_text(R"({"ops": [{"op": "add", "value": )" + nested(300) + "}]}", "the message");
  ASSERT_FALSE(inside);
  EXPECT_EQ(inside.error().pointer, "/ops/0/value");
  Result<nlohmann::json> escaped =
      parse_json_text(R"({"a/b~c": )" + nested(300) + "}", "the message");
  ASSERT_FALSE(escaped);
  EXPECT_EQ(escaped.error().pointer, "/a~1b~0c");
  EXPECT_EQ(parse_json_text(nested(300), "the text").error().pointer, "");
  JsonTextLimits tight;
  tight.max_depth = 2;
  EXPECT_FALSE(parse_json_text("[[[1]]]", "the text", tight));
}

TEST(JsonTextErrors, TooLongAndNotJsonAreRefused) {
  JsonTextLimits small;
  small.max_bytes = 8;
  Result<nlohmann::json> long_text = parse_json_text(R"({"a": 12345})", "the body", small);
  ASSERT_FALSE(long_text);
  EXPECT_NE(long_text.error().message.find("above the limit of 8"), std::string::npos);
  Result<nlohmann::json> broken = parse_json_text(R"({"a": )", "the scene");
  ASSERT_FALSE(broken);
  EXPECT_NE(broken.error().message.find("the scene is not valid JSON"), std::string::npos);
  EXPECT_FALSE(parse_json_text("", "the scene"));
  EXPECT_FALSE(parse_json_text("]]]]", "the scene"));  // unbalanced: the parser's to report
}

}  // namespace
}  // namespace terrain
