// `sitepose demo`: the embedded default run — simulate a construction site
// in-process, track it, and print the accuracy against the simulator's
// ground truth. The default scenario is the paper's hardest case (a roller
// working alongside), where plain stereo SLAM is pulled along.

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "command_registry.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/core/build_info.hpp"
#include "sitepose/experiments/eval_plot.hpp"
#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/labelled_source.hpp"

namespace sitepose::cli {
namespace {

struct DemoArgs {
  std::string scenario = "parallel";
  int frames = 150;
  std::string mode = "full";
  std::string out_dir;
};

int run_demo(const DemoArgs& args) {
  std::printf("sitepose %s (%s, %s)\n", version_string(), git_revision(), build_type());
  config::SiteposeConfig config;
  auto mode = config::parse_masking_mode(args.mode);
  if (!mode) return fail("demo", "--mode: " + mode.error().message, 2);
  config.dynamic.mode = *mode;
  std::printf("demo: simulating scenario '%s' (%d frames, 960x540 stereo) and tracking it in mode "
              "'%s' (objects from the simulator's labels, as the paper's protocol)\n",
              args.scenario.c_str(), args.frames, args.mode.c_str());
  experiments::DynamicRunOptions options;
  const bool tty = isatty(STDERR_FILENO) != 0;
  options.on_frame = [tty](int i, int n, const slam::FrameReport& report) {
    if (tty) {
      std::fprintf(stderr, "\rframe %d/%d  %-10s  %4d features used", i + 1, n,
                   to_string(report.pose.state), report.pose.counters.features_used);
      if (i + 1 == n) std::fprintf(stderr, "\n");
    } else if ((i + 1) % 40 == 0 || i + 1 == n) {
      std::fprintf(stderr, "frame %d/%d\n", i + 1, n);
    }
  };
  auto source = experiments::open_simulated(args.scenario, args.frames);
  if (!source) return fail("demo", source.error().message, source.error().exit_status());
  auto run = experiments::run_dynamic(**source, config, options);
  if (!run) return fail("demo", run.error().message, run.error().exit_status());
  std::printf("tracked %d frames: %d OK (%.1f %%), %zu keyframes, %zu map points\n", run->frames,
              run->recorder.frames_ok(), 100.0 * run->coverage_ok(), run->keyframes, run->points);
  std::printf("tracking speed %.1f frames/s on this machine (rendering excluded)\n",
              run->recorder.frames_per_second());
  if (!run->evaluation) {
    std::printf("accuracy: not evaluated (%s)\n", run->evaluation_error.c_str());
    return 1;
  }
  const auto& e = *run->evaluation;
  std::printf("accuracy vs ground truth (SE(3)-aligned, no scale):\n");
  std::printf("  ATE rmse %.4f m, median %.4f m, max %.4f m\n", e.ate_m.rmse, e.ate_m.median, e.ate_m.max);
  std::printf("  RPE over 1 s: %.4f m, %.3f deg (rmse)\n", e.rpe_time.translation_m.rmse,
              e.rpe_time.rotation_deg.rmse);
  if (!args.out_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(args.out_dir, ec);
    if (ec) return fail("demo", "cannot create " + args.out_dir + ": " + ec.message(), 1);
    const std::string traj = args.out_dir + "/trajectory.txt";
    const std::string plot = args.out_dir + "/accuracy.png";
    if (auto st = run->recorder.write_tum(traj); !st) return fail("demo", st.error().message, 1);
    if (auto st = experiments::write_eval_plot(plot, run->ground_truth, e); !st) return fail("demo", st.error().message, 1);
    std::printf("wrote %s and %s\n", traj.c_str(), plot.c_str());
  }
  return 0;
}

const CommandRegistrar kDemo{{"", "demo",
                              "Simulate a construction site, track it and print the accuracy (embedded default)",
                              [](CLI::App& sub) -> CommandAction {
  auto args = std::make_shared<DemoArgs>();
  sub.add_option("--scenario", args->scenario, "Scenario to simulate (see `sitepose sim --list`)")
      ->capture_default_str();
  sub.add_option("--frames", args->frames, "Frames to simulate and track")->capture_default_str()
      ->check(CLI::Range(3, 100000));
  sub.add_option("--mode", args->mode,
                 std::string("Masking mode: ") + config::masking_mode_names() +
                     " (none = plain stereo SLAM; full = the paper's system)")
      ->capture_default_str();
  sub.add_option("--out-dir", args->out_dir, "Also write the trajectory (TUM) and an accuracy plot here");
  return [args] { return run_demo(*args); };
}}};

}  // namespace
}  // namespace sitepose::cli
