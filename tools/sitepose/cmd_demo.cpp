// `sitepose demo`: the embedded default run — simulate a construction site
// in-process, track it, and print the accuracy against the simulator's
// ground truth. The default scenario is the paper's hardest case (a roller
// working alongside), where plain stereo SLAM is pulled along.

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>

#include "command_registry.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/core/build_info.hpp"
#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/eval_plot.hpp"
#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/views/debug_record.hpp"
#include "sitepose/views/report_html.hpp"
#include "sitepose/views/view_writer.hpp"

namespace sitepose::cli {
namespace {

struct DemoArgs {
  std::string scenario = "parallel";
  int frames = 150;
  std::string mode = "full";
  std::string out_dir = "sitepose-demo";
  int clip_frames = 40;
};

// What the demo keeps of the simulated frames for its report and clip: the
// ground truth of every frame, the images of the clip's frames.
struct DemoCapture {
  views::GroundTruth gt;
  std::map<std::int64_t, views::ViewImages> clip;
  std::int64_t clip_first = 0;
  std::int64_t clip_end = 0;

  void add(const experiments::LabelledFrame& f) {
    const std::int64_t seq = f.frame.seq;
    if (static_cast<std::size_t>(seq) >= gt.poses.size()) {
      gt.poses.resize(seq + 1);
      gt.times_s.resize(seq + 1);
    }
    gt.poses[seq] = f.T_world_cam_gt;
    gt.times_s[seq] = static_cast<double>(f.frame.t_left_ns) * 1e-9;
    for (const auto& b : f.objects.boxes) {
      const auto it = f.moving.find(b.instance);
      gt.moving[seq][b.instance] = it == f.moving.end() ? std::nullopt : std::optional<bool>(it->second);
    }
    if (seq >= clip_first && seq < clip_end) clip[seq] = {f.frame.left.clone(), f.instance_mask.clone()};
  }
};

// The report and the annotated clip of the demo's run, from its record.
int write_views(const std::string& record_dir, const DemoCapture& capture, const std::string& out_dir) {
  auto record = views::read_debug_record(record_dir);
  if (!record) return fail("demo", record.error().message, 1);
  const std::string generator = std::string("sitepose ") + version_string() + " (" + git_revision() + ")";
  auto report = views::write_report(*record, &capture.gt, generator, out_dir);
  if (!report) return fail("demo", report.error().message, 1);
  views::ViewRequest request;
  request.out = out_dir + "/clip.avi";
  request.range = {static_cast<std::size_t>(capture.clip_first), static_cast<std::size_t>(capture.clip_end)};
  const views::ImageSource images = [&capture](std::int64_t seq, bool) -> Expected<views::ViewImages> {
    const auto it = capture.clip.find(seq);
    if (it == capture.clip.end()) {
      return make_error(ErrorCode::kNotFound, "demo: frame " + std::to_string(seq) + " not kept");
    }
    return it->second;
  };
  auto clip = views::write_view(*record, images, capture.gt.poses, request);
  if (!clip) return fail("demo", clip.error().message, 1);
  std::printf("report: %s\nannotated clip: %s (%zu frames, %dx%d)\n", report->c_str(), request.out.c_str(),
              clip->frames, clip->width, clip->height);
  return 0;
}

experiments::DynamicRunOptions demo_options(DemoCapture& capture, views::DebugRecordWriter& debug,
                                            Status& record_status) {
  experiments::DynamicRunOptions options;
  options.trace = true;
  options.alter = [&capture](experiments::LabelledFrame& f) { capture.add(f); };
  const bool tty = isatty(STDERR_FILENO) != 0;
  options.on_frame = [tty, &debug, &record_status](int i, int n, const slam::FrameReport& report) {
    if (record_status) record_status = debug.write(report);
    if (tty) {
      std::fprintf(stderr, "\rframe %d/%d  %-10s  %4d features used", i + 1, n, to_string(report.pose.state),
                   report.pose.counters.features_used);
      if (i + 1 == n) std::fprintf(stderr, "\n");
    } else if ((i + 1) % 40 == 0 || i + 1 == n) {
      std::fprintf(stderr, "frame %d/%d\n", i + 1, n);
    }
  };
  return options;
}

int run_demo(const DemoArgs& args) {
  std::printf("sitepose %s (%s, %s)\n", version_string(), git_revision(), build_type());
  config::SiteposeConfig config;
  auto mode = config::parse_masking_mode(args.mode);
  if (!mode) return fail("demo", "--mode: " + mode.error().message, 2);
  config.dynamic.mode = *mode;
  std::printf(
      "demo: simulating scenario '%s' (%d frames, 960x540 stereo) and tracking it in mode "
      "'%s' (objects from the simulator's labels, as the paper's protocol)\n",
      args.scenario.c_str(), args.frames, args.mode.c_str());
  auto source = experiments::open_simulated(args.scenario, args.frames);
  if (!source) return fail("demo", source.error().message, source.error().exit_status());
  std::error_code ec;
  std::filesystem::create_directories(args.out_dir, ec);
  if (ec) return fail("demo", "cannot create " + args.out_dir + ": " + ec.message(), 1);
  const std::string record_dir = args.out_dir + "/run";
  const StereoCamera& camera = (*source)->camera();
  views::RunInfo info{version_string(), git_revision(),  "", args.scenario, args.mode, "labels", camera.width,
                      camera.height,    (*source)->fps()};
  auto debug = views::DebugRecordWriter::open(record_dir, info, config::to_yaml(config));
  if (!debug) return fail("demo", debug.error().message, 1);
  // The clip: the middle clip_frames frames of the run.
  DemoCapture capture;
  capture.clip_first = std::max(0, (args.frames - args.clip_frames) / 2);
  capture.clip_end = std::min(args.frames, static_cast<int>(capture.clip_first) + args.clip_frames);
  Status record_status = ok_status();
  const experiments::DynamicRunOptions options = demo_options(capture, **debug, record_status);
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
  const std::string traj = args.out_dir + "/trajectory.txt";
  const std::string plot = args.out_dir + "/accuracy.png";
  if (auto st = run->recorder.write_tum(traj); !st) return fail("demo", st.error().message, 1);
  if (auto st = experiments::write_eval_plot(plot, run->ground_truth, e); !st)
    return fail("demo", st.error().message, 1);
  std::printf("wrote %s and %s\n", traj.c_str(), plot.c_str());
  if (!record_status) return fail("demo", record_status.error().message, 1);
  if (auto st = (*debug)->close(); !st) return fail("demo", st.error().message, 1);
  return write_views(record_dir, capture, args.out_dir);
}

void add_options(CLI::App& sub, DemoArgs& args) {
  sub.add_option("--scenario", args.scenario, "Scenario to simulate (see `sitepose sim --list`)")
      ->capture_default_str();
  add_bounded(sub, "--frames", args.frames, "Frames to simulate and track", 3, 100000);
  sub.add_option("--mode", args.mode,
                 std::string("Masking mode: ") + config::masking_mode_names() +
                     " (none = plain stereo SLAM; full = the paper's system)")
      ->capture_default_str();
  sub.add_option(
         "--out-dir", args.out_dir,
         "Where the trajectory (TUM), accuracy plot, debug record (run/), report.html and the annotated "
         "clip.avi go")
      ->capture_default_str();
  add_bounded(sub, "--clip-frames", args.clip_frames, "Frames in the annotated clip (the middle of the run)",
              1, 100000);
}

const CommandRegistrar kDemo{make_command<DemoArgs>(
    "", "demo", add_options, run_demo,
    "Simulate a construction site, track it and print the accuracy (embedded default)")};

}  // namespace
}  // namespace sitepose::cli
