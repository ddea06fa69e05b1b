#include "server/static_files.hpp"

#include <filesystem>
#include <fstream>
#include <iterator>

#include "terrain/scene.hpp"

namespace server {
namespace {

std::string media_type_of(const std::string& extension) {
  static const std::map<std::string, std::string> types = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".glsl", "text/plain; charset=utf-8"},
      {".png", "image/png"},
      {".svg", "image/svg+xml"},
      {".wasm", "application/wasm"},
      {".ico", "image/x-icon"},
      {".txt", "text/plain; charset=utf-8"}};
  auto it = types.find(extension);
  return it == types.end() ? "application/octet-stream" : it->second;
}

}  // namespace

StaticFiles StaticFiles::load(const std::string& directory) {
  namespace fs = std::filesystem;
  StaticFiles files;
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) return files;
  std::size_t total = 0;
  for (auto it = fs::recursive_directory_iterator(directory, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const fs::path relative = fs::relative(it->path(), directory, ec);
    if (ec) continue;
    std::ifstream in(it->path(), std::ios::binary);
    StaticFile file;
    auto body = std::make_shared<const std::string>(std::istreambuf_iterator<char>(in),
                                                    std::istreambuf_iterator<char>());
    total += body->size();
    if (total > (std::size_t{64} << 20)) break;
    file.media_type = media_type_of(it->path().extension().string());
    file.etag = "\"" + terrain::sha256_hex(*body).substr(0, 32) + "\"";
    file.body = std::move(body);
    files.files_.emplace("/" + relative.generic_string(), std::move(file));
  }
  return files;
}

const StaticFile* StaticFiles::find(const std::string& path) const {
  // A folder's address names its index page (/ and /examples/).
  auto it = files_.find(path.ends_with('/') ? path + "index.html" : path);
  return it == files_.end() ? nullptr : &it->second;
}

}  // namespace server
