// HTTP types the request handler and the session layer share, and problem+json responses.
#pragma once

#include <boost/beast/http.hpp>

#include "server/sealed_file.hpp"
#include "terrain/result.hpp"

#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

namespace server {

namespace http = boost::beast::http;

/// The bytes of a response body: text made for this response, or an immutable buffer shared with
/// a cache (a tile, a static file), which is then sent without being copied.
class Payload {
 public:
  Payload() = default;
  // Implicit, so that `r.body() = text` reads as it would for a string body.
  Payload(std::string text)  // NOLINT(google-explicit-constructor)
      : bytes_(text.empty() ? nullptr : std::make_shared<const std::string>(std::move(text))) {}
  Payload(const char* text) : Payload(std::string(text)) {}  // NOLINT(google-explicit-constructor)
  explicit Payload(std::shared_ptr<const std::string> shared,
                   std::shared_ptr<const SealedFile> file = nullptr)
      : bytes_(std::move(shared)), file_(std::move(file)) {}

  std::string_view view() const { return bytes_ ? std::string_view(*bytes_) : std::string_view(); }
  operator std::string_view() const { return view(); }  // NOLINT: a payload is its bytes
  const char* data() const { return view().data(); }
  std::size_t size() const { return bytes_ ? bytes_->size() : 0; }
  bool empty() const { return size() == 0; }
  void clear() {
    bytes_.reset();
    file_.reset();
  }
  /// The same bytes in a sealed file the session may sendfile() from, or null.
  const SealedFile* file() const { return file_.get(); }

 private:
  std::shared_ptr<const std::string> bytes_;
  std::shared_ptr<const SealedFile> file_;
};

/// A Beast body over a Payload (responses only: requests are read into strings).
struct PayloadBody {
  using value_type = Payload;

  static std::uint64_t size(const value_type& body) { return body.size(); }

  class writer {
   public:
    using const_buffers_type = boost::asio::const_buffer;

    template <bool isRequest, class Fields>
    writer(const http::header<isRequest, Fields>&, const value_type& body) : body_(body) {}

    void init(boost::beast::error_code& ec) { ec = {}; }

    boost::optional<std::pair<const_buffers_type, bool>> get(boost::beast::error_code& ec) {
      ec = {};
      return {{const_buffers_type(body_.data(), body_.size()), false}};
    }

   private:
    const value_type& body_;
  };
};

using Request = http::request<http::string_body>;
using Response = http::response<PayloadBody>;

/// An RFC 9457 problem details response (application/problem+json) naming the offending field
/// by JSON pointer when there is one.
Response problem(const Request& request, http::status status, std::string_view title,
                 std::string_view detail, std::string_view pointer = "");

/// The status that answers an error of this kind: the one place where kinds become statuses.
http::status status_of(terrain::ErrorKind kind);

/// The problem response for an error from a module: its kind picks the status, `title` names a
/// refusal; an internal error is logged and answered 500 "Internal error" instead.
Response problem(const Request& request, std::string_view title, const terrain::Error& error);

/// `text` with every byte that does not start a well-formed UTF-8 sequence written as `\xHH`:
/// what an answer may echo of a client's bytes.
std::string escape_invalid_utf8(std::string_view text);

/// Work a request needs from the generation pool: its estimated cost and the function that
/// produces the response there.
struct Deferred {
  /// Which pool: tiles and other products come first; pictures (render.png, depth.bin) run on
  /// threads of their own at the lowest CPU priority, so that they never hold a tile back.
  enum class Lane { product, picture };
  double cost = 0.0;
  Lane lane = Lane::product;
  std::function<Response()> work;
  /// Set instead of `work` when the pool only prepares the request (parses and compiles the
  /// scene version it reads): an answer (an error), or nullopt, and the request is then handled
  /// again, which may defer its product in turn, on its own lane.
  std::function<std::optional<Response>()> prepare;
  /// Set by the session when the client has gone: work not started is skipped, and work that
  /// looks at it (renders, row by row) stops early. Shared with `work`'s captures.
  std::shared_ptr<std::atomic<bool>> abandoned = std::make_shared<std::atomic<bool>>(false);
};

/// What handling a request gives: the response now, or work for the generation pool.
using Outcome = std::variant<Response, Deferred>;

}  // namespace server
