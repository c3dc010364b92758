#include "sitepose/core/expected.hpp"
#include "sitepose/core/pose_estimate.hpp"

namespace sitepose {

const char* to_string(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument: return "invalid argument";
    case ErrorCode::kNotFound: return "not found";
    case ErrorCode::kParseError: return "parse error";
    case ErrorCode::kIoError: return "I/O error";
    case ErrorCode::kUnsupported: return "unsupported";
    case ErrorCode::kRuntime: return "runtime error";
  }
  return "unknown error";
}

const char* to_string(TrackingState state) {
  switch (state) {
    case TrackingState::kOk: return "OK";
    case TrackingState::kRecovering: return "RECOVERING";
    case TrackingState::kLost: return "LOST";
  }
  return "UNKNOWN";
}

}  // namespace sitepose
