#include "terrain/json_text.hpp"

#include "field_reader.hpp"

#include <string>
#include <vector>

namespace terrain {

namespace {

// One open array or object of the text being scanned: what names its current member.
struct Frame {
  bool object = false;
  std::size_t index = 0;  // arrays: the element's index
  std::string key;        // objects: the member's key, as written (escapes kept)
  bool reading_key = false;
};

// RFC 6901 pointer of the member that holds the over-deep value: the path down to the deepest
// object member around it (an array of arrays has no names inside).
std::string pointer_of(const std::vector<Frame>& frames) {
  std::size_t last_member = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].object && !frames[i].key.empty()) last_member = i + 1;
  }
  std::string pointer;
  for (std::size_t i = 0; i < last_member; ++i) {
    pointer = frames[i].object ? pointer_join(pointer, frames[i].key)
                               : pointer_join(pointer, frames[i].index);
  }
  return pointer;
}

}  // namespace

int json_nesting_depth(std::string_view text, int stop_above, std::size_t* offset,
                       std::string* pointer) {
  std::vector<Frame> frames;
  int deepest = 0;
  bool in_string = false;
  bool escaped = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (c == '\\') {
        escaped = true;
      } else if (c == '"') {
        in_string = false;
        if (!frames.empty()) frames.back().reading_key = false;
        continue;
      }
      if (!frames.empty() && frames.back().reading_key) frames.back().key += c;
      continue;
    }
    switch (c) {
      case '"':
        in_string = true;
        // A string where an object expects a key (after '{' or ','): record it.
        if (!frames.empty() && frames.back().object && frames.back().key.empty()) {
          frames.back().reading_key = true;
        }
        break;
      case '[':
      case '{':
        frames.push_back({c == '{', 0, {}, false});
        if (static_cast<int>(frames.size()) > deepest) {
          deepest = static_cast<int>(frames.size());
          if (deepest > stop_above) {
            if (offset != nullptr) *offset = i;
            if (pointer != nullptr) {
              frames.pop_back();
              *pointer = pointer_of(frames);
            }
            return deepest;
          }
        }
        break;
      case ']':
      case '}':
        if (!frames.empty()) frames.pop_back();  // unbalanced text is the parser's to report
        break;
      case ',':
        if (!frames.empty()) {
          ++frames.back().index;
          frames.back().key.clear();
        }
        break;
      default:
        break;
    }
  }
  return deepest;
}

Result<nlohmann::json> parse_json_text(std::string_view text, std::string_view what,
                                       const JsonTextLimits& limits) {
  if (text.size() > limits.max_bytes) {
    return Error{std::string(what) + " is " + std::to_string(text.size()) +
                     " bytes long, above the limit of " + std::to_string(limits.max_bytes),
                 ""};
  }
  std::size_t offset = 0;
  std::string pointer;
  if (json_nesting_depth(text, limits.max_depth, &offset, &pointer) > limits.max_depth) {
    return Error{std::string(what) + " nests arrays and objects more than " +
                     std::to_string(limits.max_depth) + " levels deep (at byte " +
                     std::to_string(offset) + ")",
                 pointer};
  }
  nlohmann::json document = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!document.is_discarded()) return document;
  // Parse again with exceptions only to learn where it failed (never escapes). The depth is
  // bounded now, so the exception's context is harmless.
  try {
    const nlohmann::json ignored = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    return Error{std::string(what) + " is not valid JSON: " + e.what(), ""};
  }
  return Error{std::string(what) + " is not valid JSON", ""};
}

}  // namespace terrain
