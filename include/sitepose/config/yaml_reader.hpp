#pragma once
// Validated YAML reading for every sitepose file format built on YAML
// (sitepose.yaml, simulator scenarios, daemon settings).
//
// Contract:
// - A YamlReader owns one parsed document. YamlMap is a cheap view of one
//   mapping inside it; views share the reader's state and stay valid as long
//   as any view or the reader lives. Not thread-safe: read on one thread.
// - Every read names its key, so the reader knows the keys each mapping may
//   hold. finish() reports every problem at once: values of the wrong type,
//   values breaking a rule, missing required keys, duplicate keys and keys no
//   read asked for ("unknown key"). Messages look like
//     file.yaml:12: tracking.min_inliers_ok = -3: must be >= 10
//     file.yaml:7: dynamic.modee: unknown key (expected one of: mode, tau_mar)
//     file.yaml:3: orb.n_features = "many": expected an integer
//   (line numbers are 1-based; absent when the problem has no place in the
//   file, e.g. a missing key is reported at its parent mapping's line).
// - Absent optional keys leave the destination untouched: the caller's
//   struct default is the documented default. A key present with no value
//   (`key:`) is an error for scalars and an empty mapping for sections.
// - Nothing throws out of this API: yaml-cpp exceptions become errors.
//
// Usage:
//   SITEPOSE_TRY(auto reader, YamlReader::from_file(path));
//   YamlMap orb = reader.root().map("orb");
//   orb.read("n_features", cfg.n_features, at_least(100));
//   SITEPOSE_TRY_STATUS(reader.finish());

#include <charconv>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "sitepose/core/expected.hpp"

namespace sitepose::config {

namespace detail {
struct ReaderState;

// Shortest text that reads back to the same number ("0.5", "1e-06", "10").
template <typename T>
std::string number_text(T value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}
inline std::string number_text(const std::string& value) { return "\"" + value + "\""; }
inline std::string number_text(const char* value) { return "\"" + std::string(value) + "\""; }
}  // namespace detail

// A rule on a parsed value: `accepts(value)` says whether it is allowed,
// `expectation` completes "key = value: <expectation>".
template <typename Check>
struct ValueRule {
  Check accepts;
  std::string expectation;
};

template <typename Check>
ValueRule<Check> make_rule(Check check, std::string expectation) {
  return ValueRule<Check>{std::move(check), std::move(expectation)};
}

// Numeric rules; the bound's type need not match the field's (int vs double).
template <typename B>
auto at_least(B bound) {
  return make_rule([bound](const auto& v) { return v >= bound; },
                   "must be >= " + detail::number_text(bound));
}
template <typename B>
auto at_most(B bound) {
  return make_rule([bound](const auto& v) { return v <= bound; },
                   "must be <= " + detail::number_text(bound));
}
template <typename B>
auto greater_than(B bound) {
  return make_rule([bound](const auto& v) { return v > bound; },
                   "must be > " + detail::number_text(bound));
}
template <typename B>
auto less_than(B bound) {
  return make_rule([bound](const auto& v) { return v < bound; },
                   "must be < " + detail::number_text(bound));
}
template <typename B>
auto in_range(B low, B high) {  // closed interval [low, high]
  return make_rule([low, high](const auto& v) { return v >= low && v <= high; },
                   "must be in [" + detail::number_text(low) + ", " +
                       detail::number_text(high) + "]");
}
inline auto positive() {
  return make_rule([](const auto& v) { return v > 0; }, "must be > 0");
}
inline auto non_negative() {
  return make_rule([](const auto& v) { return v >= 0; }, "must be >= 0");
}
// Strings and lists.
inline auto non_empty() {
  return make_rule([](const auto& v) { return !v.empty(); }, "must not be empty");
}
// A string equal to one of the listed choices.
std::string join_choices(const std::vector<std::string>& choices, std::string_view separator);
inline auto one_of(std::vector<std::string> choices) {
  std::string expectation = "expected one of: " + join_choices(choices, ", ");
  return make_rule(
      [choices = std::move(choices)](const std::string& v) {
        for (const auto& choice : choices) {
          if (v == choice) return true;
        }
        return false;
      },
      std::move(expectation));
}
// Every element of a list satisfies `rule`.
template <typename Check>
auto each(ValueRule<Check> rule) {
  return make_rule(
      [accepts = std::move(rule.accepts)](const auto& list) {
        for (const auto& element : list) {
          if (!accepts(element)) return false;
        }
        return true;
      },
      "every element " + rule.expectation);
}

class YamlMap {
 public:
  // Dotted path of this mapping ("" for the document root, "machines[2].path").
  const std::string& path() const;
  // Path of a key of this mapping ("machines[2].path.speed_mps").
  std::string key_path(std::string_view key) const;
  // 1-based line of this mapping in the file, 0 when unknown.
  int line() const;

  // Views are handles: const methods still record reads and errors in the
  // shared reader state.

  // True when the key is present. Registers the key as known.
  bool has(std::string_view key) const;
  // Keys present in this mapping, in file order (does not mark them known;
  // use for mappings whose keys are names, then read each one).
  std::vector<std::string> keys() const;

  // Optional value: absent -> `value` untouched and false; present and valid
  // -> assigned and true; present and invalid -> error recorded, `value`
  // untouched, false. Rules are checked in order, the first broken one is
  // reported. Supported T: bool, int, int64_t, double (finite only),
  // std::string, and std::vector of those, std::vector<std::vector<double>>.
  template <typename T, typename... Rules>
  bool read(std::string_view key, T& value, const Rules&... rules) const {
    T parsed = value;
    if (!parse_value(key, parsed)) return false;
    if (!check_rules(key, parsed, rules...)) return false;
    value = std::move(parsed);
    return true;
  }

  // As read(), and a missing key is an error too.
  template <typename T, typename... Rules>
  bool read_required(std::string_view key, T& value, const Rules&... rules) const {
    if (!require(key)) return false;
    return read(key, value, rules...);
  }

  // A key required only in some settings (a cross-field rule): false and
  // reported missing when absent. Registers the key as known.
  bool require(std::string_view key) const;

  // Checks a value already read against rules, reporting the first broken
  // one about `key` (cross-field rules that reuse the rule helpers).
  template <typename T, typename... Rules>
  bool check(std::string_view key, const T& value, const Rules&... rules) const {
    return check_rules(key, value, rules...);
  }

  // A string turned into T by `parse` (std::string -> Expected<T>), e.g. an
  // enum by name; parse's error message becomes the expectation.
  template <typename T, typename Parse>
  bool read_parsed(std::string_view key, T& value, Parse&& parse) const {
    std::string text;
    if (!parse_value(key, text)) return false;
    auto parsed = parse(text);
    if (!parsed) {
      report(key, parsed.error().message);
      return false;
    }
    value = std::move(parsed).value();
    return true;
  }

  // Nested mapping. Absent or `key:` with no value -> an empty mapping (all
  // reads keep their defaults); not a mapping -> error and an empty mapping.
  YamlMap map(std::string_view key) const;
  // Sequence of mappings (`machines: [{...}, {...}]`), paths `key[i]`.
  // Absent -> empty; not a sequence, or an element not a mapping -> error.
  std::vector<YamlMap> maps(std::string_view key) const;

  // Records an error about a key of this mapping (cross-field checks):
  // "file:line: path.key = value: message" (value and line when present).
  void report(std::string_view key, std::string_view message) const;
  // Records an error about this mapping as a whole.
  void report_here(std::string_view message) const;

 private:
  friend class YamlReader;
  YamlMap(std::shared_ptr<detail::ReaderState> state, int record);

  bool parse_value(std::string_view key, bool& out) const;
  bool parse_value(std::string_view key, int& out) const;
  bool parse_value(std::string_view key, std::int64_t& out) const;
  bool parse_value(std::string_view key, double& out) const;
  bool parse_value(std::string_view key, std::string& out) const;
  bool parse_value(std::string_view key, std::vector<int>& out) const;
  bool parse_value(std::string_view key, std::vector<std::int64_t>& out) const;
  bool parse_value(std::string_view key, std::vector<double>& out) const;
  bool parse_value(std::string_view key, std::vector<std::string>& out) const;
  bool parse_value(std::string_view key, std::vector<std::vector<double>>& out) const;

  template <typename T, typename Rule, typename... Rest>
  bool check_rules(std::string_view key, const T& value, const Rule& rule,
                   const Rest&... rest) const {
    if (!rule.accepts(value)) {
      report(key, rule.expectation);
      return false;
    }
    return check_rules<T>(key, value, rest...);
  }
  template <typename T>
  bool check_rules(std::string_view, const T&) const {
    return true;
  }

  std::shared_ptr<detail::ReaderState> state_;
  int record_ = 0;  // index of this mapping in the reader's records
};

// Largest YAML text read (1 MiB; the shipped files are a few kB): a larger
// one is a mistake, such as a log or an image given as --config.
inline constexpr std::size_t kMaxYamlBytes = std::size_t{1} << 20;
// finish() lists at most this many problems, then their count.
inline constexpr std::size_t kMaxReportedProblems = 100;

// The text of a configuration file: kNotFound (cannot open), kInvalidArgument
// (a directory; larger than kMaxYamlBytes), kIoError (read failed). Messages
// name the path.
Expected<std::string> read_yaml_file(const std::string& path);

class YamlReader {
 public:
  // Errors: kNotFound (no such file), kParseError (malformed YAML, with the
  // file and line), kInvalidArgument (the document is not a mapping, or the
  // text is larger than kMaxYamlBytes). An empty document is an empty
  // mapping.
  static Expected<YamlReader> from_file(const std::string& path);
  static Expected<YamlReader> from_string(std::string_view text, std::string source_name);

  // The document's top-level mapping.
  YamlMap root() const;

  // Call after all reads: ok, or kInvalidArgument with every problem found,
  // one per line, in file order where known (the first
  // kMaxReportedProblems, then how many more). Adds the unknown keys of every
  // mapping that was opened; mappings never opened were reported as unknown
  // keys of their parent.
  Status finish() const;

  // Problems recorded so far (without the unknown-key pass).
  std::vector<std::string> errors() const;

  // Name used in messages (the path, or the source name given).
  const std::string& source_name() const;

 private:
  explicit YamlReader(std::shared_ptr<detail::ReaderState> state);
  std::shared_ptr<detail::ReaderState> state_;
};

}  // namespace sitepose::config
