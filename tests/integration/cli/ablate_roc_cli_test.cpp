// `sitepose ablate roc` through the built binary (issue 22): roc_states.csv
// holds a row per classifier and class (and `all`) whose counts add up, the
// unknown verdicts split by reason; the same figures are printed.

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "sitepose/testing/command.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose {
namespace {

using testing::run_command;
using testing::TempDir;

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::istringstream in(line);
  for (std::string f; std::getline(in, f, ',');) fields.push_back(f);
  return fields;
}

// The classes labelled in a sequence's boxes.csv (third column).
std::set<std::string> labelled_classes(const std::string& boxes_csv) {
  std::set<std::string> classes;
  const std::vector<std::string> rows = testing::read_lines(boxes_csv);
  for (std::size_t i = 1; i < rows.size(); ++i) classes.insert(split(rows[i]).at(2));
  return classes;
}

const char* const kHeader =
    "classifier,class,samples,testable,unknown_share,balanced_accuracy,auc,auc_with_untestable,"
    "static_called_static,static_called_moving,moving_called_moving,moving_called_static,unknown_no_"
    "reference,"
    "unknown_too_few_points,unknown_ambiguous,unknown_settling";

// Columns: samples and testable, then shares and AUCs (4-7), then counts
// (the confusion matrix, the unknown reasons).
constexpr int kSamples = 2, kTestable = 3, kUnknownShare = 4, kFirstConfusion = 8, kFirstReason = 12,
              kColumns = 16;
// The counts add up over the classes of a classifier; shares and AUCs do not.
bool is_count(int column) { return column == kSamples || column == kTestable || column >= kFirstConfusion; }

TEST(AblateRocCli, StatesCsvHasPerClassRowsAndReasonCounts) {
  TempDir dir("ablate_roc");
  const std::string exe = SITEPOSE_SITEPOSE_EXE;
  // 6 s with a roller passing a parked truck and a parked excavator, all in
  // view from the start (the shipped scenarios show one class at first).
  const std::string scenario = dir.write("roc_cli.yaml", R"(name: roc_cli
description: "a roller passes a parked truck and a parked excavator"
fps: 6
duration_s: 6
seed: 3
ego:
  segments:
    - {speed_mps: 0.4, duration_s: 6}
machines:
  - {class: truck, paint: white, x_m: -2.5, y_m: -9, yaw_deg: 0}
  - {class: excavator, paint: yellow, x_m: 3, y_m: -12, yaw_deg: 20}
  - {class: roller, paint: orange, waypoints: [[4, -6], [-12, -6]], speed_mps: 0.9}
)");
  ASSERT_EQ(run_command(exe + " sim --scenario " + scenario + " --width 320 --height 180 --out " +
                        (dir / "seq") + " > " + (dir / "sim.txt") + " 2>&1"),
            0)
      << testing::read_text(dir / "sim.txt");
  const int status = run_command(exe + " ablate roc --sequence " + (dir / "seq") + " --out-dir " +
                                 (dir / "out") + " > " + (dir / "roc.txt") + " 2>&1");
  const std::string out = testing::read_text(dir / "roc.txt");
  ASSERT_EQ(status, 0) << out;

  const std::vector<std::string> rows = testing::read_lines(dir / "out/roc_states.csv");
  ASSERT_GE(rows.size(), 2u) << out;
  EXPECT_EQ(rows[0], kHeader);
  const std::set<std::string> labelled = labelled_classes(dir / "seq/labels/boxes.csv");
  // classifier -> class -> fields
  std::map<std::string, std::map<std::string, std::vector<std::string>>> table;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const std::vector<std::string> f = split(rows[i]);
    ASSERT_EQ(f.size(), static_cast<std::size_t>(kColumns)) << rows[i];
    EXPECT_TRUE(f[0] == "paper" || f[0] == "sitepose") << rows[i];
    EXPECT_TRUE(f[1] == "all" || labelled.count(f[1]) == 1) << "class not in the labels: " << rows[i];
    EXPECT_TRUE(table[f[0]].emplace(f[1], f).second) << "row twice: " << rows[i];
  }
  ASSERT_EQ(table.size(), 2u) << out;
  EXPECT_EQ(table["paper"].size(), table["sitepose"].size());  // the same objects, other verdicts

  for (const auto& [classifier, classes] : table) {
    ASSERT_EQ(classes.count("all"), 1u) << classifier;
    EXPECT_GE(classes.size(), 3u) << classifier << ": `all` and at least two classes";
    std::vector<long> class_sums(kColumns, 0);
    int reasons_all = 0;
    for (const auto& [name, f] : classes) {
      // Every sample is a decided verdict (four confusion counts) or an
      // unknown one with its reason.
      long decided = 0, unknown = 0;
      for (int c = kFirstConfusion; c < kFirstReason; ++c) decided += std::stol(f[c]);
      for (int c = kFirstReason; c < kColumns; ++c) unknown += std::stol(f[c]);
      EXPECT_EQ(decided + unknown, std::stol(f[kSamples])) << classifier << ' ' << name;
      EXPECT_LE(std::stol(f[kTestable]), std::stol(f[kSamples])) << classifier << ' ' << name;
      const double unknown_share = std::stod(f[kUnknownShare]);
      EXPECT_TRUE(unknown_share >= 0.0 && unknown_share <= 1.0) << classifier << ' ' << name;
      if (name == "all") {
        reasons_all = static_cast<int>(unknown);
        continue;
      }
      for (int c = kSamples; c < kColumns; ++c) {
        if (is_count(c)) class_sums[c] += std::stol(f[c]);
      }
      // The printed line of this row.
      EXPECT_NE(out.find(classifier + std::string(9 - classifier.size(), ' ') + " " + name),
                std::string::npos)
          << classifier << ' ' << name << '\n'
          << out;
    }
    const std::vector<std::string>& all = classes.at("all");
    for (int c = kSamples; c < kColumns; ++c) {
      if (!is_count(c)) continue;
      EXPECT_EQ(class_sums[c], std::stol(all[c])) << classifier << ": column " << c;
    }
    EXPECT_GT(std::stol(all[kSamples]), 0) << classifier;
    // The first frame has no reference frame: some verdicts are unknown.
    EXPECT_GT(reasons_all, 0) << classifier;
  }
  // sitepose mode tells why it is unsure (no reference at the start at
  // least) and decides both ways here: the parked truck static, the roller moving.
  const std::vector<std::string>& sitepose = table["sitepose"]["all"];
  EXPECT_GT(std::stol(sitepose[kFirstReason]), 0);
  EXPECT_GT(std::stol(sitepose[kFirstConfusion]), 0);      // static called static
  EXPECT_GT(std::stol(sitepose[kFirstConfusion + 2]), 0);  // moving called moving
}

}  // namespace
}  // namespace sitepose
