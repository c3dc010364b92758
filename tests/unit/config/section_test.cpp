#include "sitepose/config/section.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/testing/files.hpp"

namespace sitepose::config {
namespace {

enum class Sink { kFile, kStdout };

struct Limits {
  int low = 1;
  int high = 10;
};

struct Point {
  double x_m = 0.0;
  double y_m = 0.0;
};

struct Settings {
  bool enabled = true;
  std::string path;
  std::size_t capacity = 4;
  std::int64_t offset_ns = 0;
  Sink sink = Sink::kFile;
  std::vector<std::string> names{"a", "b"};
  Limits limits;
  std::optional<Point> origin;
};

Section<Limits> limits_section() {
  Section<Limits> s;
  s.key("low", &Limits::low, at_least(0))
      .key("high", &Limits::high, at_least(0))
      .check([](const ReadKeys& keys, const Limits& l) {
        if (keys.valid("high") && l.high < l.low) keys.report("high", "must be >= low");
      });
  return s;
}

Section<Point> point_section() {
  Section<Point> s;
  s.required("x_m", &Point::x_m).required("y_m", &Point::y_m);
  return s;
}

const Section<Settings>& settings_section() {
  static const Section<Settings> section = [] {
    Section<Settings> output;
    output.key("enabled", &Settings::enabled)
        .key("path", &Settings::path)
        .choice("sink", &Settings::sink,
                {Choice<Sink>{Sink::kFile, "file"}, Choice<Sink>{Sink::kStdout, "stdout"}})
        .check([](const ReadKeys& keys, const Settings& s) {
          if (s.enabled && s.sink == Sink::kFile) keys.require("path", s.path, non_empty());
        });
    Section<Settings> s;
    s.group("output", std::move(output))
        .key_as<int>("capacity", &Settings::capacity, in_range(1, 64))
        .computed(
            "offset_s", [](const Settings& v) { return static_cast<double>(v.offset_ns) * 1e-9; },
            [](Settings& v, double t) { v.offset_ns = static_cast<std::int64_t>(t * 1e9); })
        .key("names", &Settings::names)
        .section("limits", &Settings::limits, limits_section())
        .optional_section("origin", &Settings::origin, point_section(), "origin from the map");
    return s;
  }();
  return section;
}

struct Loaded {
  Settings value;
  std::string problems;
};

Loaded load(const std::string& text) {
  auto reader = YamlReader::from_string(text, "s.yaml");
  EXPECT_TRUE(reader.has_value());
  Loaded out;
  settings_section().read(reader->root(), out.value);
  if (const Status status = reader->finish(); !status) out.problems = status.error().message;
  return out;
}

TEST(Section, AbsentKeysKeepTheStructDefaults) {
  const Loaded loaded = load("output: {path: out.txt}\n");
  EXPECT_EQ(loaded.problems, "");
  EXPECT_EQ(loaded.value.path, "out.txt");
  EXPECT_EQ(loaded.value.capacity, 4u);
  EXPECT_EQ(loaded.value.names, (std::vector<std::string>{"a", "b"}));
  EXPECT_FALSE(loaded.value.origin.has_value());
}

TEST(Section, ReadsEveryKindOfKey) {
  const Loaded loaded = load(
      "output: {enabled: false, sink: stdout}\ncapacity: 16\noffset_s: 0.25\nnames: []\n"
      "limits: {low: 2, high: 3}\norigin: {x_m: 1.5, y_m: -2}\n");
  ASSERT_EQ(loaded.problems, "");
  EXPECT_FALSE(loaded.value.enabled);
  EXPECT_EQ(loaded.value.sink, Sink::kStdout);
  EXPECT_EQ(loaded.value.capacity, 16u);
  EXPECT_EQ(loaded.value.offset_ns, 250'000'000);
  EXPECT_TRUE(loaded.value.names.empty());
  EXPECT_EQ(loaded.value.limits.low, 2);
  ASSERT_TRUE(loaded.value.origin.has_value());
  EXPECT_DOUBLE_EQ(loaded.value.origin->y_m, -2.0);
}

TEST(Section, RulesChoicesAndChecksReportInTheReaderStyle) {
  const Loaded loaded = load(
      "output:\n  sink: pipe\n  enabled: false\ncapacity: 100\nlimits: {low: 5, high: 4}\n"
      "origin: {x_m: 1}\nextra: 1\n");
  EXPECT_EQ(loaded.problems,
            "s.yaml:2: output.sink = \"pipe\": expected one of: file, stdout\n"
            "s.yaml:4: capacity = 100: must be in [1, 64]\n"
            "s.yaml:5: limits.high = 4: must be >= low\n"
            "s.yaml:6: origin.y_m: missing (required key)\n"
            "s.yaml:7: extra: unknown key (expected one of: output, capacity, offset_s, names, "
            "limits, origin)");
}

TEST(Section, ConditionalRequirementAndCheckSkipInvalidKeys) {
  // enabled with sink file needs a path...
  EXPECT_EQ(load("output: {enabled: true}\n").problems, "s.yaml:1: output.path: missing (required key)");
  EXPECT_EQ(load("output: {path: \"\"}\n").problems, "s.yaml:1: output.path = \"\": must not be empty");
  // ... but not otherwise.
  EXPECT_EQ(load("output: {enabled: false}\n").problems, "");
  // A key that broke its own rule is not checked again.
  EXPECT_EQ(load("output: {path: x}\nlimits: {low: 5, high: -1}\n").problems,
            "s.yaml:2: limits.high = -1: must be >= 0");
}

TEST(Section, WritesWhatReadsBackToTheSameValues) {
  Settings changed;
  changed.enabled = false;
  changed.path = "a \"quoted\"\tpath";
  changed.capacity = 32;
  changed.offset_ns = -1'500'000'000;
  changed.sink = Sink::kStdout;
  changed.names = {"x y", "yes", "1"};
  changed.limits = {3, 7};
  changed.origin = Point{1.0 / 3.0, 2.0};
  const std::string text = write_yaml(settings_section(), changed);
  const Loaded again = load(text);
  ASSERT_EQ(again.problems, "") << text;
  EXPECT_EQ(write_yaml(settings_section(), again.value), text);
  EXPECT_EQ(again.value.path, changed.path);
  EXPECT_EQ(again.value.names, changed.names);
  EXPECT_EQ(again.value.origin->x_m, 1.0 / 3.0);
  EXPECT_EQ(again.value.offset_ns, changed.offset_ns);
}

TEST(Section, WriterLayout) {
  Settings value;
  value.path = "out";
  EXPECT_EQ(write_yaml(settings_section(), value),
            "output:\n"
            "  enabled: true\n"
            "  path: \"out\"\n"
            "  sink: file\n"
            "capacity: 4\n"
            "offset_s: 0\n"
            "names: [\"a\", \"b\"]\n"
            "limits:\n"
            "  low: 1\n"
            "  high: 10\n");
}

TEST(Section, EmptySectionCarriesTheNoteOfItsAbsentPart) {
  struct Outer {
    Settings inner;
  };
  Section<Outer> outer;
  Section<Settings> only_origin;
  only_origin.optional_section("origin", &Settings::origin, point_section(), "from the map");
  outer.section("place", &Outer::inner, std::move(only_origin));
  EXPECT_EQ(write_yaml(outer, Outer{}), "place: {}  # from the map\n");
  Outer set;
  set.inner.origin = Point{1, 2};
  EXPECT_EQ(write_yaml(outer, set), "place:\n  origin:\n    x_m: 1\n    y_m: 2\n");
}

// A file that adds its own keys to another file's section (siteposed's
// mapping.map_file in sitepose's mapping): one section in the text, the
// added keys after the others, read back to the same values.
TEST(Section, AddedKeysGoIntoTheSectionWrittenBefore) {
  struct Both {
    Settings base;
    Limits extra{5, 7};
  };
  Section<Limits> extra;
  extra.key("top", &Limits::high);
  Section<Both> both;
  both.embed(&Both::base, settings_section()).section("limits", &Both::extra, std::move(extra));
  Both value;
  value.base.path = "out";
  value.extra.high = 9;
  const std::string text = write_yaml(both, value);
  EXPECT_EQ(text.substr(text.find("limits:")), "limits:\n  low: 1\n  high: 10\n  top: 9\n");
  auto reader = YamlReader::from_string(text + "capacity_extra: 1\n", "s.yaml");
  ASSERT_TRUE(reader.has_value());
  Both read;
  both.read(reader->root(), read);
  const Status status = reader->finish();
  ASSERT_FALSE(status.has_value());  // capacity_extra only: both tables' keys are known
  EXPECT_EQ(status.error().message.find("limits."), std::string::npos) << status.error().message;
  EXPECT_EQ(read.extra.high, 9);
  EXPECT_EQ(read.base.limits.high, 10);
}

TEST(Section, EntriesListEveryKeyWithItsPath) {
  const auto listed = entries(settings_section(), Settings{}, true);
  std::vector<std::string> paths;
  for (const YamlEntry& e : listed) paths.push_back(e.path + (e.absent ? " (absent)" : ""));
  EXPECT_EQ(paths,
            (std::vector<std::string>{"output", "output.enabled", "output.path", "output.sink", "capacity",
                                      "offset_s", "names", "limits", "limits.low", "limits.high",
                                      "origin (absent)", "origin.x_m (absent)", "origin.y_m (absent)"}));
}

class DocumentedFileTest : public ::testing::Test {
 protected:
  std::string write(const std::string& text) {
    std::ofstream(path_) << text;
    return path_;
  }
  Status check(const std::string& text, std::vector<std::string> shipped = {},
               std::vector<std::string> elsewhere = {}) {
    return check_documented(settings_section(),
                            DocumentedFile{write(text), std::move(shipped), std::move(elsewhere)});
  }
  testing::TempDir dir_;
  std::string path_ = dir_ / "documented.yaml";
};

constexpr const char* kDocumented =
    "output:\n  enabled: true\n  path: \"\"\n  sink: file\n"
    "capacity: 4   # ring size\noffset_s: 0.0\nnames: [a, b]\n"
    "limits: {low: 1, high: 10}\n"
    "# origin:       # optional\n#   x_m: 0.0\n#   y_m: 0.0\n";

TEST_F(DocumentedFileTest, FileWithEveryDefaultAgrees) {
  // path: "" breaks the rule "enabled needs a path": shipped files must load.
  const Status bad = check(kDocumented);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("output.path = \"\": must not be empty"), std::string::npos)
      << bad.error().message;

  std::string text = kDocumented;
  text.replace(text.find("path: \"\""), 8, "path: out");
  const Status status = check(text, {"output.path"});
  EXPECT_TRUE(status.has_value()) << status.error().message;
}

TEST_F(DocumentedFileTest, MissingKeysWrongDefaultsAndUnknownKeysAreNamed) {
  const std::string base = "output: {enabled: true, path: p, sink: file}\n";
  const Status status =
      check(base + "capacity: 8\nnames: [a, b]\nlimits: {low: 1}\n# origin:\n#   x_m: 1\n", {"output.path"});
  ASSERT_FALSE(status.has_value());
  const std::string p = path_ + ": ";
  EXPECT_EQ(status.error().message,
            p + "capacity = 8: the default is 4\n" +            //
                p + "offset_s: not documented (default 0)\n" +  //
                p + "limits.high: not documented (default 10)\n" + p +
                "origin.y_m: not documented (expected a comment line \"# y_m: ...\")");

  const Status unknown = check(base + "capacity: 4\nextra: 1\n", {"output.path"});
  ASSERT_FALSE(unknown.has_value());
  EXPECT_NE(unknown.error().message.find(":3: extra: unknown key"), std::string::npos)
      << unknown.error().message;
}

TEST_F(DocumentedFileTest, ShippedValuesMustDifferAndSectionsMayBeDocumentedElsewhere) {
  const Status same = check(
      "output: {enabled: true, path: p, sink: file}\ncapacity: 4\noffset_s: 0\n"
      "names: [a, b]\n# origin:\n#  x_m: 1\n#  y_m: 1\n",
      {"output.path", "capacity", "no.such.key"}, {"limits"});
  ASSERT_FALSE(same.has_value());
  EXPECT_EQ(same.error().message,
            path_ + ": capacity = 4: listed as a deployment value, but equals the default\n" + path_ +
                ": no.such.key: listed as a deployment value, but no such key");
}

}  // namespace
}  // namespace sitepose::config
