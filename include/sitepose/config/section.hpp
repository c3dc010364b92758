#pragma once
// Configuration keys declared once. A Section<S> is the table of one YAML
// mapping: each key bound to a field of struct S with its rules. The one
// table
//   - reads a mapping into S through YamlMap (validation and messages as in
//     yaml_reader.hpp: "file:line: path.key = value: rule"); absent keys keep
//     the value already in S, so S's default member initialisers are the
//     defaults and the table holds none of its own;
//   - writes S back as YAML (write_yaml: the resolved configuration, which
//     reads back to an equal S);
//   - lists every key with its value (entries), which documented files such
//     as config/sitepose.yaml are checked against (check_documented).
//
// Usage, for struct Orb { int n_levels = 8; int ini = 20; int min = 7; }:
//   Section<Orb> orb;
//   orb.key("n_levels", &Orb::n_levels, in_range(1, 16))
//       .key("ini", &Orb::ini, at_least(1))
//       .key("min", &Orb::min, at_least(1))
//       .check([](const ReadKeys& keys, const Orb& o) {
//         if (keys.valid("min") && o.min > o.ini) keys.report("min", "must be <= ini");
//       });
//   Section<Config> root;
//   root.section("orb", &Config::orb, orb);
//   root.read(reader.root(), config);
//
// Sections are built once (function-local statics) and are immutable after;
// read() and write() are const and may run on any thread, each read on its
// own YamlReader.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "sitepose/config/yaml_reader.hpp"
#include "sitepose/core/expected.hpp"

namespace sitepose::config {

// ---- writing --------------------------------------------------------------

// One line of written YAML: a key with its value text, or the start of a
// nested mapping (section) whose keys follow one level deeper.
struct YamlEntry {
  std::string path;  // dotted key path, "outputs.can.path"
  std::string key;   // its last part, "path"
  int depth = 0;     // nesting level, 0 at the top
  bool section = false;
  std::string value;  // YAML text of the value; empty for a section
  // An optional section absent from the value: nothing is written for it
  // but `note` (a comment on the parent's line). With expand_absent the
  // section's keys follow, written from its defaults, marked `absent` too.
  bool absent = false;
  std::string note;
};

class YamlWriter {
 public:
  // expand_absent: also list the keys of absent optional sections.
  explicit YamlWriter(bool expand_absent = false) : expand_absent_(expand_absent) {}

  void value(std::string_view key, std::string text);
  void begin_section(std::string_view key);
  // A section written a second time at the same place (a file adding its
  // own keys to another file's section, siteposed's `mapping`) is merged
  // into the first when it ends: its keys follow the first one's, and the
  // text holds the section once.
  void end_section();
  // An optional section that is not set. Returns whether its keys are to
  // follow (expand_absent); then end_section() closes it.
  bool absent_section(std::string_view key, std::string note);

  const std::vector<YamlEntry>& entries() const { return entries_; }
  // Block-style YAML, two spaces per level; a section with nothing to write
  // is "key: {}", followed by the notes of its absent sections.
  std::string text() const;

 private:
  std::string path_of(std::string_view key) const;

  bool expand_absent_ = false;
  std::vector<std::string> path_;  // open sections
  int absent_depth_ = 0;           // depth inside the open absent section, 0 = none
  std::vector<YamlEntry> entries_;
};

// YAML text of a value: numbers that read back exactly, strings always
// double-quoted with escapes, lists in flow style.
std::string yaml_text(bool value);
std::string yaml_text(int value);
std::string yaml_text(std::int64_t value);
std::string yaml_text(double value);
std::string yaml_text(const std::string& value);
template <typename T>
std::string yaml_text(const std::vector<T>& values) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i > 0) out += ", ";
    out += yaml_text(values[i]);
  }
  return out + "]";
}

// ---- reading --------------------------------------------------------------

// What a section check sees: the mapping and which of the section's keys
// were present with a valid value (a cross-field rule on a key that failed
// its own rule would only repeat the problem).
class ReadKeys {
 public:
  ReadKeys(const YamlMap& map, std::vector<std::string> valid, std::size_t key_count)
      : map_(map), valid_(std::move(valid)), key_count_(key_count) {}

  const YamlMap& map() const { return map_; }
  bool valid(std::string_view key) const;
  // Every key of the section present and valid.
  bool all_valid() const { return valid_.size() == key_count_; }
  void report(std::string_view key, std::string_view message) const { map_.report(key, message); }

  // A key required only in some settings: reports it missing, or (when it
  // was read) the first rule its value breaks. True when present and valid.
  template <typename T, typename... Rules>
  bool require(std::string_view key, const T& value, const Rules&... rules) const {
    if (!map_.require(key)) return false;
    return valid(key) && map_.check(key, value, rules...);
  }

 private:
  const YamlMap& map_;
  std::vector<std::string> valid_;
  std::size_t key_count_ = 0;
};

// A named value of an enum, for Section::choice.
template <typename E>
struct Choice {
  E value;
  const char* name;
};

template <typename S>
class Section {
 public:
  using Check = std::function<void(const ReadKeys&, const S&)>;

  // A key bound to a member; T is a type YamlMap::read supports.
  template <typename T, typename... Rules>
  Section& key(std::string name, T S::*member, Rules... rules) {
    return add_key(std::move(name), false, Access<T>::of(member), std::move(rules)...);
  }
  // Same, and an absent key is an error.
  template <typename T, typename... Rules>
  Section& required(std::string name, T S::*member, Rules... rules) {
    return add_key(std::move(name), true, Access<T>::of(member), std::move(rules)...);
  }
  // A member of another arithmetic type (std::size_t, std::uint8_t) read
  // and written as Y; the rules must keep the value in the member's range.
  template <typename Y, typename M, typename... Rules>
  Section& key_as(std::string name, M S::*member, Rules... rules) {
    Access<Y> access{[member](const S& s) { return static_cast<Y>(s.*member); },
                     [member](S& s, Y v) { s.*member = static_cast<M>(v); }};
    return add_key(std::move(name), false, std::move(access), std::move(rules)...);
  }
  // A key whose YAML value is computed from S and stored back (units,
  // vectors in Eigen types): get(const S&) -> Y, set(S&, Y).
  template <typename Get, typename Set, typename... Rules>
  Section& computed(std::string name, Get get, Set set, Rules... rules) {
    using Y = std::decay_t<std::invoke_result_t<Get, const S&>>;
    return add_key(std::move(name), false, Access<Y>{std::move(get), std::move(set)}, std::move(rules)...);
  }
  // An enum member written as its name; other names are errors listing the
  // accepted ones ("expected one of: candump, stdout").
  template <typename E>
  Section& choice(std::string name, E S::*member, std::vector<Choice<E>> choices) {
    std::vector<std::string> names;
    names.reserve(choices.size());
    for (const auto& c : choices) names.emplace_back(c.name);
    std::string expectation = "expected one of: " + join_choices(names, ", ");
    auto parse = [choices, expectation](const std::string& text) -> Expected<E> {
      for (const auto& c : choices) {
        if (text == c.name) return c.value;
      }
      return make_error(ErrorCode::kInvalidArgument, expectation);
    };
    auto format = [choices](E value) -> std::string {
      for (const auto& c : choices) {
        if (c.value == value) return c.name;
      }
      return "?";
    };
    return parsed(std::move(name), member, std::move(parse), std::move(format));
  }
  // A member parsed from a string by parse(const std::string&) -> Expected<T>
  // (its error message is the rule) and written bare as format(value).
  template <typename T, typename Parse, typename Format>
  Section& parsed(std::string name, T S::*member, Parse parse, Format format) {
    Field field;
    field.name = name;
    field.read = [name, member, parse](const YamlMap& map, S& s) {
      return map.read_parsed(name, s.*member, parse);
    };
    field.write = [name, member, format](const S& s, YamlWriter& out) {
      out.value(name, std::string(format(s.*member)));
    };
    fields_.push_back(std::move(field));
    return *this;
  }

  // A nested mapping.
  template <typename N>
  Section& section(const std::string& name, N S::*member, Section<N> nested) {
    auto table = std::make_shared<const Section<N>>(std::move(nested));
    Field field;
    field.name = name;
    field.nested = true;
    field.read = [name, member, table](const YamlMap& map, S& s) {
      table->read(map.map(name), s.*member);
      return false;
    };
    field.write = [name, member, table](const S& s, YamlWriter& out) {
      out.begin_section(name);
      table->write(s.*member, out);
      out.end_section();
    };
    fields_.push_back(std::move(field));
    return *this;
  }
  // A nested mapping whose keys are fields of S itself (a file layout that
  // groups keys differently from the structs).
  Section& group(const std::string& name, Section<S> nested) {
    auto table = std::make_shared<const Section<S>>(std::move(nested));
    Field field;
    field.name = name;
    field.nested = true;
    field.read = [name, table](const YamlMap& map, S& s) {
      table->read(map.map(name), s);
      return false;
    };
    field.write = [name, table](const S& s, YamlWriter& out) {
      out.begin_section(name);
      table->write(s, out);
      out.end_section();
    };
    fields_.push_back(std::move(field));
    return *this;
  }
  // A nested mapping that is absent unless the file gives it (then read
  // from N's defaults); `note` says what holds when it is absent.
  template <typename N>
  Section& optional_section(const std::string& name, std::optional<N> S::*member, Section<N> nested,
                            const std::string& note) {
    auto table = std::make_shared<const Section<N>>(std::move(nested));
    Field field;
    field.name = name;
    field.nested = true;
    field.read = [name, member, table](const YamlMap& map, S& s) {
      if (!map.has(name)) return false;
      N value{};
      table->read(map.map(name), value);
      s.*member = std::move(value);
      return false;
    };
    field.write = [name, member, table, note](const S& s, YamlWriter& out) {
      if (s.*member) {
        out.begin_section(name);
        table->write(*(s.*member), out);
        out.end_section();
      } else if (out.absent_section(name, note)) {
        table->write(N{}, out);
        out.end_section();
      }
    };
    fields_.push_back(std::move(field));
    return *this;
  }
  // The keys of a member struct at this level (a file embedding another
  // file's sections next to its own).
  template <typename N>
  Section& embed(N S::*member, Section<N> nested) {
    auto table = std::make_shared<const Section<N>>(std::move(nested));
    Field field;
    field.nested = true;
    field.read = [member, table](const YamlMap& map, S& s) {
      table->read(map, s.*member);
      return false;
    };
    field.write = [member, table](const S& s, YamlWriter& out) { table->write(s.*member, out); };
    fields_.push_back(std::move(field));
    return *this;
  }

  // A rule over several keys, run after the section's keys were read (in
  // the order added), reporting through ReadKeys.
  Section& check(Check rule) {
    checks_.push_back(std::move(rule));
    return *this;
  }

  void read(const YamlMap& map, S& value) const {
    std::vector<std::string> valid;
    std::size_t key_count = 0;
    for (const Field& field : fields_) {
      if (!field.nested) ++key_count;
      if (field.read(map, value) && !field.nested) valid.push_back(field.name);
    }
    const ReadKeys keys(map, std::move(valid), key_count);
    for (const Check& rule : checks_) rule(keys, value);
  }

  void write(const S& value, YamlWriter& out) const {
    for (const Field& field : fields_) field.write(value, out);
  }

 private:
  // A key's value as the YAML type Y, whatever the member's type.
  template <typename Y>
  struct Access {
    std::function<Y(const S&)> get;
    std::function<void(S&, Y)> set;

    static Access of(Y S::*member) {
      return {[member](const S& s) { return s.*member; }, [member](S& s, Y v) { s.*member = std::move(v); }};
    }
  };

  struct Field {
    std::string name;     // empty for embed()
    bool nested = false;  // a section: not a key of this mapping's checks
    // True when the key was present and valid (always false for sections).
    std::function<bool(const YamlMap&, S&)> read;
    std::function<void(const S&, YamlWriter&)> write;
  };

  template <typename Y, typename... Rules>
  Section& add_key(std::string name, bool required, Access<Y> access, Rules... rules) {
    Field field;
    field.name = name;
    field.read = [name, required, access, rules...](const YamlMap& map, S& s) {
      Y value = access.get(s);
      const bool ok = required ? map.read_required(name, value, rules...) : map.read(name, value, rules...);
      if (ok) access.set(s, std::move(value));
      return ok;
    };
    field.write = [name, get = access.get](const S& s, YamlWriter& out) {
      out.value(name, yaml_text(get(s)));
    };
    fields_.push_back(std::move(field));
    return *this;
  }

  std::vector<Field> fields_;
  std::vector<Check> checks_;
};

template <typename S>
std::vector<YamlEntry> entries(const Section<S>& section, const S& value, bool expand_absent) {
  YamlWriter out(expand_absent);
  section.write(value, out);
  return out.entries();
}

template <typename S>
std::string write_yaml(const Section<S>& section, const S& value) {
  YamlWriter out;
  section.write(value, out);
  return out.text();
}

// ---- documented files -----------------------------------------------------

struct DocumentedFile {
  std::string path;
  // Keys set to a deployment value on purpose (their comment states the
  // default); each must differ from the default.
  std::vector<std::string> shipped_values;
  // Top-level sections documented in another file: their keys need not be
  // present here (those present are still checked).
  std::vector<std::string> documented_elsewhere;
};

namespace detail {
// Compares a documented file with the table's keys: `defaults` and
// `documented` are the entries (expand_absent) of S{} and of the file read
// into S{}; `reader` holds the file (finish() passed).
Status compare_documented(const DocumentedFile& file, const std::string& text, const YamlReader& reader,
                          const std::vector<YamlEntry>& defaults, const std::vector<YamlEntry>& documented);
}  // namespace detail

// A documented file agrees with the table: it reads without a problem (no
// key outside the table), every key of the table is in it with its default
// value (or in `shipped_values`), and the keys of optional sections that
// are absent by default appear in comments ("#   fx: 700.0"). Errors
// (kInvalidArgument) list every disagreement.
template <typename S>
Status check_documented(const Section<S>& section, const DocumentedFile& file) {
  SITEPOSE_TRY(const std::string text, read_yaml_file(file.path));
  SITEPOSE_TRY(const YamlReader reader, YamlReader::from_string(text, file.path));
  S documented{};
  section.read(reader.root(), documented);
  SITEPOSE_TRY_STATUS(reader.finish());
  return detail::compare_documented(file, text, reader, entries(section, S{}, true),
                                    entries(section, documented, true));
}

}  // namespace sitepose::config
