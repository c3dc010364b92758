#include "sitepose/config/yaml_reader.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <limits>
#include <optional>
#include <type_traits>
#include <unordered_map>

#include "detail/file_head.hpp"
#include "sitepose/core/echo.hpp"

namespace sitepose::config {

namespace detail {

struct MapRecord {
  std::string path;
  YAML::Node node;                 // a mapping, or null for an absent/empty one
  std::vector<std::string> known;  // every key a read asked for
};

struct Problem {
  int line = 0;  // 1-based; 0 = no place in the file
  std::string text;
};

struct ReaderState {
  std::string source;
  std::vector<MapRecord> records;
  std::unordered_map<std::string, int> record_by_path;  // records[i].path -> i
  std::vector<Problem> problems;
};

}  // namespace detail

namespace {

using detail::MapRecord;
using detail::ReaderState;

struct Entry {
  YAML::Node key;
  YAML::Node value;
};

int line_of(const YAML::Node& node) {
  if (!node.IsDefined()) return 0;
  const YAML::Mark mark = node.Mark();
  return mark.line >= 0 ? mark.line + 1 : 0;
}

// Where a value lives: its own mark, or its key's for an empty value after
// `key:` (yaml-cpp marks that at the next token, often the next line).
int line_of(const Entry& entry) {
  if (!entry.value.IsDefined() || entry.value.IsNull()) return line_of(entry.key);
  const int line = line_of(entry.value);
  return line > 0 ? line : line_of(entry.key);
}

std::string join_path(const std::string& parent, std::string_view key) {
  if (parent.empty()) return std::string(key);
  return parent + "." + std::string(key);
}

std::optional<Entry> find_entry(const YAML::Node& map, std::string_view key) {
  if (!map.IsMap()) return std::nullopt;
  for (auto it = map.begin(); it != map.end(); ++it) {
    if (it->first.IsScalar() && it->first.Scalar() == key) return Entry{it->first, it->second};
  }
  return std::nullopt;
}

bool looks_like_number(const std::string& text) {
  if (text.empty()) return false;
  const char* begin = text.data() + (text[0] == '+' ? 1 : 0);
  const char* end = text.data() + text.size();
  double value = 0.0;
  const auto result = std::from_chars(begin, end, value);
  return result.ec == std::errc() && result.ptr == end && std::isfinite(value);
}

// The value as the user wrote it, for messages.
// Capped (echo_value): a value may be a whole file given by mistake.
std::string value_text(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "(empty)";
  if (node.IsScalar()) {
    const std::string& s = node.Scalar();
    if (looks_like_number(s) || s == "true" || s == "false") return echo_value(s);
    return "\"" + echo_value(s) + "\"";
  }
  YAML::Emitter out;
  out.SetMapFormat(YAML::Flow);
  out.SetSeqFormat(YAML::Flow);
  out << node;
  return echo_value(out.c_str());
}

std::string prefix(const ReaderState& state, int line) {
  if (line > 0) return state.source + ":" + std::to_string(line) + ": ";
  return state.source + ": ";
}

void add_problem(ReaderState& state, int line, const std::string& text) {
  state.problems.push_back({line, prefix(state, line) + text});
}

void register_known(MapRecord& record, std::string_view key) {
  if (std::find(record.known.begin(), record.known.end(), key) == record.known.end()) {
    record.known.emplace_back(key);
  }
}

// Duplicate keys: yaml-cpp keeps both and lookups see the first, so the
// second would be silently ignored. One hash lookup per key: files with tens
// of thousands of keys are checked in milliseconds.
void check_duplicates(ReaderState& state, const MapRecord& record) {
  if (!record.node.IsMap()) return;
  std::unordered_map<std::string, int> first_line;
  for (auto it = record.node.begin(); it != record.node.end(); ++it) {
    if (!it->first.IsScalar()) {
      add_problem(state, line_of(it->first),
                  join_path(record.path, value_text(it->first)) + ": keys must be plain names");
      continue;
    }
    const auto [first, inserted] = first_line.try_emplace(it->first.Scalar(), line_of(it->first));
    if (!inserted) {
      add_problem(state, line_of(it->first),
                  join_path(record.path, it->first.Scalar()) + ": duplicate key (first at line " +
                      std::to_string(first->second) + ")");
    }
  }
}

int open_record(ReaderState& state, const std::string& path, const YAML::Node& node) {
  const auto [known, inserted] =
      state.record_by_path.try_emplace(path, static_cast<int>(state.records.size()));
  if (!inserted) return known->second;
  state.records.push_back(MapRecord{path, node, {}});
  check_duplicates(state, state.records.back());
  return known->second;
}

// ---- decoding one node into a typed value -------------------------------

struct Failure {
  YAML::Node where;    // the offending node
  std::string suffix;  // appended to the key path, e.g. "[3]"
  std::string expectation;
};

// What a value of type T must look like, for "expected ..." messages.
template <typename T>
const char* type_name() {
  if constexpr (std::is_same_v<T, bool>) return "a boolean (true or false)";
  if constexpr (std::is_same_v<T, int> || std::is_same_v<T, std::int64_t>) return "an integer";
  if constexpr (std::is_same_v<T, double>) return "a finite number";
  if constexpr (std::is_same_v<T, std::string>) return "a string";
  if constexpr (std::is_same_v<T, std::vector<double>>) return "a list of numbers";
  static_assert(std::is_same_v<T, bool> || std::is_same_v<T, int> || std::is_same_v<T, std::int64_t> ||
                    std::is_same_v<T, double> || std::is_same_v<T, std::string> ||
                    std::is_same_v<T, std::vector<double>>,
                "type_name: a type the YAML reader does not decode");
}

template <typename T>
struct ParsedNumber {
  T value{};
  std::errc error{};
  bool whole_scalar = false;  // the number is all of the scalar, and it is not empty
};

// std::from_chars over a scalar. YAML allows a leading '+', from_chars does
// not: it is skipped here.
template <typename T>
ParsedNumber<T> parse_number(const std::string& scalar) {
  const char* begin = scalar.data() + (!scalar.empty() && scalar[0] == '+' ? 1 : 0);
  const char* end = scalar.data() + scalar.size();
  ParsedNumber<T> parsed;
  const auto result = std::from_chars(begin, end, parsed.value);
  parsed.error = result.ec;
  parsed.whole_scalar = result.ptr == end && begin != end;
  return parsed;
}

template <typename T>
std::optional<Failure> decode_integer(const YAML::Node& node, T& out) {
  const Failure fail{node, "", std::string("expected ") + type_name<T>()};
  if (!node.IsScalar()) return fail;
  const ParsedNumber<T> parsed = parse_number<T>(node.Scalar());
  if (parsed.error == std::errc::result_out_of_range) {
    return Failure{node, "",
                   "out of range for an integer (limits " +
                       detail::number_text(std::numeric_limits<T>::min()) + ", " +
                       detail::number_text(std::numeric_limits<T>::max()) + ")"};
  }
  if (parsed.error != std::errc() || !parsed.whole_scalar) return fail;
  out = parsed.value;
  return std::nullopt;
}

std::optional<Failure> decode(const YAML::Node& node, int& out) { return decode_integer(node, out); }
std::optional<Failure> decode(const YAML::Node& node, std::int64_t& out) { return decode_integer(node, out); }

std::optional<Failure> decode(const YAML::Node& node, double& out) {
  const Failure fail{node, "", std::string("expected ") + type_name<double>()};
  if (!node.IsScalar()) return fail;
  const ParsedNumber<double> parsed = parse_number<double>(node.Scalar());
  if (parsed.error != std::errc() || !parsed.whole_scalar || !std::isfinite(parsed.value)) return fail;
  out = parsed.value;
  return std::nullopt;
}

std::optional<Failure> decode(const YAML::Node& node, bool& out) {
  // Only true/false: YAML 1.1's yes/no/on/off are too easy to misread.
  if (node.IsScalar()) {
    const std::string& s = node.Scalar();
    if (s == "true" || s == "True" || s == "TRUE") {
      out = true;
      return std::nullopt;
    }
    if (s == "false" || s == "False" || s == "FALSE") {
      out = false;
      return std::nullopt;
    }
  }
  return Failure{node, "", std::string("expected ") + type_name<bool>()};
}

std::optional<Failure> decode(const YAML::Node& node, std::string& out) {
  if (!node.IsScalar()) return Failure{node, "", "expected a string"};
  out = node.Scalar();
  return std::nullopt;
}

template <typename T>
std::optional<Failure> decode(const YAML::Node& node, std::vector<T>& out) {
  if (!node.IsSequence()) {
    return Failure{node, "", std::string("expected a list (each element ") + type_name<T>() + ")"};
  }
  std::vector<T> values;
  values.reserve(node.size());
  for (std::size_t i = 0; i < node.size(); ++i) {
    T value{};
    if (auto failure = decode(node[i], value)) {
      failure->suffix = "[" + std::to_string(i) + "]" + failure->suffix;
      return failure;
    }
    values.push_back(std::move(value));
  }
  out = std::move(values);
  return std::nullopt;
}

template <typename T>
bool parse_any(ReaderState& state, int record_index, std::string_view key, T& out) {
  MapRecord& record = state.records[record_index];
  register_known(record, key);
  const auto entry = find_entry(record.node, key);
  if (!entry) return false;
  const std::string path = join_path(record.path, key);
  // An empty value (`key:`) fails decoding like any wrong type.
  T value = out;
  if (auto failure = decode(entry->value, value)) {
    const bool whole_value = failure->suffix.empty();
    const int line = !whole_value && line_of(failure->where) > 0 ? line_of(failure->where) : line_of(*entry);
    add_problem(state, line,
                path + failure->suffix + " = " + value_text(failure->where) + ": " + failure->expectation);
    return false;
  }
  out = std::move(value);
  return true;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::vector<detail::Problem> unknown_keys(const ReaderState& state) {
  std::vector<detail::Problem> out;
  for (const MapRecord& record : state.records) {
    if (!record.node.IsMap()) continue;
    for (auto it = record.node.begin(); it != record.node.end(); ++it) {
      if (!it->first.IsScalar()) continue;  // reported as a bad key already
      const std::string& key = it->first.Scalar();
      if (std::find(record.known.begin(), record.known.end(), key) != record.known.end()) continue;
      std::string text = join_path(record.path, key) + ": unknown key";
      if (record.known.empty()) {
        text += " (this mapping takes no keys)";
      } else {
        text += " (expected one of: " + join_choices(record.known, ", ") + ")";
        std::string best;
        std::size_t best_distance = 3;  // suggest only near misses
        for (const std::string& known : record.known) {
          const std::size_t d = edit_distance(key, known);
          if (d < best_distance) {
            best_distance = d;
            best = known;
          }
        }
        if (!best.empty()) text += "; did you mean " + best + "?";
      }
      const int line = line_of(it->first);
      out.push_back({line, prefix(state, line) + text});
    }
  }
  return out;
}

Unexpected too_large(const std::string& source, const std::string& size_bytes) {
  return make_error(ErrorCode::kInvalidArgument, source + ": " + size_bytes +
                                                     " bytes, larger than a configuration file may be (" +
                                                     std::to_string(kMaxYamlBytes) + " bytes = 1 MiB)");
}

}  // namespace

std::string join_choices(const std::vector<std::string>& choices, std::string_view separator) {
  std::string out;
  for (std::size_t i = 0; i < choices.size(); ++i) {
    if (i > 0) out += separator;
    out += choices[i];
  }
  return out;
}

// ---- YamlMap --------------------------------------------------------------

YamlMap::YamlMap(std::shared_ptr<detail::ReaderState> state, int record)
    : state_(std::move(state)), record_(record) {}

const std::string& YamlMap::path() const { return state_->records[record_].path; }

std::string YamlMap::key_path(std::string_view key) const { return join_path(path(), key); }

int YamlMap::line() const { return line_of(state_->records[record_].node); }

bool YamlMap::has(std::string_view key) const {
  MapRecord& record = state_->records[record_];
  register_known(record, key);
  return find_entry(record.node, key).has_value();
}

std::vector<std::string> YamlMap::keys() const {
  std::vector<std::string> out;
  const YAML::Node& node = state_->records[record_].node;
  if (!node.IsMap()) return out;
  for (auto it = node.begin(); it != node.end(); ++it) {
    if (it->first.IsScalar()) out.push_back(it->first.Scalar());
  }
  return out;
}

bool YamlMap::parse_value(std::string_view key, bool& out) const {
  return parse_any(*state_, record_, key, out);
}
bool YamlMap::parse_value(std::string_view key, int& out) const {
  return parse_any(*state_, record_, key, out);
}
bool YamlMap::parse_value(std::string_view key, std::int64_t& out) const {
  return parse_any(*state_, record_, key, out);
}
bool YamlMap::parse_value(std::string_view key, double& out) const {
  return parse_any(*state_, record_, key, out);
}
bool YamlMap::parse_value(std::string_view key, std::string& out) const {
  return parse_any(*state_, record_, key, out);
}
bool YamlMap::parse_value(std::string_view key, std::vector<int>& out) const {
  return parse_any(*state_, record_, key, out);
}
bool YamlMap::parse_value(std::string_view key, std::vector<std::int64_t>& out) const {
  return parse_any(*state_, record_, key, out);
}
bool YamlMap::parse_value(std::string_view key, std::vector<double>& out) const {
  return parse_any(*state_, record_, key, out);
}
bool YamlMap::parse_value(std::string_view key, std::vector<std::string>& out) const {
  return parse_any(*state_, record_, key, out);
}
bool YamlMap::parse_value(std::string_view key, std::vector<std::vector<double>>& out) const {
  return parse_any(*state_, record_, key, out);
}

bool YamlMap::require(std::string_view key) const {
  if (has(key)) return true;
  add_problem(*state_, line(), key_path(key) + ": missing (required key)");
  return false;
}

void YamlMap::report(std::string_view key, std::string_view message) const {
  const auto entry = find_entry(state_->records[record_].node, key);
  if (!entry) {
    add_problem(*state_, line(), key_path(key) + ": " + std::string(message));
    return;
  }
  add_problem(*state_, line_of(*entry),
              key_path(key) + " = " + value_text(entry->value) + ": " + std::string(message));
}

void YamlMap::report_here(std::string_view message) const {
  const std::string& p = path();
  add_problem(*state_, line(), (p.empty() ? std::string("(top level)") : p) + ": " + std::string(message));
}

YamlMap YamlMap::map(std::string_view key) const {
  register_known(state_->records[record_], key);
  const std::string path = key_path(key);
  const auto entry = find_entry(state_->records[record_].node, key);
  YAML::Node node;  // null: an empty mapping
  if (entry && entry->value.IsMap()) {
    node = entry->value;
  } else if (entry && entry->value.IsDefined() && !entry->value.IsNull()) {
    report(key, "expected a mapping");
  }
  const int index = open_record(*state_, path, node);
  return YamlMap(state_, index);
}

std::vector<YamlMap> YamlMap::maps(std::string_view key) const {
  register_known(state_->records[record_], key);
  std::vector<YamlMap> out;
  const auto entry = find_entry(state_->records[record_].node, key);
  if (!entry || !entry->value.IsDefined() || entry->value.IsNull()) return out;
  if (!entry->value.IsSequence()) {
    report(key, "expected a list of mappings");
    return out;
  }
  const std::string base = key_path(key);
  for (std::size_t i = 0; i < entry->value.size(); ++i) {
    const YAML::Node element = entry->value[i];
    const std::string path = base + "[" + std::to_string(i) + "]";
    if (!element.IsMap()) {
      add_problem(*state_, line_of(element) > 0 ? line_of(element) : line_of(*entry),
                  path + " = " + value_text(element) + ": expected a mapping");
      continue;
    }
    out.push_back(YamlMap(state_, open_record(*state_, path, element)));
  }
  return out;
}

// ---- YamlReader -----------------------------------------------------------

YamlReader::YamlReader(std::shared_ptr<detail::ReaderState> state) : state_(std::move(state)) {}

Expected<std::string> read_yaml_file(const std::string& path) {
  SITEPOSE_TRY(std::string text,
               detail::read_file_head(path, kMaxYamlBytes, "config file", ", expected a YAML file"));
  if (text.size() > kMaxYamlBytes) return too_large(path, "more than " + std::to_string(kMaxYamlBytes));
  return text;
}

Expected<YamlReader> YamlReader::from_file(const std::string& path) {
  SITEPOSE_TRY(const std::string text, read_yaml_file(path));
  return from_string(text, path);
}

Expected<YamlReader> YamlReader::from_string(std::string_view text, std::string source_name) {
  if (text.size() > kMaxYamlBytes) return too_large(source_name, std::to_string(text.size()));
  auto state = std::make_shared<ReaderState>();
  state->source = std::move(source_name);
  YAML::Node document;
  try {
    document = YAML::Load(std::string(text));
  } catch (const YAML::ParserException& e) {
    const int line = e.mark.line >= 0 ? e.mark.line + 1 : 0;
    std::string where = state->source;
    if (line > 0) where += ":" + std::to_string(line) + ":" + std::to_string(e.mark.column + 1);
    return make_error(ErrorCode::kParseError, where + ": malformed YAML: " + e.msg);
  } catch (const YAML::Exception& e) {
    return make_error(ErrorCode::kParseError, state->source + ": malformed YAML: " + e.msg);
  }
  if (document.IsDefined() && !document.IsNull() && !document.IsMap()) {
    const int line = line_of(document);
    return make_error(ErrorCode::kInvalidArgument, prefix(*state, line) +
                                                       "expected a mapping (key: value lines) at the top "
                                                       "level, got " +
                                                       value_text(document));
  }
  if (!document.IsMap()) document = YAML::Node();  // empty file = empty mapping
  open_record(*state, "", document);
  return YamlReader(std::move(state));
}

YamlMap YamlReader::root() const { return YamlMap(state_, 0); }

const std::string& YamlReader::source_name() const { return state_->source; }

std::vector<std::string> YamlReader::errors() const {
  std::vector<std::string> out;
  for (const auto& problem : state_->problems) out.push_back(problem.text);
  return out;
}

Status YamlReader::finish() const {
  std::vector<detail::Problem> all = state_->problems;
  for (auto& problem : unknown_keys(*state_)) all.push_back(std::move(problem));
  if (all.empty()) return ok_status();
  // File order; problems without a line (none today) go last.
  std::stable_sort(all.begin(), all.end(), [](const detail::Problem& a, const detail::Problem& b) {
    const int la = a.line > 0 ? a.line : std::numeric_limits<int>::max();
    const int lb = b.line > 0 ? b.line : std::numeric_limits<int>::max();
    return la < lb;
  });
  // A file of garbage gives one problem per line; the first ones say what
  // is wrong, thousands more would only flood the terminal or journal.
  const std::size_t shown = std::min(all.size(), kMaxReportedProblems);
  std::string message;
  for (std::size_t i = 0; i < shown; ++i) {
    if (i > 0) message += "\n";
    message += all[i].text;
  }
  if (shown < all.size()) {
    message += "\n" + state_->source + ": " + std::to_string(all.size() - shown) + " more problems not shown";
  }
  return make_error(ErrorCode::kInvalidArgument, message);
}

}  // namespace sitepose::config
