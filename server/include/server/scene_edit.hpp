// Live edits as JSON Patch (RFC 6902) over a scene's canonical JSON, and their rebasing onto a
// head that moved since the author looked (docs/live.md).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "terrain/result.hpp"

namespace server {

/// Why an edit was refused: an HTTP-like status, and the offending field as a JSON pointer into
/// the edit message ("/ops/2/path").
struct EditRejection {
  int status = 400;
  std::string title;
  std::string detail;
  std::string pointer;
};

/// Largest number of operations one edit may carry.
inline constexpr std::size_t kMaxEditOps = 256;

/// Checks that `ops` is a well-formed JSON Patch of at most kMaxEditOps operations (op, path,
/// from and value as RFC 6902 asks); pointers in the rejection are relative to the message.
terrain::Result<bool, EditRejection> check_patch(const nlohmann::json& ops);

/// Applies `ops`, written against `base`, to `head`. When the two differ, the edit is rebased:
/// it applies to `head` unless one of its paths overlaps (one is a prefix of the other) a value
/// that changed between `base` and `head` — then it is a 409 conflict naming that path. A patch
/// that does not apply (missing path, failed test) is a 400 naming the operation.
terrain::Result<nlohmann::json, EditRejection> rebase_and_apply(const nlohmann::json& ops,
                                                                const nlohmann::json& base,
                                                                const nlohmann::json& head);

}  // namespace server
