// Bytes in a sealed in-memory file (memfd), which a socket can be fed from with sendfile(2):
// the kernel then references the file's pages instead of copying the bytes from user space.
#pragma once

#include <cstddef>
#include <memory>
#include <string_view>

namespace server {

class SealedFile {
 public:
  /// Bodies smaller than this are written from memory: sendfile saves little on them.
  static constexpr std::size_t kMinimumSize = 16 * 1024;

  /// A sealed copy of `bytes`, or null when they are smaller than kMinimumSize or the file
  /// cannot be made (no memfd support, descriptors exhausted): callers then send from memory.
  static std::shared_ptr<const SealedFile> create(std::string_view bytes);

  ~SealedFile();
  SealedFile(const SealedFile&) = delete;
  SealedFile& operator=(const SealedFile&) = delete;

  int descriptor() const { return fd_; }
  std::size_t size() const { return size_; }

 private:
  SealedFile(int fd, std::size_t size) : fd_(fd), size_(size) {}
  int fd_;
  std::size_t size_;
};

}  // namespace server
