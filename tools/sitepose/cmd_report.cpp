// `sitepose report`: one self-contained HTML page of a run recorded with
// `sitepose run --debug-out` (views/report_html.hpp).

#include <cstdio>

#include "command_registry.hpp"
#include "sitepose/core/build_info.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/views/report_html.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "report";

struct ReportArgs {
  std::string run;
  std::string gt;
  std::string out;
};

int run(const ReportArgs& args) {
  auto record = views::read_debug_record(args.run);
  if (!record) return fail(kCommand, "--run: " + record.error().message, 2);
  std::optional<views::GroundTruth> gt;
  if (!args.gt.empty()) {
    auto opened = io::open_sequence(args.gt);
    if (!opened) return fail(kCommand, "--gt: " + opened.error().message, 2);
    if (!(*opened)->has_gt()) return fail(kCommand, "--gt: " + args.gt + " has no ground-truth poses", 2);
    auto truth = views::ground_truth_of(**opened);
    if (!truth) return fail(kCommand, "--gt: " + truth.error().message, 2);
    gt = std::move(*truth);
  }
  const std::string generator =
      std::string("sitepose ") + version_string() + " (" + git_revision() + ", " + build_type() + ")";
  auto written = views::write_report(*record, gt ? &*gt : nullptr, generator, args.out);
  if (!written) return fail(kCommand, written.error().message, 1);
  std::printf("wrote %s\n", written->c_str());
  return 0;
}

void add_options(CLI::App& sub, ReportArgs& args) {
  sub.add_option("--run", args.run, "The run's --debug-out folder")->required();
  sub.add_option(
      "--gt", args.gt,
      "Sequence with ground truth (poses, labels, meta.json): accuracy, truth beside the motion states");
  sub.add_option("--out", args.out, "Output folder (report.html)")->required();
}

const CommandRegistrar kReport{make_command<ReportArgs>(
    "", "report", add_options, run, "One self-contained HTML page of a run recorded with run --debug-out")};

}  // namespace
}  // namespace sitepose::cli
