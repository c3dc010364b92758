#include "sitepose/output/candump.hpp"
#include "sitepose/core/echo.hpp"

#include <cinttypes>
#include <cstdio>
#include <fstream>

namespace sitepose::output {

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

Unexpected parse_error(std::string_view line, const std::string& what) {
  return make_error(ErrorCode::kParseError, "candump line '" + echo_value(line) + "': " + what);
}

}  // namespace

Expected<std::string> format_candump_line(const CandumpRecord& r) {
  if (r.t_ns < 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      "candump timestamp t_ns = " + std::to_string(r.t_ns) + ": must be >= 0");
  }
  if (r.interface.empty() || r.interface.find_first_of(" \t\r\n#()") != std::string::npos) {
    return make_error(
        ErrorCode::kInvalidArgument,
        "candump interface '" + r.interface + "': must be a non-empty name without blanks");
  }
  const CanFrame& f = r.frame;
  if (f.dlc > kCanMaxDataBytes) {
    return make_error(ErrorCode::kInvalidArgument,
                      "CAN frame dlc = " + std::to_string(f.dlc) + ": must be 0..8");
  }
  const std::uint32_t mask = f.extended ? kCanExtendedIdMask : kCanStandardIdMask;
  if ((f.id & ~mask) != 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      "CAN id = " + std::to_string(f.id) + ": does not fit a " +
                          (f.extended ? "29" : "11") + "-bit identifier");
  }
  char buf[96];
  int n = std::snprintf(buf, sizeof(buf), "(%" PRId64 ".%06" PRId64 ") ", r.t_ns / 1'000'000'000,
                        (r.t_ns % 1'000'000'000) / 1000);
  std::string line(buf, static_cast<std::size_t>(n));
  line += r.interface;
  n = std::snprintf(buf, sizeof(buf), f.extended ? " %08X#" : " %03X#", f.id);
  line.append(buf, static_cast<std::size_t>(n));
  for (std::uint8_t i = 0; i < f.dlc; ++i) {
    n = std::snprintf(buf, sizeof(buf), "%02X", f.data[i]);
    line.append(buf, static_cast<std::size_t>(n));
  }
  return line;
}

Expected<CandumpRecord> parse_candump_line(std::string_view line) {
  std::string_view s = line;
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  CandumpRecord r;
  // "(sec.usec)"
  if (s.size() < 4 || s.front() != '(') return parse_error(line, "expected '(' and a timestamp");
  const std::size_t close = s.find(')');
  if (close == std::string_view::npos) return parse_error(line, "timestamp lacks ')'");
  const std::string_view stamp = s.substr(1, close - 1);
  const std::size_t dot = stamp.find('.');
  if (dot == std::string_view::npos || dot == 0 || stamp.size() - dot - 1 != 6) {
    return parse_error(line, "timestamp must be <seconds>.<6 digits>");
  }
  std::int64_t sec = 0;
  for (char c : stamp.substr(0, dot)) {
    if (c < '0' || c > '9' || sec > 9'000'000'000LL)
      return parse_error(line, "bad timestamp seconds");
    sec = sec * 10 + (c - '0');
  }
  std::int64_t usec = 0;
  for (char c : stamp.substr(dot + 1)) {
    if (c < '0' || c > '9') return parse_error(line, "bad timestamp microseconds");
    usec = usec * 10 + (c - '0');
  }
  r.t_ns = sec * 1'000'000'000 + usec * 1000;
  // " iface "
  s.remove_prefix(close + 1);
  if (s.empty() || s.front() != ' ')
    return parse_error(line, "expected a blank after the timestamp");
  s.remove_prefix(1);
  const std::size_t space = s.find(' ');
  if (space == std::string_view::npos || space == 0)
    return parse_error(line, "expected an interface name");
  r.interface = std::string(s.substr(0, space));
  s.remove_prefix(space + 1);
  // "ID#DATA"
  const std::size_t hash = s.find('#');
  if (hash == std::string_view::npos) return parse_error(line, "expected <id>#<data>");
  const std::string_view id = s.substr(0, hash);
  if (id.size() != 3 && id.size() != 8) return parse_error(line, "id must have 3 or 8 hex digits");
  std::uint32_t id_value = 0;
  for (char c : id) {
    const int h = hex_value(c);
    if (h < 0) return parse_error(line, "id is not hexadecimal");
    id_value = (id_value << 4) | static_cast<std::uint32_t>(h);
  }
  r.frame.extended = id.size() == 8;
  if ((id_value & ~(r.frame.extended ? kCanExtendedIdMask : kCanStandardIdMask)) != 0) {
    return parse_error(line, "id exceeds the identifier width");
  }
  r.frame.id = id_value;
  const std::string_view data = s.substr(hash + 1);
  if (!data.empty() && data.front() == '#')
    return parse_error(line, "CAN FD frames are not supported");
  if (!data.empty() && (data.front() == 'R' || data.front() == 'r')) {
    return parse_error(line, "remote frames are not supported");
  }
  if (data.size() % 2 != 0 || data.size() > 2 * kCanMaxDataBytes) {
    return parse_error(line, "data must be 0..8 bytes of 2 hex digits each");
  }
  r.frame.dlc = static_cast<std::uint8_t>(data.size() / 2);
  for (std::size_t i = 0; i < r.frame.dlc; ++i) {
    const int hi = hex_value(data[2 * i]);
    const int lo = hex_value(data[2 * i + 1]);
    if (hi < 0 || lo < 0) return parse_error(line, "data is not hexadecimal");
    r.frame.data[i] = static_cast<std::uint8_t>((hi << 4) | lo);
  }
  return r;
}

Expected<std::vector<CandumpRecord>> read_candump_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) return make_error(ErrorCode::kNotFound, "candump log '" + path + "': cannot open");
  std::vector<CandumpRecord> records;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    auto r = parse_candump_line(line);
    if (!r) {
      return make_error(ErrorCode::kParseError,
                        path + ":" + std::to_string(line_no) + ": " + r.error().message);
    }
    records.push_back(std::move(r).value());
  }
  if (in.bad()) return make_error(ErrorCode::kIoError, "candump log '" + path + "': read error");
  return records;
}

}  // namespace sitepose::output
