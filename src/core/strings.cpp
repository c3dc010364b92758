#include <cstdio>

#include "sitepose/core/echo.hpp"
#include "sitepose/core/enum_names.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/hex.hpp"
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

constexpr auto kTrackingStateNames = enum_names<TrackingState>(
    {{TrackingState::kOk, "OK"}, {TrackingState::kRecovering, "RECOVERING"}, {TrackingState::kLost, "LOST"}},
    "UNKNOWN");

const char* to_string(TrackingState state) { return kTrackingStateNames.name(state); }

std::string hex(std::uint32_t value, HexStyle style) {
  char text[16];
  std::snprintf(text, sizeof(text), style == HexStyle::kLiteral ? "0x%X" : "%08x", value);
  return text;
}

std::string echo_value(std::string_view text, std::size_t max_chars) {
  std::string out;
  std::size_t shown = 0;
  for (; shown < text.size() && out.size() < max_chars; ++shown) {
    const auto c = static_cast<unsigned char>(text[shown]);
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c < 0x20 || c == 0x7f) {
      char hex[8];
      std::snprintf(hex, sizeof(hex), "\\x%02X", c);
      out += hex;
    } else {
      out += static_cast<char>(c);
    }
  }
  if (shown < text.size()) out += "... (" + std::to_string(text.size()) + " bytes)";
  return out;
}

}  // namespace sitepose
