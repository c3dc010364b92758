#pragma once
// Strict text parsing shared by the io readers. Every failure message starts
// with "<path>:<line>: " so a user can open the file at the broken line.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sitepose/core/expected.hpp"

namespace sitepose::io::detail {

// The file's lines without line terminators ('\r' of CRLF files stripped).
// kNotFound when the file does not exist, kIoError when it cannot be read.
Expected<std::vector<std::string>> read_lines(const std::string& path);

// "<path>:<line_no>: " (line_no is 1-based).
std::string where(const std::string& path, std::size_t line_no);

std::string_view trim(std::string_view text);
bool is_blank(std::string_view line);
// Blank or starting with '#' after leading whitespace.
bool is_comment_or_blank(std::string_view line);

std::vector<std::string_view> split_whitespace(std::string_view text);
// Splits on every `separator`; fields are trimmed; "a,,b" gives an empty middle field.
std::vector<std::string_view> split_fields(std::string_view text, char separator);

// Whole-token parses: the token must be consumed completely.
// parse_double also rejects NaN and infinities.
std::optional<double> parse_double(std::string_view token);
std::optional<std::int64_t> parse_int64(std::string_view token);

// Parses a whitespace-separated line of exactly `count` finite numbers;
// errors read "<path>:<line>: expected 12 numbers, got 11" or
// "<path>:<line>: field 3 'abc' is not a finite number".
Expected<std::vector<double>> parse_number_line(const std::string& path, std::size_t line_no,
                                                std::string_view line, std::size_t count);

// Index one past the last non-blank line: trailing blank lines are allowed,
// blank lines inside a per-frame file are not (they would shift frames).
std::size_t content_end(const std::vector<std::string>& lines);

// Which lines of a file hold data: files with free-form comments (TUM,
// EuRoC csv) skip comments and blank lines anywhere; per-frame files (KITTI
// poses, times.txt) take every line up to content_end.
enum class DataLines { kSkipCommentsAndBlanks, kEveryLineToContentEnd };

// Reads `path` and calls parse(line_no, line) -> Status on each data line in
// order, stopping at the first error (line_no is 1-based).
template <typename Parse>
Status for_each_data_line(const std::string& path, DataLines which, Parse&& parse) {
  SITEPOSE_TRY(const std::vector<std::string> lines, read_lines(path));
  const bool skip = which == DataLines::kSkipCommentsAndBlanks;
  const std::size_t end = skip ? lines.size() : content_end(lines);
  for (std::size_t i = 0; i < end; ++i) {
    if (skip && is_comment_or_blank(lines[i])) continue;
    SITEPOSE_TRY_STATUS(parse(i + 1, std::string_view(lines[i])));
  }
  return ok_status();
}

// "<where>expected a timestamp after <last_ns> ns, got <t_ns>" for files whose
// nanosecond timestamps must increase.
Unexpected timestamp_not_increasing(const std::string& where, std::int64_t last_ns, std::int64_t t_ns);

}  // namespace sitepose::io::detail
