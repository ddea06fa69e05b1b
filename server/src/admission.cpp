#include "server/admission.hpp"

#include <algorithm>
#include <cctype>
#include <string_view>
#include <vector>

namespace server {

std::optional<FramingRefusal> check_framing(const http::request_header<>& header) {
  const auto lines = header.equal_range(http::field::transfer_encoding);
  if (lines.first == lines.second) return std::nullopt;
  // The codings, lower-cased, of every Transfer-Encoding line in order.
  std::vector<std::string> codings;
  for (auto it = lines.first; it != lines.second; ++it) {
    const std::string_view value(it->value().data(), it->value().size());
    std::size_t start = 0;
    while (start <= value.size()) {
      const std::size_t comma = std::min(value.find(',', start), value.size());
      std::string_view token = value.substr(start, comma - start);
      while (!token.empty() && (token.front() == ' ' || token.front() == '\t')) {
        token.remove_prefix(1);
      }
      while (!token.empty() && (token.back() == ' ' || token.back() == '\t')) {
        token.remove_suffix(1);
      }
      if (!token.empty()) {
        std::string coding(token);
        std::transform(coding.begin(), coding.end(), coding.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        codings.push_back(std::move(coding));
      }
      start = comma + 1;
    }
  }
  if (header.version() < 11) {
    return FramingRefusal{http::status::bad_request,
                          "Transfer-Encoding is not allowed in an HTTP/1.0 request"};
  }
  if (codings.empty() || codings.back() != "chunked") {
    return FramingRefusal{http::status::bad_request,
                          "the final transfer coding must be chunked, else the body's length "
                          "is unknown (RFC 9112 section 6.3)"};
  }
  if (codings.size() > 1) {
    return FramingRefusal{http::status::not_implemented,
                          "transfer codings other than a single chunked are not supported"};
  }
  if (header.find(http::field::content_length) != header.end()) {
    return FramingRefusal{http::status::bad_request,
                          "a request may not carry both Transfer-Encoding and Content-Length"};
  }
  return std::nullopt;
}

BodyBudget::Reservation BodyBudget::reserve(std::int64_t bytes) {
  const std::int64_t before = used_.fetch_add(bytes);
  if (bytes > 0 && before + bytes > limit_) {
    used_.fetch_sub(bytes);
    return {};
  }
  return {this, bytes};
}

bool LogRate::admit(std::chrono::steady_clock::time_point now, std::int64_t& dropped) {
  dropped = 0;
  const std::int64_t second =
      std::chrono::duration_cast<std::chrono::seconds>(now.time_since_epoch()).count();
  std::int64_t seen = second_.load();
  if (seen != second && second_.compare_exchange_strong(seen, second)) {
    // The first line of a new second: report what the seconds before refused.
    dropped = refused_.exchange(0);
    admitted_.store(0);
  }
  if (admitted_.fetch_add(1) < per_second_) return true;
  refused_.fetch_add(1);
  return false;
}

}  // namespace server
