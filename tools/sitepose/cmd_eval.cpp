// `sitepose eval`: accuracy of an estimated trajectory against ground truth
// (FORMATS.md "Evaluation conventions"): timestamp association, optional
// time-offset search, SE(3) Umeyama alignment, ATE, RPE, coverage.

#include <cstdio>
#include <memory>
#include <string>

#include "command_registry.hpp"
#include "sitepose/eval/evaluate.hpp"
#include "sitepose/experiments/eval_plot.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::cli {
namespace {

struct EvalArgs {
  std::string gt_path;
  std::string times_path;
  std::string est_path;
  std::string est_times_path;
  bool json = false;
  std::string plot_path;
  double max_dt_s = eval::kDefaultMaxDtS;
  double offset_range_s = 0.0;
};

int run_eval(const EvalArgs& args) {
  const std::string cmd = "eval";
  // KITTI ground truth takes its times from --times; TUM and EuRoC carry them.
  auto gt_format = io::detect_trajectory_format(args.gt_path);
  if (!gt_format)
    return fail(cmd, "ground truth: " + gt_format.error().message, gt_format.error().exit_status());
  if (*gt_format == io::TrajectoryFormat::kKitti && args.times_path.empty()) {
    return fail(cmd, "--gt " + args.gt_path + " is KITTI (12 numbers a line, no times): --times is required",
                2);
  }
  auto gt = io::read_trajectory(args.gt_path, args.times_path);
  if (!gt) return fail(cmd, "ground truth: " + gt.error().message, gt.error().exit_status());
  auto est = io::read_trajectory(args.est_path, args.est_times_path);
  if (!est) return fail(cmd, "estimate: " + est.error().message, est.error().exit_status());
  if (gt->empty()) {
    return fail(cmd, "ground truth '" + args.gt_path + "' holds no poses", 2);
  }
  if (est->empty()) {
    return fail(cmd, "estimate '" + args.est_path + "' holds no poses", 2);
  }

  eval::EvalOptions options;
  options.max_dt_s = args.max_dt_s;
  options.time_offset_search_range_s = args.offset_range_s;
  auto result = eval::evaluate(*gt, *est, options);
  if (!result) {
    return fail(cmd, "'" + args.est_path + "' vs '" + args.gt_path + "': " + result.error().message,
                result.error().exit_status());
  }

  if (args.json) {
    std::fputs(eval::to_json(*result).c_str(), stdout);
  } else {
    std::fputs(eval::to_text(*result).c_str(), stdout);
  }
  if (!args.plot_path.empty()) {
    if (auto st = experiments::write_eval_plot(args.plot_path, *gt, *result); !st) {
      return fail(cmd, st.error().message, st.error().exit_status());
    }
    if (!args.json) std::printf("plot          %s\n", args.plot_path.c_str());
  }
  return 0;
}

// A trajectory file (required) and the timestamps file of its KITTI form.
struct TrajectoryOption {
  const char* flag;
  const char* type_name;
  const char* help;
  const char* times_flag;
  const char* times_help;
};

void add_trajectory_option(CLI::App& sub, const TrajectoryOption& option, std::string& path,
                           std::string& times_path) {
  add_required(sub, option.flag, path, option.type_name, option.help);
  sub.add_option(option.times_flag, times_path, option.times_help)->type_name("TIMES");
}

void add_options(CLI::App& sub, EvalArgs& args) {
  add_trajectory_option(sub,
                        {"--gt", "POSES",
                         "Ground-truth poses, T_world_cam: TUM (t x y z qx qy qz qw), KITTI (12 numbers a "
                         "line, with --times) or "
                         "EuRoC CSV (e.g. the sequence's poses_tum.txt, or poses.txt)",
                         "--times", "Timestamps of KITTI ground-truth poses (s), one a line (times.txt)"},
                        args.gt_path, args.times_path);
  add_trajectory_option(
      sub,
      {"--est", "TRAJ",
       "Estimated trajectory: TUM, KITTI (times from --est-times, default TRAJ.times.txt as "
       "`run --format kitti` writes it) or EuRoC CSV",
       "--est-times", "Timestamps of a KITTI estimate (s), one a line (default: TRAJ.times.txt)"},
      args.est_path, args.est_times_path);
  sub.add_flag("--json", args.json, "Print the figures as JSON on stdout instead of text");
  sub.add_option("--plot", args.plot_path,
                 "Write a PNG: top view of ground truth vs aligned estimate coloured by "
                 "ATE, and ATE over time")
      ->type_name("PNG");
  sub.add_option("--max-dt", args.max_dt_s, "Largest timestamp difference of an associated pair (s)")
      ->type_name("S")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub.add_option("--time-offset-search", args.offset_range_s,
                 "Search a constant clock offset in [-RANGE, +RANGE] s minimising ATE "
                 "(t_gt = t_est + offset); 0 = no search")
      ->type_name("RANGE_S")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
}

const CommandRegistrar kEval{make_command<EvalArgs>(
    "", "eval", add_options, run_eval,
    "Accuracy of an estimated trajectory against ground truth (TUM, KITTI + times or EuRoC, "
    "detected from the first line): "
    "ATE after SE(3) alignment, RPE over 1 s and 10 frames, coverage")};

}  // namespace
}  // namespace sitepose::cli
