// Reading JSON text that may be hostile. nlohmann's parser itself is iterative, but copying,
// comparing or dumping a document recurses once per nesting level, so a few hundred kilobytes of
// "[[[[…" overflow the stack later, far from the parse. Every JSON text the project reads from
// outside (scene and planet bodies, live messages, stored rows) goes through parse_json_text,
// which refuses over-deep or over-long text before nlohmann builds anything.
#pragma once

#include <cstddef>
#include <string_view>

#include <nlohmann/json.hpp>

#include "terrain/result.hpp"

namespace terrain {

/// Bounds on a JSON text. The depth counts open arrays and objects: `[[1]]` is 2 deep.
struct JsonTextLimits {
  /// Scenes nest nodes 64 deep (ParseLimits::max_depth), two JSON levels per node level.
  int max_depth = 192;
  std::size_t max_bytes = std::size_t{64} << 20;
};

/// Parses `text`, or says why not: too long, nested too deep (with the byte offset), or not JSON
/// (nlohmann's message). `what` names the text in messages ("the scene", "the message").
Result<nlohmann::json> parse_json_text(std::string_view text, std::string_view what,
                                       const JsonTextLimits& limits = {});

/// The deepest nesting of arrays and objects in `text`, stopping early once above `stop_above`
/// (then it returns a value above it, with the byte `offset` and the JSON `pointer` of the
/// member holding the over-deep value); brackets inside strings do not count.
int json_nesting_depth(std::string_view text, int stop_above, std::size_t* offset = nullptr,
                       std::string* pointer = nullptr);

}  // namespace terrain
