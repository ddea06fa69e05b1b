// HTTP types the request handler and the session layer share, and problem+json responses.
#pragma once

#include <boost/beast/http.hpp>

#include <functional>
#include <string>
#include <string_view>
#include <variant>

namespace server {

namespace http = boost::beast::http;
using Request = http::request<http::string_body>;
using Response = http::response<http::string_body>;

/// An RFC 9457 problem details response (application/problem+json) naming the offending field
/// by JSON pointer when there is one.
Response problem(const Request& request, http::status status, std::string_view title,
                 std::string_view detail, std::string_view pointer = "");

/// Work a request needs from the generation pool: its estimated cost and the function that
/// produces the response there.
struct Deferred {
  double cost = 0.0;
  std::function<Response()> work;
};

/// What handling a request gives: the response now, or work for the generation pool.
using Outcome = std::variant<Response, Deferred>;

}  // namespace server
