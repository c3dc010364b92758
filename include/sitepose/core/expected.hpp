#pragma once
// Errors as values: every run-time failure in sitepose returns
// Expected<T> (a value or an Error saying why). Shaped like C++23
// std::expected, which GCC 12 lacks in C++20 mode.

#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <variant>

namespace sitepose {

enum class ErrorCode {
  kInvalidArgument,  // bad usage or bad input data (maps to exit status 2)
  kNotFound,         // a file, frame, key or device that should exist does not
  kParseError,       // malformed file content
  kIoError,          // read/write/device failure while running
  kUnsupported,      // a feature or mode that is not available
  kRuntime,          // any other failure while running (exit status 1)
};

const char* to_string(ErrorCode code);

struct Error {
  ErrorCode code = ErrorCode::kRuntime;
  std::string message;

  // Exit status per the command contract in FORMATS.md: 2 for bad usage or
  // bad input, 1 for a failure while running.
  int exit_status() const {
    switch (code) {
      case ErrorCode::kInvalidArgument:
      case ErrorCode::kNotFound:
      case ErrorCode::kParseError:
      case ErrorCode::kUnsupported: return 2;
      default: return 1;
    }
  }
};

// Tag wrapper so Expected<Error>-like ambiguities cannot happen.
struct Unexpected {
  Error error;
};

inline Unexpected make_error(ErrorCode code, std::string message) {
  return Unexpected{Error{code, std::move(message)}};
}

// SITEPOSE_CHECK: programmer errors (broken invariants), never input errors.
#define SITEPOSE_CHECK(cond)                                                        \
  do {                                                                              \
    if (!(cond)) {                                                                  \
      std::fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
      std::abort();                                                                 \
    }                                                                               \
  } while (false)

// Its copy and move operations are std::variant's: they throw when T's do
// (cv::Mat's move is not noexcept), which the exception-escape check flags
// for every Expected<T> that is move-assigned.
template <typename T>
class [[nodiscard]] Expected {  // NOLINT(bugprone-exception-escape)
 public:
  Expected(T value) : storage_(std::in_place_index<0>, std::move(value)) {}  // NOLINT
  Expected(Unexpected unexpected)                                            // NOLINT
      : storage_(std::in_place_index<1>, std::move(unexpected.error)) {}

  bool has_value() const { return storage_.index() == 0; }
  explicit operator bool() const { return has_value(); }

  T& value() & {
    SITEPOSE_CHECK(has_value());
    return std::get<0>(storage_);
  }
  const T& value() const& {
    SITEPOSE_CHECK(has_value());
    return std::get<0>(storage_);
  }
  T&& value() && {
    SITEPOSE_CHECK(has_value());
    return std::get<0>(std::move(storage_));
  }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  const Error& error() const {
    SITEPOSE_CHECK(!has_value());
    return std::get<1>(storage_);
  }

 private:
  std::variant<T, Error> storage_;
};

// Expected<void>: success or an Error.
template <>
class [[nodiscard]] Expected<void> {
 public:
  Expected() = default;
  Expected(Unexpected unexpected) : error_(std::move(unexpected.error)), ok_(false) {}  // NOLINT

  bool has_value() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const {
    SITEPOSE_CHECK(!ok_);
    return error_;
  }

 private:
  Error error_;
  bool ok_ = true;
};

using Status = Expected<void>;

inline Status ok_status() { return Status{}; }

}  // namespace sitepose

// Propagate an error from an Expected-returning call:
//   SITEPOSE_TRY(auto cam, load_camera(path));
#define SITEPOSE_CONCAT_INNER(a, b) a##b
#define SITEPOSE_CONCAT(a, b) SITEPOSE_CONCAT_INNER(a, b)
// The NOLINT must stay on the line that uses decl.
// clang-format off
#define SITEPOSE_TRY(decl, expr)                                                     \
  auto SITEPOSE_CONCAT(sitepose_try_, __LINE__) = (expr);                            \
  if (!SITEPOSE_CONCAT(sitepose_try_, __LINE__))                                     \
    return ::sitepose::Unexpected{SITEPOSE_CONCAT(sitepose_try_, __LINE__).error()}; \
  decl = std::move(SITEPOSE_CONCAT(sitepose_try_, __LINE__)).value() /* NOLINT(bugprone-macro-parentheses): decl declares */
// clang-format on
#define SITEPOSE_TRY_STATUS(expr)                                                   \
  do {                                                                              \
    auto sitepose_status_ = (expr);                                                 \
    if (!sitepose_status_) return ::sitepose::Unexpected{sitepose_status_.error()}; \
  } while (false)
