// `sitepose run`: track a recorded sequence and write the trajectory
// (FORMATS.md command contract).

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <unistd.h>

#include "command_registry.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/config/orbslam2_settings.hpp"
#include "sitepose/core/echo.hpp"
#include "sitepose/detect/create_detector.hpp"
#include "sitepose/dynamic/masking.hpp"
#include "sitepose/io/output_path.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/slam/detector_objects.hpp"
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
  const bool masking = config.dynamic.mode != config::MaskingMode::kNone;
  if (!masking && !args.detector.empty()) {
    return fail(kCommand, "--detector needs a masking mode (--mode bbox|pixel|hierarchical|full); --mode none uses no detector", 2);
  }
  if (!args.states_out.empty() && config.dynamic.mode != config::MaskingMode::kFull) {
    return fail(kCommand, std::string("--states-out needs --mode full (motion states are classified only there); mode is ") +
                              config::to_string(config.dynamic.mode), 2);
  }
  if (!args.detector.empty()) config.detector.name = args.detector;
  // Outputs are written after the whole run: a path that cannot be written
  // is bad usage now, not a failure then.
  for (const auto& [option, path] : {std::pair{"--out", &args.out}, std::pair{"--states-out", &args.states_out},
                                     std::pair{"--stats-out", &args.stats_out}}) {
    if (path->empty()) continue;
    if (auto st = io::check_output_path(*path); !st) {
      return fail(kCommand, std::string(option) + ": " + st.error().message, 2);
    }
  }
  io::SequenceOptions options;
  options.gt_path = args.gt;
  auto sequence = io::open_sequence(args.sequence, options);
  if (!sequence) return fail(kCommand, sequence.error().message, 2);
  StereoCamera camera = (*sequence)->camera();
  if (config.camera.stereo) {
    camera = *config.camera.stereo;
    const StereoCamera& images = (*sequence)->camera();
    if (camera.width != images.width || camera.height != images.height) {
      return fail(kCommand, "camera.stereo is " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                                " but the images of " + args.sequence + " are " + std::to_string(images.width) +
                                "x" + std::to_string(images.height),
                  2);
    }
  }

  std::unique_ptr<detect::Detector> detector;
  if (masking) {
    if (config.detector.name == "labels" && !(*sequence)->has_labels()) {
      return fail(kCommand, "--mode " + std::string(config::to_string(config.dynamic.mode)) +
                                " with detector labels: " + args.sequence +
                                " has no labels/boxes.csv; choose --detector stereo-geometric or a plugin", 2);
    }
    detect::DetectorContext context;
    context.sequence_dir = args.sequence;
    context.camera = camera;
    auto created = detect::create_detector(config.detector, context);
    if (!created) return fail(kCommand, "--detector " + config.detector.name + ": " + created.error().message, 2);
    detector = std::move(*created);
    const bool needs_pixels = config.dynamic.mode != config::MaskingMode::kBbox;
    if (needs_pixels && !detector->capabilities().has_segmentation) {
      return fail(kCommand, "--mode " + std::string(config::to_string(config.dynamic.mode)) +
                                " needs pixel masks, but detector " + config.detector.name +
                                " cannot segment (for labels: the sequence has no labels/masks/); use --mode bbox",
                  2);
    }
    for (const std::string& added : detect::add_inherent_dynamic_classes(config.detector, config.dynamic)) {
      std::fprintf(stderr, "sitepose run: detector %s: class '%s' added to dynamic.dynamic_classes\n",
                   config.detector.name.c_str(), added.c_str());
    }
  }
  slam::SlamOptions slam_options;
  slam_options.mapper_thread = args.mapper_thread;
  if (const double hz = io::mean_frame_rate_hz(**sequence); hz > 0.0) slam_options.fps = hz;
  auto system = slam::SlamSystem::create(camera, config, slam_options);
  if (!system) return fail(kCommand, system.error().message, 2);

  const std::size_t n_frames = args.max_frames > 0
                                   ? std::min<std::size_t>(args.max_frames, (*sequence)->size())
                                   : (*sequence)->size();
  const bool tty = isatty(STDERR_FILENO) != 0;
  slam::RunRecorder recorder;
  int detector_failures = 0;
  for (std::size_t i = 0; i < n_frames; ++i) {
    auto frame = (*sequence)->read_frame(i);
    if (!frame) return fail(kCommand, frame.error().message, 2);
    Expected<slam::FrameReport> report = make_error(ErrorCode::kRuntime, "not run");
    if (detector) {
      const auto t_detect = std::chrono::steady_clock::now();
      auto objects = slam::detect_objects(*detector, *frame);
      const double detect_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_detect).count();
      if (!objects) {
        // The frame goes on without detections (counted), never a crash.
        ++detector_failures;
        std::fprintf(stderr, "sitepose run: frame %zu: %s\n", i, objects.error().message.c_str());
        objects = dynamic::FrameObjects{};
      }
      report = (*system)->process(*frame, *objects);
      if (report) {
        report->timings.detect_ms = detect_ms;
        report->timings.total_ms += detect_ms;
      }
    } else {
      report = (*system)->process(*frame);
    }
    if (!report) {
      return fail(kCommand, "frame " + std::to_string(i) + ": " + report.error().message,
                  report.error().exit_status());
    }
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
 "  \"mode\": \"" + std::string(config::to_string(config.dynamic.mode)) + "\",\n  \"detector\": \"" +
        (detector ? config.detector.name : std::string()) + "\",\n  \"classifier\": \"" +
        config::to_string(config.dynamic.classifier) + "\",\n  \"detector_failures\": " +
        std::to_string(detector_failures) + ",\n  \"keyframes_created\": " + std::to_string(counters.keyframes_created) +
        ",\n  \"relocalisations\": " + std::to_string(counters.relocalisations) +
        ",\n  \"keyframes_in_map\": " + std::to_string((*system)->keyframe_count()) +
        ",\n  \"points_in_map\": " + std::to_string((*system)->point_count()) +
        ",\n  \"keyframes_culled\": " + std::to_string(mapping.keyframes_culled);
    if (auto st = recorder.write_stats_json(args.stats_out, extra); !st) return fail(kCommand, st.error().message, 1);
  }
  if (!args.states_out.empty()) {
    if (auto st = recorder.write_states_csv(args.states_out); !st) return fail(kCommand, st.error().message, 1);
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
  sub.add_option("--config", args->config_path, "sitepose YAML config (default: built-in defaults)")
      ->check(CLI::ExistingFile);
  sub.add_option("--orbslam2-settings", args->orbslam2_settings,
                 "ORB-SLAM2 stereo settings file: camera and ORB parameters override the config")
      ->check(CLI::ExistingFile);
  sub.add_option("--mode", args->mode,
                 std::string("Masking mode: ") + config::masking_mode_names() +
                     " (default: the config's dynamic.mode, full; full = hierarchical masks + motion "
                     "states + two passes)")
      ->check(CLI::Validator(
          [](std::string& name) {
            return config::parse_masking_mode(name) ? std::string()
                                                    : "'" + echo_value(name) + "' is not one of " +
                                                          config::masking_mode_names();
          },
          "MODE"));
  sub.add_option("--detector", args->detector,
                 "Detector for the masking modes: labels (the sequence's labels/), stereo-geometric, "
                 "opencv-dnn, or a plugin .so path (default: the config's detector.name, labels)");
  sub.add_option("--out", args->out, "Trajectory output, TUM format (T_world_cam, left camera)")->required();
  sub.add_option("--states-out", args->states_out,
                 "Motion states CSV, frame,instance,class,state,score,points,reason (--mode full only; reason: why unknown)");
  sub.add_option("--stats-out", args->stats_out, "Per-run statistics JSON");
  sub.add_option("--gt", args->gt, "Ground-truth poses file kept apart (real KITTI: poses/NN.txt)");
  sub.add_option("--frames", args->max_frames, "Process at most N frames (default: all)")
      ->check(CLI::Range(1, std::numeric_limits<int>::max()));
  sub.add_flag("--mapper-thread", args->mapper_thread,
               "Run local mapping on its own thread (as the daemon does); default runs it "
               "inline after each keyframe so results are reproducible");
  sub.add_flag("--quiet", args->quiet, "No progress output");
  return [args] { return run(*args); };
}}};

}  // namespace
}  // namespace sitepose::cli
