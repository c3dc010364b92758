#include "sitepose/drivers/aravis/feature_file.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace sitepose::drivers::aravis {

namespace {

constexpr std::size_t kMaxFileBytes = 1 << 20;

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r");
  return s.substr(first, last - first + 1);
}

bool is_feature_name(std::string_view s) {
  if (s.empty()) return false;
  auto letter = [](char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_'; };
  auto digit = [](char c) { return c >= '0' && c <= '9'; };
  if (!letter(s.front())) return false;
  for (char c : s) {
    if (!letter(c) && !digit(c)) return false;
  }
  return true;
}

bool is_one_word(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (u <= 0x20 || u == 0x7F || c == '\'' || c == '"') return false;
  }
  return true;
}

// One line without its comment, trimmed and not empty.
Expected<FeatureStep> parse_step(std::string_view line, int number, const std::string& path) {
  auto bad = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidArgument,
                      path + ":" + std::to_string(number) + ": \"" + std::string(line) + "\": " + why);
  };
  FeatureStep step;
  step.line = number;
  const auto eq = line.find('=');
  const std::string_view name = trim(line.substr(0, eq));
  if (!is_feature_name(name)) return bad("expected a GenICam feature name ([A-Za-z_][A-Za-z0-9_]*)");
  step.name = std::string(name);
  if (eq == std::string_view::npos) return step;
  const std::string_view value = trim(line.substr(eq + 1));
  if (!is_one_word(value)) return bad("expected Name=Value with a value of one word (no spaces or quotes)");
  step.value = std::string(value);
  return step;
}

}  // namespace

Expected<FeatureFile> parse_feature_file(std::string_view text, const std::string& path) {
  FeatureFile file;
  file.path = path;
  int number = 0;
  std::size_t start = 0;
  while (start <= text.size()) {
    const auto end = std::min(text.find('\n', start), text.size());
    ++number;
    std::string_view line = text.substr(start, end - start);
    line = trim(line.substr(0, line.find('#')));
    if (!line.empty()) {
      SITEPOSE_TRY(FeatureStep step, parse_step(line, number, path));
      file.steps.push_back(std::move(step));
    }
    start = end + 1;
  }
  return file;
}

Expected<FeatureFile> read_feature_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    return make_error(ErrorCode::kInvalidArgument, "feature file " + path + ": is a folder");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "feature file " + path + ": cannot open it");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return make_error(ErrorCode::kIoError, "feature file " + path + ": read failed");
  const std::string s = std::move(text).str();
  if (s.size() > kMaxFileBytes) {
    return make_error(ErrorCode::kInvalidArgument, "feature file " + path + ": larger than 1 MiB");
  }
  return parse_feature_file(s, path);
}

}  // namespace sitepose::drivers::aravis
