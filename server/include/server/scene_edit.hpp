// Live edits as JSON Patch (RFC 6902) over a scene's canonical JSON, and their rebasing onto a
// head that moved since the author looked (docs/live.md).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

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

/// A version that landed after an edit's base, as the JSON Patch from the version before it.
struct NewerChange {
  std::int64_t version = 0;
  std::string author;
  nlohmann::json patch;  ///< nlohmann::json::diff(previous version, this version)
};

/// Applies `ops` to `head`. `newer` are the versions that landed since the edit's base version
/// (other authors' only: a connection's own edits never conflict with its later ones). The edit is
/// rebased onto the head unless one of its paths overlaps a path one of them changed (one is a
/// prefix of the other; "-" appends never overlap) — then it is a 409 conflict naming that path
/// and version. A patch that does not apply (missing path, failed test) is a 400 naming the op.
terrain::Result<nlohmann::json, EditRejection> rebase_and_apply(
    const nlohmann::json& ops, const std::vector<NewerChange>& newer, const nlohmann::json& head);

}  // namespace server
