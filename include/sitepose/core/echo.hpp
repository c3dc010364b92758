#pragma once
// User input quoted back in a message is capped and kept on one line, so a
// bad value (a 10 MB config line, a whole file given as a name) cannot
// flood a terminal or a journal.

#include <cstddef>
#include <string>
#include <string_view>

namespace sitepose {

inline constexpr std::size_t kMaxEchoChars = 80;

// `text` with control characters escaped (\n, \t, \xNN); when longer than
// `max_chars`, its first `max_chars` characters and "... (N bytes)".
std::string echo_value(std::string_view text, std::size_t max_chars = kMaxEchoChars);

}  // namespace sitepose
