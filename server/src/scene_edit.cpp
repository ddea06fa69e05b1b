#include "server/scene_edit.hpp"

#include <array>
#include <string_view>

namespace server {
namespace {

using nlohmann::json;

constexpr std::array<std::string_view, 6> kOps = {"add",  "remove", "replace",
                                                  "move", "copy",   "test"};

EditRejection invalid(std::string detail, std::string pointer) {
  return {400, "Invalid edit", std::move(detail), std::move(pointer)};
}

bool valid_pointer(const std::string& text) {
  try {
    static_cast<void>(json::json_pointer(text));
    return true;
  } catch (const json::exception&) {
    return false;
  }
}

// Reference tokens of a pointer; "-" (past the end of an array) stays a token of its own.
std::vector<std::string> tokens(const std::string& pointer) {
  std::vector<std::string> out;
  json::json_pointer p(pointer);
  while (!p.empty()) {
    out.insert(out.begin(), p.back());
    p.pop_back();
  }
  return out;
}

// True when one path is a prefix of the other (a change to one may change the other's value).
// "-" names a new element past the end of an array: never one that exists, nor another new one,
// so two appends to one array do not conflict.
bool overlaps(const std::vector<std::string>& a, const std::vector<std::string>& b) {
  const std::size_t n = std::min(a.size(), b.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (a[i] != b[i] || a[i] == "-") return false;
  }
  return true;
}

}  // namespace

terrain::Result<bool, EditRejection> check_patch(const json& ops) {
  if (!ops.is_array()) return invalid("ops must be an array of JSON Patch operations", "/ops");
  if (ops.empty()) return invalid("ops is empty: an edit changes something", "/ops");
  if (ops.size() > kMaxEditOps) {
    return invalid("at most " + std::to_string(kMaxEditOps) + " operations per edit", "/ops");
  }
  for (std::size_t i = 0; i < ops.size(); ++i) {
    const std::string at = "/ops/" + std::to_string(i);
    const json& op = ops[i];
    if (!op.is_object()) return invalid("an operation is an object", at);
    const auto kind = op.find("op");
    if (kind == op.end() || !kind->is_string()) {
      return invalid("op must be one of add, remove, replace, move, copy, test", at + "/op");
    }
    const std::string name = kind->get<std::string>();
    if (std::find(kOps.begin(), kOps.end(), name) == kOps.end()) {
      return invalid("unknown op '" + name + "' (add, remove, replace, move, copy, test)",
                     at + "/op");
    }
    for (const char* field : {"path", "from"}) {
      const bool needed = std::string_view(field) == "path" || name == "move" || name == "copy";
      const auto it = op.find(field);
      if (it == op.end()) {
        if (needed) return invalid(std::string(field) + " is required", at + "/" + field);
        continue;
      }
      if (!it->is_string() || !valid_pointer(it->get<std::string>())) {
        return invalid(std::string(field) + " must be a JSON pointer such as /root/children/0",
                       at + "/" + field);
      }
    }
    if ((name == "add" || name == "replace" || name == "test") && !op.contains("value")) {
      return invalid("value is required for " + name, at + "/value");
    }
    if (op.at("path").get<std::string>().empty() && name != "test") {
      return invalid("an edit changes parts of the scene, not the whole document (use PUT)",
                     at + "/path");
    }
  }
  return true;
}

terrain::Result<json, EditRejection> rebase_and_apply(const json& ops,
                                                      const std::vector<NewerChange>& newer,
                                                      const json& head) {
  if (auto checked = check_patch(ops); !checked) return checked.error();
  for (std::size_t i = 0; i < ops.size(); ++i) {
    for (const char* field : {"path", "from"}) {
      if (!ops[i].contains(field)) continue;
      const auto mine = tokens(ops[i][field].get<std::string>());
      for (const NewerChange& version : newer) {
        for (const json& change : version.patch) {
          for (const char* theirs_field : {"path", "from"}) {
            if (!change.contains(theirs_field)) continue;
            const std::string theirs = change[theirs_field].get<std::string>();
            if (overlaps(mine, tokens(theirs))) {
              return EditRejection{409, "Edit conflict",
                                   (theirs.empty() ? std::string("the document") : theirs) +
                                       " was changed by version " +
                                       std::to_string(version.version) + " (" + version.author +
                                       ") after the edit's base version",
                                   "/ops/" + std::to_string(i) + "/" + field};
            }
          }
        }
      }
    }
  }
  json document = head;
  for (std::size_t i = 0; i < ops.size(); ++i) {
    try {
      document = document.patch(json::array({ops[i]}));
    } catch (const json::exception& e) {
      std::string why = e.what();
      // nlohmann prefixes "[json.exception.out_of_range.403] "; the rest is the reason.
      if (const auto end = why.find("] "); end != std::string::npos) why = why.substr(end + 2);
      return EditRejection{400, "Edit does not apply",
                           "operation " + std::to_string(i) + " does not apply: " + why,
                           "/ops/" + std::to_string(i)};
    }
  }
  return document;
}

}  // namespace server
