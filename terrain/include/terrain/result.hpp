// Expected-style results for input that may be wrong: a value, or a message with the JSON pointer
// of the offending field. Bad input never throws across a module boundary.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace terrain {

/// Whose fault an error is, so that a caller answering with a status picks it from the kind and
/// never from the message or the pointer.
enum class ErrorKind {
  invalid,      ///< the input is malformed or out of range
  not_found,    ///< the input names something that does not exist (a format, a file)
  unsupported,  ///< well-formed, but asks for what this build or scheme does not offer
  internal,     ///< a contract inside broke or a dependency failed: not the caller's fault
};

/// Why an input was refused, and where (RFC 6901 JSON pointer, "" for the whole document).
struct Error {
  std::string message;
  std::string pointer;
  ErrorKind kind = ErrorKind::invalid;
};

/// The same error, marked as the callee's fault (an encoder failing on what the module made).
inline Error internal_error(Error error) {
  error.kind = ErrorKind::internal;
  return error;
}

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
