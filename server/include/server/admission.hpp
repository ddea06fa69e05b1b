// What a session checks of a request before it reads the body or takes work: the framing
// (RFC 9112 §6), the body budget shared by all connections, and the rate of request log lines.
// Pure or lock-free pieces, so that they are tested without sockets.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "server/http.hpp"

namespace server {

/// Why a request's framing cannot be trusted, or nullopt when it can. A Transfer-Encoding whose
/// final coding is not chunked leaves the body's length unknown, so the bytes after the header
/// could be read as another request (smuggling): 400, and the connection closes. Codings other
/// than chunked are not implemented here (501); so is Transfer-Encoding in HTTP/1.0, and with
/// Content-Length beside it.
struct FramingRefusal {
  http::status status;
  std::string detail;
};
std::optional<FramingRefusal> check_framing(const http::request_header<>& header);

/// Bytes of request bodies being received, all connections together. A request reserves what it
/// may receive (its Content-Length, or its route's limit when chunked) before reading a byte.
class BodyBudget {
 public:
  explicit BodyBudget(std::int64_t limit) : limit_(limit) {}

  /// A reservation, released when destroyed; empty when the budget has no room for `bytes`.
  class Reservation {
   public:
    Reservation() = default;
    Reservation(Reservation&& other) noexcept
        : budget_(std::exchange(other.budget_, nullptr)), bytes_(other.bytes_) {}
    Reservation& operator=(Reservation&& other) noexcept {
      release();
      budget_ = std::exchange(other.budget_, nullptr);
      bytes_ = other.bytes_;
      return *this;
    }
    ~Reservation() { release(); }
    explicit operator bool() const { return budget_ != nullptr; }

   private:
    friend class BodyBudget;
    Reservation(BodyBudget* budget, std::int64_t bytes) : budget_(budget), bytes_(bytes) {}
    void release() {
      if (budget_ != nullptr) budget_->used_.fetch_sub(bytes_);
      budget_ = nullptr;
    }
    BodyBudget* budget_ = nullptr;
    std::int64_t bytes_ = 0;
  };

  Reservation reserve(std::int64_t bytes);
  std::int64_t used() const { return used_.load(); }
  std::int64_t limit() const { return limit_; }

 private:
  const std::int64_t limit_;
  std::atomic<std::int64_t> used_{0};
};

/// Admits at most `per_second` request log lines a second; the lines refused are counted and
/// reported in one summary line at the start of the next second that logs.
class LogRate {
 public:
  explicit LogRate(int per_second) : per_second_(per_second) {}
  /// True when this line may be written. `dropped` is set to the count of lines refused in
  /// earlier seconds, once, to be written as a summary (0 when there is none).
  bool admit(std::chrono::steady_clock::time_point now, std::int64_t& dropped);

 private:
  const int per_second_;
  std::atomic<std::int64_t> second_{-1};
  std::atomic<std::int64_t> admitted_{0};
  std::atomic<std::int64_t> refused_{0};
};

}  // namespace server
