// The browser client's files, read into memory once at start. Requests are answered by looking
// their path up in that table, so no request value ever becomes a file path.
#pragma once

#include <map>
#include <memory>
#include <string>

namespace server {

struct StaticFile {
  std::shared_ptr<const std::string> body;  ///< shared with the responses that send it
  std::string media_type;
  std::string etag;
};

class StaticFiles {
 public:
  /// Reads every regular file under `directory` (recursively, at most 64 MiB in all); a missing
  /// directory gives an empty table.
  static StaticFiles load(const std::string& directory);

  /// The file for a URL path ("/" is "/index.html"), or null.
  const StaticFile* find(const std::string& path) const;
  bool empty() const { return files_.empty(); }

 private:
  std::map<std::string, StaticFile> files_;
};

}  // namespace server
