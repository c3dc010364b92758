// `sitepose run`: track a recorded sequence and write the trajectory
// (FORMATS.md command contract).

#include <cstdio>
#include <filesystem>
#include <unistd.h>

#include "command_registry.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/config/orbslam2_settings.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/slam/run_recorder.hpp"
#include "sitepose/slam/slam_system.hpp"

namespace sitepose::cli {
namespace {

struct RunArgs {
  std::string sequence;
  std::string config_path;
  std::string orbslam2_settings;
  std::string mode;
  std::string detector;
  std::string out;
  std::string states_out;
  std::string stats_out;
  std::string gt;
  int max_frames = 0;
  bool mapper_thread = false;
  bool quiet = false;
};

constexpr const char* kCommand = "run";

int run(const RunArgs& args) {
  config::SiteposeConfig config;
  if (!args.config_path.empty()) {
    auto loaded = config::load_config(args.config_path);
    if (!loaded) return fail(kCommand, loaded.error().message, 2);
    config = *loaded;
  }
  if (!args.orbslam2_settings.empty()) {
    auto settings = config::load_orbslam2_settings(args.orbslam2_settings);
    if (!settings) return fail(kCommand, settings.error().message, 2);
    config::apply_orbslam2_settings(*settings, config);
  }
  if (!args.mode.empty()) {
    auto mode = config::parse_masking_mode(args.mode);
    if (!mode) return fail(kCommand, "--mode: " + mode.error().message, 2);
    config.dynamic.mode = *mode;
  }
  if (config.dynamic.mode != config::MaskingMode::kNone) {
    return fail(kCommand,
                std::string("--mode ") + config::to_string(config.dynamic.mode) +
                    ": the dynamic layer (masking, motion states, two passes) is not in this "
                    "build yet; only --mode none is available",
                2);
  }
  if (!args.detector.empty() || !args.states_out.empty()) {
    return fail(kCommand, "--detector and --states-out need a masking mode; with --mode none there is no detector", 2);
  }
  io::SequenceOptions options;
  options.gt_path = args.gt;
  auto sequence = io::open_sequence(args.sequence, options);
  if (!sequence) return fail(kCommand, sequence.error().message, 2);
  StereoCamera camera = (*sequence)->camera();
  if (config.camera.stereo) camera = *config.camera.stereo;

  auto system = slam::SlamSystem::create(camera, config, {args.mapper_thread});
  if (!system) return fail(kCommand, system.error().message, 2);

  const std::size_t n_frames = args.max_frames > 0
                                   ? std::min<std::size_t>(args.max_frames, (*sequence)->size())
                                   : (*sequence)->size();
  const bool tty = isatty(STDERR_FILENO) != 0;
  slam::RunRecorder recorder;
  for (std::size_t i = 0; i < n_frames; ++i) {
    auto frame = (*sequence)->read_frame(i);
    if (!frame) return fail(kCommand, frame.error().message, 2);
    auto report = (*system)->process(*frame);
    if (!report) return fail(kCommand, report.error().message, 1);
    recorder.add(*report);
    if (!args.quiet && (tty ? (i % 5 == 0 || i + 1 == n_frames) : ((i + 1) % 100 == 0 || i + 1 == n_frames))) {
      std::fprintf(stderr, "%sframe %zu/%zu  %s  %.1f frames/s%s", tty ? "\r" : "", i + 1, n_frames,
                   to_string(report->pose.state), recorder.frames_per_second(), tty ? "   " : "\n");
    }
  }
  (*system)->finish();
  if (!args.quiet && tty) std::fprintf(stderr, "\n");
  if (auto st = recorder.write_tum(args.out); !st) return fail(kCommand, st.error().message, 1);
  if (!args.stats_out.empty()) {
    const auto& counters = (*system)->tracker_counters();
    const auto mapping = (*system)->mapping_stats();
    const std::string extra =
        "  \"mode\": \"none\",\n  \"keyframes_created\": " + std::to_string(counters.keyframes_created) +
        ",\n  \"relocalisations\": " + std::to_string(counters.relocalisations) +
        ",\n  \"keyframes_in_map\": " + std::to_string((*system)->keyframe_count()) +
        ",\n  \"points_in_map\": " + std::to_string((*system)->point_count()) +
        ",\n  \"keyframes_culled\": " + std::to_string(mapping.keyframes_culled);
    if (auto st = recorder.write_stats_json(args.stats_out, extra); !st) return fail(kCommand, st.error().message, 1);
  }
  std::printf("frames %d, tracked OK %d (%.1f %%), %.1f frames/s, keyframes %zu, points %zu\n",
              recorder.frames(), recorder.frames_ok(),
              recorder.frames() ? 100.0 * recorder.frames_ok() / recorder.frames() : 0.0,
              recorder.frames_per_second(), (*system)->keyframe_count(), (*system)->point_count());
  return 0;
}

const CommandRegistrar kRun{{"", "run", "Track a recorded stereo sequence and write its trajectory",
                             [](CLI::App& sub) -> CommandAction {
  auto args = std::make_shared<RunArgs>();
  sub.add_option("--sequence", args->sequence, "Sequence directory (sitepose/KITTI or EuRoC layout)")
      ->required();
  sub.add_option("--config", args->config_path, "sitepose YAML config (default: built-in defaults)");
  sub.add_option("--orbslam2-settings", args->orbslam2_settings,
                 "ORB-SLAM2 stereo settings file: camera and ORB parameters override the config");
  sub.add_option("--mode", args->mode,
                 std::string("Masking mode: ") + config::masking_mode_names() +
                     " (this build: none only)");
  sub.add_option("--detector", args->detector, "Detector for the masking modes (not in this build)");
  sub.add_option("--out", args->out, "Trajectory output, TUM format (T_world_cam, left camera)")->required();
  sub.add_option("--states-out", args->states_out, "Motion states CSV (masking modes only)");
  sub.add_option("--stats-out", args->stats_out, "Per-run statistics JSON");
  sub.add_option("--gt", args->gt, "Ground-truth poses file kept apart (real KITTI: poses/NN.txt)");
  sub.add_option("--frames", args->max_frames, "Process at most N frames (0 = all)");
  sub.add_flag("--mapper-thread", args->mapper_thread,
               "Run local mapping on its own thread (as the daemon does); default runs it "
               "inline after each keyframe so results are reproducible");
  sub.add_flag("--quiet", args->quiet, "No progress output");
  return [args] { return run(*args); };
}}};

}  // namespace
}  // namespace sitepose::cli
