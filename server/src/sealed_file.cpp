#include "server/sealed_file.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>

namespace server {
namespace {

// Sealed files hold a descriptor each; they may take half of what the process may open, so that
// connections (and SQLite) always find descriptors.
std::atomic<long> live_files{0};

long file_budget() {
  static const long budget = [] {
    rlimit limit{};
    if (::getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return 4096L;
    return static_cast<long>(limit.rlim_cur / 2);
  }();
  return budget;
}

}  // namespace

std::shared_ptr<const SealedFile> SealedFile::create(std::string_view bytes) {
  if (bytes.size() < kMinimumSize) return nullptr;
  if (live_files.fetch_add(1) >= file_budget()) {
    live_files.fetch_sub(1);
    return nullptr;
  }
  const int fd = ::memfd_create("terrain-product", MFD_CLOEXEC | MFD_ALLOW_SEALING);
  if (fd < 0) {
    live_files.fetch_sub(1);
    return nullptr;
  }
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n <= 0) {
      ::close(fd);
      live_files.fetch_sub(1);
      return nullptr;
    }
    written += static_cast<std::size_t>(n);
  }
  // Sealed: the bytes a response promised (its ETag, its Content-Length) can never change,
  // even while the kernel still holds the pages of an earlier send.
  if (::fcntl(fd, F_ADD_SEALS, F_SEAL_WRITE | F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_SEAL) != 0) {
    ::close(fd);
    live_files.fetch_sub(1);
    return nullptr;
  }
  return std::shared_ptr<const SealedFile>(new SealedFile(fd, bytes.size()));
}

SealedFile::~SealedFile() {
  ::close(fd_);
  live_files.fetch_sub(1);
}

}  // namespace server
