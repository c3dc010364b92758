#include "sitepose/config/yaml_reader.hpp"

#include <gtest/gtest.h>

#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "sitepose/testing/files.hpp"

namespace sitepose::config {
namespace {

YamlReader parse(const std::string& text) {
  auto reader = YamlReader::from_string(text, "test.yaml");
  EXPECT_TRUE(reader.has_value()) << (reader ? "" : reader.error().message);
  return std::move(reader).value();
}

std::string finish_message(const YamlReader& reader) {
  const Status status = reader.finish();
  if (status) return "";
  EXPECT_EQ(status.error().code, ErrorCode::kInvalidArgument);
  return status.error().message;
}

// `count` lines "<indent><name>: 1", name numbered unless `same_name`.
std::string generated_keys(int count, const std::string& indent, bool same_name) {
  std::string text;
  for (int i = 0; i < count; ++i) {
    text += indent + "k" + (same_name ? std::string() : std::to_string(i)) + ": 1\n";
  }
  return text;
}

// Processor time, not wall time: a loaded machine must not fail the test.
double cpu_seconds_since(std::clock_t start) {
  return static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
}

// Checking 40 000 keys takes ~0.25 s of CPU in a release build; the
// quadratic duplicate pass this guards against needed 24 s for 20 000
// distinct keys and never finished 40 000. The bound leaves room for
// sanitizer builds.
constexpr double kFortyThousandKeysBudget_s = 2.0;

TEST(YamlReader, ReadsTypedValuesAndKeepsDefaultsForAbsentKeys) {
  const YamlReader reader = parse(
      "a:\n"
      "  count: 12\n"
      "  ratio: 0.25\n"
      "  flag: true\n"
      "  name: truck\n"
      "  big: 9000000000\n"
      "  list: [car, person]\n"
      "  path: [[0, 1.5], [2, 3]]\n");
  YamlMap a = reader.root().map("a");
  int count = 0, absent = 77;
  double ratio = 0.0;
  bool flag = false;
  std::string name;
  std::int64_t big = 0;
  std::vector<std::string> list;
  std::vector<std::vector<double>> path;
  EXPECT_TRUE(a.read("count", count, at_least(10)));
  EXPECT_TRUE(a.read("ratio", ratio, in_range(0.0, 1.0)));
  EXPECT_TRUE(a.read("flag", flag));
  EXPECT_TRUE(a.read("name", name, one_of({"truck", "car"})));
  EXPECT_TRUE(a.read("big", big, positive()));
  EXPECT_TRUE(a.read("list", list, non_empty()));
  EXPECT_TRUE(a.read("path", path));
  EXPECT_FALSE(a.read("absent", absent));
  EXPECT_EQ(count, 12);
  EXPECT_DOUBLE_EQ(ratio, 0.25);
  EXPECT_TRUE(flag);
  EXPECT_EQ(name, "truck");
  EXPECT_EQ(big, 9000000000LL);
  EXPECT_EQ(list, (std::vector<std::string>{"car", "person"}));
  ASSERT_EQ(path.size(), 2u);
  EXPECT_DOUBLE_EQ(path[0][1], 1.5);
  EXPECT_EQ(absent, 77);
  EXPECT_EQ(finish_message(reader), "");
}

TEST(YamlReader, RuleViolationNamesPathValueRuleAndLine) {
  const YamlReader reader = parse("tracking:\n  min_inliers_ok: -3\n");
  int value = 30;
  EXPECT_FALSE(reader.root().map("tracking").read("min_inliers_ok", value, at_least(10)));
  EXPECT_EQ(value, 30);  // untouched on error
  EXPECT_EQ(finish_message(reader), "test.yaml:2: tracking.min_inliers_ok = -3: must be >= 10");
}

TEST(YamlReader, WrongTypeIsReportedWithQuotedText) {
  const YamlReader reader = parse("orb:\n  n_features: many\n  scale: 1.2.3\n  on: yes\n");
  YamlMap orb = reader.root().map("orb");
  int n = 0;
  double scale = 0.0;
  bool on = false;
  EXPECT_FALSE(orb.read("n_features", n));
  EXPECT_FALSE(orb.read("scale", scale));
  EXPECT_FALSE(orb.read("on", on));
  const std::string message = finish_message(reader);
  EXPECT_NE(message.find("test.yaml:2: orb.n_features = \"many\": expected an integer"), std::string::npos)
      << message;
  EXPECT_NE(message.find("test.yaml:3: orb.scale = \"1.2.3\": expected a finite number"), std::string::npos)
      << message;
  EXPECT_NE(message.find("test.yaml:4: orb.on = \"yes\": expected a boolean"), std::string::npos) << message;
}

TEST(YamlReader, IntegersRejectFractionsOverflowAndNonFiniteNumbers) {
  const YamlReader reader = parse("a: 1.5\nb: 99999999999\nc: .inf\nd: nan\n");
  int a = 0, b = 0;
  double c = 0.0, d = 0.0;
  EXPECT_FALSE(reader.root().read("a", a));
  EXPECT_FALSE(reader.root().read("b", b));
  EXPECT_FALSE(reader.root().read("c", c));
  EXPECT_FALSE(reader.root().read("d", d));
  const std::string message = finish_message(reader);
  EXPECT_NE(message.find("a = 1.5: expected an integer"), std::string::npos) << message;
  EXPECT_NE(message.find("b = 99999999999: out of range"), std::string::npos) << message;
  EXPECT_NE(message.find("c = \".inf\": expected a finite number"), std::string::npos) << message;
  EXPECT_NE(message.find("d = \"nan\""), std::string::npos) << message;
}

TEST(YamlReader, UnknownKeyListsKnownKeysAndSuggestsNearMiss) {
  const YamlReader reader = parse("dynamic:\n  mode: full\n  modee: bbox\n");
  YamlMap dynamic = reader.root().map("dynamic");
  std::string mode;
  double tau = 0.5;
  dynamic.read("mode", mode);
  dynamic.read("tau_mar", tau);
  EXPECT_EQ(finish_message(reader),
            "test.yaml:3: dynamic.modee: unknown key (expected one of: mode, tau_mar); did you "
            "mean mode?");
}

TEST(YamlReader, UnreadSectionIsAnUnknownKeyOfItsParent) {
  const YamlReader reader = parse("orb: {}\nextra:\n  x: 1\n");
  reader.root().map("orb");
  EXPECT_EQ(finish_message(reader), "test.yaml:2: extra: unknown key (expected one of: orb)");
}

TEST(YamlReader, RequiredKeyMissingIsReported) {
  const YamlReader reader = parse("machine:\n  name: r1\n");
  double speed = 0.0;
  std::string name;
  YamlMap machine = reader.root().map("machine");
  machine.read("name", name);
  EXPECT_FALSE(machine.read_required("speed_mps", speed, positive()));
  const std::string message = finish_message(reader);
  EXPECT_NE(message.find("machine.speed_mps: missing (required key)"), std::string::npos) << message;
}

TEST(YamlReader, SequenceOfMappingsHasIndexedPaths) {
  const YamlReader reader = parse(
      "machines:\n"
      "  - path: {speed_mps: 1.0}\n"
      "  - path: {speed_mps: 2.0}\n"
      "  - path: {speed_mps: -1.0, sped: 3}\n"
      "  - 5\n");
  const std::vector<YamlMap> machines = reader.root().maps("machines");
  ASSERT_EQ(machines.size(), 3u);
  std::vector<double> speeds;
  for (const YamlMap& machine : machines) {
    double speed = 0.0;
    machine.map("path").read("speed_mps", speed, positive());
    speeds.push_back(speed);
  }
  EXPECT_DOUBLE_EQ(speeds[1], 2.0);
  const std::string message = finish_message(reader);
  EXPECT_NE(message.find("test.yaml:4: machines[2].path.speed_mps = -1.0: must be > 0"), std::string::npos)
      << message;
  EXPECT_NE(message.find("machines[2].path.sped: unknown key"), std::string::npos) << message;
  EXPECT_NE(message.find("test.yaml:5: machines[3] = 5: expected a mapping"), std::string::npos) << message;
}

TEST(YamlReader, ListElementErrorsNameTheIndex) {
  const YamlReader reader = parse("classes: [car, [x], person]\nweights: [1, two]\nempty: []\n");
  std::vector<std::string> classes;
  std::vector<double> weights;
  std::vector<std::string> empty;
  EXPECT_FALSE(reader.root().read("classes", classes));
  EXPECT_FALSE(reader.root().read("weights", weights));
  EXPECT_FALSE(reader.root().read("empty", empty, non_empty()));
  const std::string message = finish_message(reader);
  EXPECT_NE(message.find("classes[1] = [x]: expected a string"), std::string::npos) << message;
  EXPECT_NE(message.find("weights[1] = \"two\": expected a finite number"), std::string::npos) << message;
  EXPECT_NE(message.find("empty = []: must not be empty"), std::string::npos) << message;
}

TEST(YamlReader, EachRuleAppliesToEveryElement) {
  const YamlReader reader = parse("sizes: [1, 2, 0]\n");
  std::vector<int> sizes;
  EXPECT_FALSE(reader.root().read("sizes", sizes, each(positive())));
  EXPECT_NE(finish_message(reader).find("sizes = [1, 2, 0]: every element must be > 0"), std::string::npos);
}

TEST(YamlReader, EmptyValueIsAnErrorForScalarsAndEmptyForSections) {
  const YamlReader reader = parse("count:\nsection:\n");
  int count = 4;
  EXPECT_FALSE(reader.root().read("count", count));
  int inner = 9;
  EXPECT_FALSE(reader.root().map("section").read("inner", inner));
  EXPECT_EQ(inner, 9);
  EXPECT_EQ(finish_message(reader), "test.yaml:1: count = (empty): expected an integer");
}

TEST(YamlReader, ScalarWhereSectionExpected) {
  const YamlReader reader = parse("orb: 5\n");
  reader.root().map("orb");
  EXPECT_EQ(finish_message(reader), "test.yaml:1: orb = 5: expected a mapping");
}

TEST(YamlReader, DuplicateKeysAreReported) {
  const YamlReader reader = parse("a: 1\nb: 2\na: 3\n");
  int a = 0, b = 0;
  reader.root().read("a", a);
  reader.root().read("b", b);
  EXPECT_EQ(finish_message(reader), "test.yaml:3: a: duplicate key (first at line 1)");
}

TEST(YamlReader, ReadParsedReportsTheParserMessage) {
  const YamlReader reader = parse("level: loud\n");
  int level = 0;
  EXPECT_FALSE(reader.root().read_parsed("level", level, [](const std::string& s) -> Expected<int> {
    if (s == "quiet") return 1;
    return make_error(ErrorCode::kInvalidArgument, "expected quiet");
  }));
  EXPECT_EQ(finish_message(reader), "test.yaml:1: level = \"loud\": expected quiet");
}

TEST(YamlReader, CrossFieldReportNamesKeyAndValue) {
  const YamlReader reader = parse("lo: 5\nhi: 3\n");
  int lo = 0, hi = 0;
  reader.root().read("lo", lo);
  reader.root().read("hi", hi);
  if (hi < lo) reader.root().report("hi", "must be >= lo (5)");
  EXPECT_EQ(finish_message(reader), "test.yaml:2: hi = 3: must be >= lo (5)");
}

TEST(YamlReader, MalformedYamlGivesParseErrorWithLine) {
  const auto reader = YamlReader::from_string("a: 1\nb: [1, 2\nc: 3\n", "bad.yaml");
  ASSERT_FALSE(reader.has_value());
  EXPECT_EQ(reader.error().code, ErrorCode::kParseError);
  EXPECT_NE(reader.error().message.find("bad.yaml:"), std::string::npos) << reader.error().message;
  EXPECT_NE(reader.error().message.find("malformed YAML"), std::string::npos);
}

TEST(YamlReader, TopLevelMustBeAMapping) {
  const auto reader = YamlReader::from_string("- a\n- b\n", "list.yaml");
  ASSERT_FALSE(reader.has_value());
  EXPECT_EQ(reader.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(reader.error().message.find("list.yaml:1: expected a mapping"), std::string::npos)
      << reader.error().message;
}

TEST(YamlReader, EmptyDocumentIsAnEmptyMapping) {
  for (const char* text : {"", "# only a comment\n", "---\n"}) {
    const YamlReader reader = parse(text);
    int value = 3;
    EXPECT_FALSE(reader.root().read("value", value));
    EXPECT_EQ(value, 3);
    EXPECT_EQ(finish_message(reader), "");
  }
}

TEST(YamlReader, MissingFileIsNotFound) {
  const auto reader = YamlReader::from_file("/nonexistent/sitepose/x.yaml");
  ASSERT_FALSE(reader.has_value());
  EXPECT_EQ(reader.error().code, ErrorCode::kNotFound);
  EXPECT_NE(reader.error().message.find("/nonexistent/sitepose/x.yaml"), std::string::npos);
}

TEST(YamlReader, FortyThousandKeysAreCheckedInLinearTime) {
  for (const bool same_name : {false, true}) {
    const std::string text = "s:\n" + generated_keys(40000, "  ", same_name);
    ASSERT_LT(text.size(), kMaxYamlBytes);
    const std::clock_t start = std::clock();
    const YamlReader reader = parse(text);
    int value = 0;
    reader.root().map("s").read(same_name ? "k" : "k0", value);
    const std::string message = finish_message(reader);
    EXPECT_LT(cpu_seconds_since(start), kFortyThousandKeysBudget_s)
        << (same_name ? "duplicates" : "unknown keys");
    // Unknown keys (k1 ... k39999) or duplicates of k: every one is a problem.
    EXPECT_NE(message.find(same_name ? "test.yaml:3: s.k: duplicate key (first at line 2)"
                                     : "test.yaml:3: s.k1: unknown key (expected one of: k0)"),
              std::string::npos)
        << message.substr(0, 500);
    EXPECT_NE(message.find("test.yaml: 39899 more problems not shown"), std::string::npos)
        << message.substr(message.size() > 500 ? message.size() - 500 : 0);
  }
}

TEST(YamlReader, FortyThousandListElementsOpenInLinearTime) {
  std::string text = "items:\n";
  for (int i = 0; i < 40000; ++i) text += "  - {a: " + std::to_string(i) + "}\n";
  const std::clock_t start = std::clock();
  const YamlReader reader = parse(text);
  long long sum = 0;
  for (const YamlMap& item : reader.root().maps("items")) {
    int a = 0;
    item.read("a", a);
    sum += a;
  }
  EXPECT_EQ(finish_message(reader), "");
  EXPECT_LT(cpu_seconds_since(start), kFortyThousandKeysBudget_s);
  EXPECT_EQ(sum, 40000LL * 39999 / 2);
}

TEST(YamlReader, ProblemsBeyondTheCapAreCounted) {
  const YamlReader reader = parse(generated_keys(kMaxReportedProblems + 2, "", false));
  const std::string message = finish_message(reader);
  EXPECT_NE(message.find("test.yaml:100: k99: unknown key"), std::string::npos) << message;
  EXPECT_EQ(message.find("k100: unknown key"), std::string::npos) << message;
  EXPECT_NE(message.find("\ntest.yaml: 2 more problems not shown"), std::string::npos) << message;
}

TEST(YamlReader, TextLargerThanOneMebibyteIsRefused) {
  const std::string at_limit = "a: \"" + std::string(kMaxYamlBytes - 6, 'x') + "\"\n";
  ASSERT_EQ(at_limit.size(), kMaxYamlBytes);
  EXPECT_TRUE(YamlReader::from_string(at_limit, "limit.yaml").has_value());

  const auto larger = YamlReader::from_string(at_limit + "\n", "big.yaml");
  ASSERT_FALSE(larger.has_value());
  EXPECT_EQ(larger.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(larger.error().message,
            "big.yaml: 1048577 bytes, larger than a configuration file may be (1048576 bytes = 1 MiB)");

  const testing::TempDir dir;
  const std::string path = dir.write("big.yaml", at_limit + std::string(5 * kMaxYamlBytes, '#'));
  const auto from_file = YamlReader::from_file(path);
  ASSERT_FALSE(from_file.has_value());
  EXPECT_EQ(from_file.error().message,
            path +
                ": more than 1048576 bytes, larger than a configuration file may be (1048576 "
                "bytes = 1 MiB)");
}

TEST(YamlReader, DirectoryIsRefusedNamingThePath) {
  const std::string dir = std::filesystem::temp_directory_path().string();
  const auto reader = YamlReader::from_file(dir);
  ASSERT_FALSE(reader.has_value());
  EXPECT_EQ(reader.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(reader.error().message,
            "cannot read config file " + dir + ": is a directory, expected a YAML file");
}

TEST(YamlReader, OpeningTheSameSectionTwiceSharesKnownKeys) {
  const YamlReader reader = parse("s:\n  a: 1\n  b: 2\n");
  int a = 0, b = 0;
  reader.root().map("s").read("a", a);
  reader.root().map("s").read("b", b);
  EXPECT_EQ(finish_message(reader), "");
}

}  // namespace
}  // namespace sitepose::config
