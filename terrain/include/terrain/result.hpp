// Expected-style results for input that may be wrong: a value, or a message with the JSON pointer
// of the offending field. Bad input never throws across a module boundary.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace terrain {

/// Why an input was refused, and where (RFC 6901 JSON pointer, "" for the whole document).
struct Error {
  std::string message;
  std::string pointer;
};

/// A value or an error; E defaults to Error (message + JSON pointer), other modules may carry
/// their own error type (a store's "not found" or "conflict", say).
template <class T, class E = Error>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::move(value)) {}  // NOLINT: implicit by design
  Result(E error) : state_(std::move(error)) {}  // NOLINT: implicit by design

  bool ok() const { return state_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & {
    assert(ok());
    return std::get<0>(state_);
  }
  const T& value() const& {
    assert(ok());
    return std::get<0>(state_);
  }
  T&& value() && {
    assert(ok());
    return std::get<0>(std::move(state_));
  }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  const E& error() const {
    assert(!ok());
    return std::get<1>(state_);
  }

 private:
  std::variant<T, E> state_;
};

/// For operations that yield nothing but may fail.
struct Ok {};
using Status = Result<Ok>;

}  // namespace terrain
