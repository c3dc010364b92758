#pragma once
// candump log lines, as written by `candump -L` and read by can-utils'
// log2asc / python-can's CanutilsLogReader:
//   (1700000000.000000) can0 09F8011C#6A3C4B23D0F1C204
// Timestamp: seconds since the Unix epoch with 6 decimals; id: 8 hex digits
// for an extended (29-bit) frame, 3 for a standard one; data: 2 hex digits a
// byte, upper case, none for dlc 0. Classic CAN only: CAN FD ("##") and
// remote frames ("R") are rejected by the reader. Pure functions + a file
// reader; no threads.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/output/can_frame.hpp"

namespace sitepose::output {

struct CandumpRecord {
  std::int64_t t_ns = 0;  // ns since the Unix epoch; the log keeps microseconds
  std::string interface;  // e.g. "can0"
  CanFrame frame;

  friend bool operator==(const CandumpRecord&, const CandumpRecord&) = default;
};

// One line without the newline. Fails (kInvalidArgument) for t_ns < 0, an
// empty interface or one with blanks, dlc > 8, or an id wider than its format.
Expected<std::string> format_candump_line(const CandumpRecord& record);

// Parses one line (trailing blanks/newline allowed). Errors (kParseError)
// quote the line and say which part is malformed.
Expected<CandumpRecord> parse_candump_line(std::string_view line);

// Reads a whole log; blank lines are skipped. Errors name "path:line".
Expected<std::vector<CandumpRecord>> read_candump_file(const std::string& path);

}  // namespace sitepose::output
