#include "detail/text.hpp"
#include "sitepose/core/echo.hpp"

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace sitepose::io::detail {

Expected<std::vector<std::string>> read_lines(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    return make_error(ErrorCode::kNotFound, path + ": file does not exist");
  }
  if (std::filesystem::is_directory(path, ec)) {
    return make_error(ErrorCode::kInvalidArgument, path + ": expected a file, found a directory");
  }
  std::ifstream in(path);
  if (!in) {
    return make_error(ErrorCode::kIoError, path + ": cannot open for reading: " + std::strerror(errno));
  }
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(std::move(line));
  }
  if (in.bad()) return make_error(ErrorCode::kIoError, path + ": read failed");
  return lines;
}

std::string where(const std::string& path, std::size_t line_no) {
  return path + ":" + std::to_string(line_no) + ": ";
}

std::string_view trim(std::string_view text) {
  const char* kSpace = " \t\r\n\f\v";
  const auto first = text.find_first_not_of(kSpace);
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(kSpace);
  return text.substr(first, last - first + 1);
}

bool is_blank(std::string_view line) { return trim(line).empty(); }

bool is_comment_or_blank(std::string_view line) {
  const std::string_view t = trim(line);
  return t.empty() || t.front() == '#';
}

std::vector<std::string_view> split_whitespace(std::string_view text) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    const std::size_t start = i;
    while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i > start) tokens.push_back(text.substr(start, i - start));
  }
  return tokens;
}

std::vector<std::string_view> split_fields(std::string_view text, char separator) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t pos = text.find(separator, start);
    if (pos == std::string_view::npos) {
      fields.push_back(trim(text.substr(start)));
      return fields;
    }
    fields.push_back(trim(text.substr(start, pos - start)));
    start = pos + 1;
  }
}

std::optional<double> parse_double(std::string_view token) {
  // from_chars rejects a leading '+', which some writers emit.
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return std::nullopt;
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || ptr != token.data() + token.size()) return std::nullopt;
  if (!std::isfinite(value)) return std::nullopt;
  return value;
}

std::optional<std::int64_t> parse_int64(std::string_view token) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return std::nullopt;
  std::int64_t value = 0;
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || ptr != token.data() + token.size()) return std::nullopt;
  return value;
}

Expected<std::vector<double>> parse_number_line(const std::string& path, std::size_t line_no,
                                                std::string_view line, std::size_t count) {
  const std::vector<std::string_view> tokens = split_whitespace(line);
  if (tokens.size() != count) {
    return make_error(ErrorCode::kParseError, where(path, line_no) + "expected " + std::to_string(count) +
                                                  (count == 1 ? " number, got " : " numbers, got ") +
                                                  std::to_string(tokens.size()));
  }
  std::vector<double> values;
  values.reserve(count);
  for (std::size_t i = 0; i < tokens.size(); ++i) {
    const std::optional<double> v = parse_double(tokens[i]);
    if (!v) {
      return make_error(ErrorCode::kParseError, where(path, line_no) + "field " + std::to_string(i + 1) +
                                                    " '" + echo_value(tokens[i]) +
                                                    "' is not a finite number");
    }
    values.push_back(*v);
  }
  return values;
}

std::size_t content_end(const std::vector<std::string>& lines) {
  std::size_t end = lines.size();
  while (end > 0 && is_blank(lines[end - 1])) --end;
  return end;
}

Unexpected timestamp_not_increasing(const std::string& where, std::int64_t last_ns, std::int64_t t_ns) {
  return make_error(ErrorCode::kParseError, where + "expected a timestamp after " + std::to_string(last_ns) +
                                                " ns, got " + std::to_string(t_ns));
}

}  // namespace sitepose::io::detail
