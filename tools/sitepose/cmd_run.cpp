// `sitepose run`: track a recorded sequence and write the trajectory
// (FORMATS.md command contract).

#include <unistd.h>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/config/orbslam2_settings.hpp"
#include "sitepose/core/build_info.hpp"
#include "sitepose/core/echo.hpp"
#include "sitepose/detect/create_detector.hpp"
#include "sitepose/dynamic/masking.hpp"
#include "sitepose/io/json_file.hpp"
#include "sitepose/io/output_path.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/io/trajectory.hpp"
#include "sitepose/mapfile/map_file.hpp"
#include "sitepose/placerec/vocabulary.hpp"
#include "sitepose/slam/detector_objects.hpp"
#include "sitepose/slam/run_recorder.hpp"
#include "sitepose/slam/slam_system.hpp"
#include "sitepose/views/debug_record.hpp"

namespace sitepose::cli {
namespace {

struct RunArgs {
  std::string sequence;
  std::string config_path;
  std::string orbslam2_settings;
  std::string mode;
  std::string detector;
  std::string out;
  std::string final_out;
  std::string format = "tum";
  std::string tracking_out;
  std::string states_out;
  std::string stats_out;
  std::string gt;
  std::string map_in;
  std::string map_out;
  std::string vocabulary;
  std::string debug_out;
  int max_frames = 0;
  int first_frame = 0;
  bool mapper_thread = false;
  bool quiet = false;
};

constexpr const char* kCommand = "run";

double ms_between(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// --map-in: the saved map the run starts in (a refused file is bad input).
Status load_map_in(const std::string& path, slam::SlamSystem& system, bool quiet) {
  const auto start = std::chrono::steady_clock::now();
  auto loaded = mapfile::load_map(path);
  if (!loaded) return Unexpected{loaded.error()};
  const std::size_t keyframes = loaded->map.keyframe_count();
  const std::size_t points = loaded->map.point_count();
  // Bags of words are not stored: the database is rebuilt from the
  // keyframes' descriptors with this run's vocabulary, whatever the map's.
  if (!quiet && loaded->meta.vocabulary_id != system.vocabulary_id()) {
    const std::string saved = loaded->meta.vocabulary_id.empty() ? "none" : loaded->meta.vocabulary_id;
    const std::string now = system.vocabulary_id().empty()
                                ? "this run has none: relocalisation uses the exact vote"
                                : "bags of words rebuilt with " + system.vocabulary_id();
    std::fprintf(stderr, "sitepose run: map %s was saved with vocabulary %s; %s\n", path.c_str(),
                 saved.c_str(), now.c_str());
  }
  if (auto st = system.load_map(std::move(loaded->map)); !st) {
    return make_error(ErrorCode::kInvalidArgument, "--map-in " + path + ": " + st.error().message);
  }
  if (!quiet) {
    std::fprintf(stderr, "sitepose run: map %s loaded: %zu keyframes, %zu points, %.1f ms\n", path.c_str(),
                 keyframes, points, ms_between(start, std::chrono::steady_clock::now()));
  }
  return ok_status();
}

Status save_map_out(const std::string& path, const slam::SlamSystem& system, bool quiet) {
  const auto start = std::chrono::steady_clock::now();
  const map::MapData map = system.copy_map();
  const auto copied = std::chrono::steady_clock::now();
  mapfile::MapFileMeta meta;
  meta.vocabulary_id = system.vocabulary_id();
  if (auto st = mapfile::save_map(path, map, meta); !st) return st;
  if (!quiet) {
    std::error_code ec;
    std::fprintf(
        stderr,
        "sitepose run: map %s saved: %zu keyframes, %zu points, %ju bytes, copy %.1f ms, write %.1f ms\n",
        path.c_str(), map.keyframe_count(), map.point_count(),
        static_cast<std::uintmax_t>(std::filesystem::file_size(path, ec)), ms_between(start, copied),
        ms_between(copied, std::chrono::steady_clock::now()));
  }
  return ok_status();
}

struct TrackedRun {
  slam::RunRecorder recorder;
  int detector_failures = 0;
  double trace_ms = 0.0;  // filling the --debug-out record, outside the frame times
};

// Tracks frames [first, n_frames) until done or interrupted (the frame in
// progress is finished first, so the trajectory holds every frame started).
// Returns 0, or the exit status of a failure.
int track(const RunArgs& args, const io::Sequence& sequence, std::size_t first, std::size_t n_frames,
          detect::Detector* detector, slam::SlamSystem& system, views::DebugRecordWriter* debug,
          TrackedRun& tracked) {
  const bool tty = isatty(STDERR_FILENO) != 0;
  for (std::size_t i = first; i < n_frames && !interrupted(); ++i) {
    auto frame = sequence.read_frame(i);
    if (!frame) return fail(kCommand, frame.error().message, 2);
    Expected<slam::FrameReport> report = make_error(ErrorCode::kRuntime, "not run");
    if (detector != nullptr) {
      const auto t_detect = std::chrono::steady_clock::now();
      auto objects = slam::detect_objects(*detector, *frame);
      const double detect_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_detect).count();
      if (!objects) {
        // The frame goes on without detections (counted), never a crash.
        ++tracked.detector_failures;
        std::fprintf(stderr, "sitepose run: frame %zu: %s\n", i, objects.error().message.c_str());
        objects = dynamic::FrameObjects{};
      }
      report = system.process(*frame, *objects);
      if (report) {
        report->timings.detect_ms = detect_ms;
        report->timings.total_ms += detect_ms;
      }
    } else {
      report = system.process(*frame);
    }
    if (!report) {
      return fail(kCommand, "frame " + std::to_string(i) + ": " + report.error().message,
                  report.error().exit_status());
    }
    tracked.recorder.add(*report);
    if (debug != nullptr) {
      tracked.trace_ms += report->trace.fill_ms;
      if (auto st = debug->write(*report); !st) return fail(kCommand, st.error().message, 1);
    }
    if (!args.quiet &&
        (tty ? (i % 5 == 0 || i + 1 == n_frames) : ((i + 1) % 100 == 0 || i + 1 == n_frames))) {
      std::fprintf(stderr, "%sframe %zu/%zu  %s  %.1f frames/s%s", tty ? "\r" : "", i + 1, n_frames,
                   to_string(report->pose.state), tracked.recorder.frames_per_second(), tty ? "   " : "\n");
    }
  }
  if (!args.quiet && tty) std::fprintf(stderr, "\n");
  return 0;
}

// The loop closer's counters and times for --stats-out.
io::Json loop_stats_json(const loop::LoopClosingStats& s) {
  return io::Json{{"keyframes_checked", s.keyframes_checked},
                  {"consistent_candidates", s.consistent_candidates},
                  {"loops_refused", s.loops_refused},
                  {"loops_closed", s.loops_closed},
                  {"total_detection_ms", s.total_detection_ms},
                  {"max_detection_ms", s.max_detection_ms},
                  {"total_verification_ms", s.total_verification_ms},
                  {"max_verification_ms", s.max_verification_ms},
                  {"last_correction_ms", s.last_correction_ms},
                  {"last_optimisation_ms", s.last_optimisation_ms},
                  {"total_correction_ms", s.total_correction_ms},
                  {"max_write_lock_ms", s.max_write_lock_ms},
                  {"last_graph_nodes", s.last_graph_nodes},
                  {"last_graph_edges", s.last_graph_edges},
                  {"last_matches", s.last_matches},
                  {"global_ba_runs", s.global_ba_runs},
                  {"global_ba_stopped", s.global_ba_stopped},
                  {"last_global_ba_ms", s.last_global_ba_ms},
                  {"last_global_ba_keyframes", s.last_global_ba_keyframes},
                  {"last_global_ba_points", s.last_global_ba_points}};
}

// Writes the trajectory and the optional stats and states of the frames
// tracked; `partial`: the run was interrupted before its last frame.
int write_outputs(const RunArgs& args, const config::SiteposeConfig& config, bool with_detector,
                  const slam::SlamSystem& system, const TrackedRun& tracked, bool partial) {
  const slam::RunRecorder& recorder = tracked.recorder;
  const io::TrajectoryFormat format = *io::parse_trajectory_format(args.format);  // checked at parse
  if (auto st = recorder.write_trajectory(args.out, format); !st)
    return fail(kCommand, st.error().message, 1);
  std::optional<slam::RunRecorder::FinalTrajectoryCounts> final_counts;
  if (!args.final_out.empty()) {
    auto written =
        recorder.write_final_trajectory(args.final_out, format, system.poses_in_final_map(recorder.poses()));
    if (!written) return fail(kCommand, written.error().message, 1);
    final_counts = *written;
    if (!args.quiet) {
      std::fprintf(stderr,
                   "sitepose run: final trajectory %s: %d poses in the final map, %d left out (tracked in "
                   "a provisional map that was dropped)\n",
                   args.final_out.c_str(), final_counts->poses, final_counts->left_out);
    }
  }
  if (!args.tracking_out.empty()) {
    if (auto st = recorder.write_tracking_states_csv(args.tracking_out); !st) {
      return fail(kCommand, st.error().message, 1);
    }
  }
  if (!args.stats_out.empty()) {
    const auto& counters = system.tracker_counters();
    const auto mapping = system.mapping_stats();
    io::Json extra{{"mode", config::to_string(config.dynamic.mode)},
                   {"detector", with_detector ? config.detector.name : std::string()},
                   {"classifier", config::to_string(config.dynamic.classifier)},
                   {"detector_failures", tracked.detector_failures},
                   {"keyframes_created", counters.keyframes_created},
                   {"relocalisations", counters.relocalisations},
                   {"provisional_maps",
                    {{"started", counters.provisional_maps_started},
                     {"joined", counters.provisional_maps_joined},
                     {"dropped", counters.provisional_maps_dropped},
                     {"joins_dropped_unconfirmed", counters.joins_dropped_unconfirmed}}},
                   {"old_keyframe_matches",
                    {{"age_s", tracking::kOldKeyFrameAge_s},
                     {"matches", counters.matches},
                     {"from_old_keyframes", counters.matches_from_old_keyframes}}},
                   {"keyframes_in_map", system.keyframe_count()},
                   {"points_in_map", system.point_count()},
                   {"keyframes_culled", mapping.keyframes_culled},
                   {"keyframes_culled_by_site", mapping.keyframes_culled_by_site},
                   {"partial", partial}};
    if (const auto loops = system.loop_stats(); loops) extra["loop_closing"] = loop_stats_json(*loops);
    if (final_counts) {
      extra["final_trajectory"] = {{"poses", final_counts->poses}, {"left_out", final_counts->left_out}};
    }
    if (auto st = recorder.write_stats_json(args.stats_out, extra); !st)
      return fail(kCommand, st.error().message, 1);
  }
  if (!args.states_out.empty()) {
    if (auto st = recorder.write_states_csv(args.states_out); !st)
      return fail(kCommand, st.error().message, 1);
  }
  return 0;
}

// The settings of the run (--config, --orbslam2-settings, --mode,
// --detector) and the checks between them. Returns 0 or the exit status.
int resolve_config(const RunArgs& args, config::SiteposeConfig& config) {
  if (!args.config_path.empty()) {
    auto loaded = config::load_config(args.config_path);
    if (!loaded) return fail(kCommand, loaded.error().message, 2);
    config = *loaded;
  }
  if (!args.orbslam2_settings.empty()) {
    auto settings = config::load_orbslam2_settings(args.orbslam2_settings);
    if (!settings) return fail(kCommand, settings.error().message, 2);
    if (!settings->ignored_keys.empty()) {
      std::string keys;
      for (const std::string& key : settings->ignored_keys) keys += (keys.empty() ? "" : ", ") + key;
      std::fprintf(stderr, "sitepose run: %s: keys sitepose does not use, ignored: %s\n",
                   args.orbslam2_settings.c_str(), keys.c_str());
    }
    config::apply_orbslam2_settings(*settings, config);
  }
  if (!args.mode.empty()) {
    auto mode = config::parse_masking_mode(args.mode);
    if (!mode) return fail(kCommand, "--mode: " + mode.error().message, 2);
    config.dynamic.mode = *mode;
  }
  const bool masking = config.dynamic.mode != config::MaskingMode::kNone;
  if (!masking && !args.detector.empty()) {
    return fail(
        kCommand,
        "--detector needs a masking mode (--mode bbox|pixel|hierarchical|full); --mode none uses no detector",
        2);
  }
  if (!args.states_out.empty() && config.dynamic.mode != config::MaskingMode::kFull) {
    return fail(
        kCommand,
        std::string("--states-out needs --mode full (motion states are classified only there); mode is ") +
            config::to_string(config.dynamic.mode),
        2);
  }
  if (!args.detector.empty()) config.detector.name = args.detector;
  return 0;
}

// Outputs are written after the whole run: a path that cannot be written
// is bad usage now, not a failure then. Returns 0 or the exit status.
int check_outputs(const RunArgs& args) {
  const bool kitti = args.format == "kitti";
  const std::string kitti_times = kitti ? io::kitti_times_path(args.out) : std::string();
  const std::string final_kitti_times =
      kitti && !args.final_out.empty() ? io::kitti_times_path(args.final_out) : std::string();
  for (const auto& [option, path] :
       {std::pair{"--out", &args.out}, std::pair{"--out (its .times.txt)", &kitti_times},
        std::pair{"--final-out", &args.final_out},
        std::pair{"--final-out (its .times.txt)", &final_kitti_times},
        std::pair{"--states-out", &args.states_out}, std::pair{"--stats-out", &args.stats_out},
        std::pair{"--tracking-out", &args.tracking_out}, std::pair{"--map-out", &args.map_out}}) {
    if (path->empty()) continue;
    if (auto st = io::check_output_path(*path); !st) {
      return fail(kCommand, std::string(option) + ": " + st.error().message, 2);
    }
  }
  return 0;
}

// The camera the run tracks with: the sequence's, or the config's
// camera.stereo when it matches the images' size. Returns 0 or the exit status.
int resolve_camera(const RunArgs& args, const config::SiteposeConfig& config, const io::Sequence& sequence,
                   StereoCamera& camera) {
  camera = sequence.camera();
  if (!config.camera.stereo) return 0;
  camera = *config.camera.stereo;
  const StereoCamera& images = sequence.camera();
  if (camera.width != images.width || camera.height != images.height) {
    const std::string from =
        args.orbslam2_settings.empty() ? "" : " (from --orbslam2-settings " + args.orbslam2_settings + ")";
    return fail(kCommand,
                "camera.stereo" + from + " is " + std::to_string(camera.width) + "x" +
                    std::to_string(camera.height) + " but the images of " + args.sequence + " are " +
                    std::to_string(images.width) + "x" + std::to_string(images.height),
                2);
  }
  return 0;
}

// The detector a masking mode needs, checked against what the mode asks
// (labels present, pixel masks). Returns 0 or the exit status.
int create_run_detector(const RunArgs& args, config::SiteposeConfig& config, const io::Sequence& sequence,
                        const StereoCamera& camera, std::unique_ptr<detect::Detector>& detector) {
  if (config.detector.name == "labels" && !sequence.has_labels()) {
    return fail(kCommand,
                "--mode " + std::string(config::to_string(config.dynamic.mode)) +
                    " with detector labels: " + args.sequence +
                    " has no labels/boxes.csv; choose --detector stereo-geometric or a plugin",
                2);
  }
  detect::DetectorContext context;
  context.sequence_dir = args.sequence;
  context.camera = camera;
  auto created = detect::create_detector(config.detector, context);
  if (!created)
    return fail(kCommand, "--detector " + config.detector.name + ": " + created.error().message, 2);
  detector = std::move(*created);
  const bool needs_pixels = config.dynamic.mode != config::MaskingMode::kBbox;
  if (needs_pixels && !detector->capabilities().has_segmentation) {
    return fail(kCommand,
                "--mode " + std::string(config::to_string(config.dynamic.mode)) +
                    " needs pixel masks, but detector " + config.detector.name +
                    " cannot segment (for labels: the sequence has no labels/masks/); use --mode bbox",
                2);
  }
  for (const std::string& added : detect::add_inherent_dynamic_classes(config.detector, config.dynamic)) {
    std::fprintf(stderr, "sitepose run: detector %s: class '%s' added to dynamic.dynamic_classes\n",
                 config.detector.name.c_str(), added.c_str());
  }
  return 0;
}

// After the last frame: the mapper drained, the map saved, every output and
// the debug record written, and the summary line (or the interrupted note).
// Returns the exit status.
int finish_run(const RunArgs& args, const config::SiteposeConfig& config, bool with_detector,
               slam::SlamSystem& system, const TrackedRun& tracked, std::size_t frames_asked,
               views::DebugRecordWriter* debug) {
  system.finish();
  const bool partial = tracked.recorder.frames() < static_cast<int>(frames_asked);
  if (!args.map_out.empty()) {
    if (auto st = save_map_out(args.map_out, system, args.quiet); !st)
      return fail(kCommand, st.error().message, 1);
  }
  if (const int status = write_outputs(args, config, with_detector, system, tracked, partial); status != 0) {
    return status;
  }
  if (debug != nullptr) {
    if (auto st = debug->close(); !st) return fail(kCommand, st.error().message, 1);
    const double whole = tracked.recorder.stage_total_ms("whole_frame");
    const double cost = tracked.trace_ms + debug->write_ms();
    std::printf("debug record in %s: %.1f ms, %.2f %% of tracking time\n", args.debug_out.c_str(), cost,
                whole > 0 ? 100.0 * cost / whole : 0.0);
  }
  if (partial) {
    const std::string what = "wrote the " + std::to_string(tracked.recorder.frames()) + " of " +
                             std::to_string(frames_asked) + " frames tracked" +
                             (args.stats_out.empty() ? "" : " (stats marked partial)");
    return report_interrupted(kCommand, what.c_str());
  }
  std::printf(
      "frames %d, tracked OK %d (%.1f %%), %.1f frames/s, keyframes %zu, points %zu\n",
      tracked.recorder.frames(), tracked.recorder.frames_ok(),
      tracked.recorder.frames() ? 100.0 * tracked.recorder.frames_ok() / tracked.recorder.frames() : 0.0,
      tracked.recorder.frames_per_second(), system.keyframe_count(), system.point_count());
  const auto& counters = system.tracker_counters();
  std::printf(
      "matches to points that keyframes made %.0f s or more before the frame observe: %ld of %ld (%.1f %%)\n",
      tracking::kOldKeyFrameAge_s, counters.matches_from_old_keyframes, counters.matches,
      counters.matches > 0 ? 100.0 * static_cast<double>(counters.matches_from_old_keyframes) /
                                 static_cast<double>(counters.matches)
                           : 0.0);
  if (const auto loops = system.loop_stats(); loops) {
    std::printf(
        "loop closing: keyframes checked %lld, consistent candidates %lld, refused %lld, loops closed %lld; "
        "detection %.2f ms mean (max %.2f), verification max %.1f ms, last correction %.1f ms, last "
        "pose-graph solve %.1f ms (%d keyframes, %d edges), global BAs %lld (last %.1f ms, %d keyframes, %d "
        "points), longest write lock %.1f ms\n",
        static_cast<long long>(loops->keyframes_checked),
        static_cast<long long>(loops->consistent_candidates), static_cast<long long>(loops->loops_refused),
        static_cast<long long>(loops->loops_closed),
        loops->keyframes_checked ? loops->total_detection_ms / static_cast<double>(loops->keyframes_checked)
                                 : 0.0,
        loops->max_detection_ms, loops->max_verification_ms, loops->last_correction_ms,
        loops->last_optimisation_ms, loops->last_graph_nodes, loops->last_graph_edges,
        static_cast<long long>(loops->global_ba_runs), loops->last_global_ba_ms,
        loops->last_global_ba_keyframes, loops->last_global_ba_points, loops->max_write_lock_ms);
  }
  return 0;
}

int run(const RunArgs& args) {
  install_interrupt_handlers();
  config::SiteposeConfig config;
  if (const int status = resolve_config(args, config); status != 0) return status;
  if (const int status = check_outputs(args); status != 0) return status;
  io::SequenceOptions options;
  options.gt_path = args.gt;
  options.channel_order = config.camera.channel_order;
  auto sequence = io::open_sequence(args.sequence, options);
  if (!sequence) return fail(kCommand, sequence.error().message, 2);
  StereoCamera camera;
  if (const int status = resolve_camera(args, config, **sequence, camera); status != 0) return status;
  std::unique_ptr<detect::Detector> detector;
  if (config.dynamic.mode != config::MaskingMode::kNone) {
    if (const int status = create_run_detector(args, config, **sequence, camera, detector); status != 0) {
      return status;
    }
  }
  slam::SlamOptions slam_options;
  slam_options.mapper_thread = args.mapper_thread;
  slam_options.trace = !args.debug_out.empty();
  slam_options.keep_removed_keyframe_links = !args.final_out.empty();
  if (const double hz = io::mean_frame_rate_hz(**sequence); hz > 0.0) slam_options.fps = hz;
  if (!args.vocabulary.empty()) {
    auto vocabulary = placerec::Vocabulary::load(args.vocabulary);
    if (!vocabulary) return fail(kCommand, "--vocabulary: " + vocabulary.error().message, 2);
    slam_options.vocabulary = std::make_shared<const placerec::Vocabulary>(std::move(*vocabulary));
  }
  auto system = slam::SlamSystem::create(camera, config, slam_options);
  if (!system) return fail(kCommand, system.error().message, 2);
  if (!args.map_in.empty()) {
    if (auto st = load_map_in(args.map_in, **system, args.quiet); !st)
      return fail(kCommand, st.error().message, 2);
  }
  std::unique_ptr<views::DebugRecordWriter> debug;
  if (!args.debug_out.empty()) {
    views::RunInfo info{version_string(),
                        git_revision(),
                        std::filesystem::absolute(args.sequence).string(),
                        "",
                        config::to_string(config.dynamic.mode),
                        detector ? config.detector.name : "",
                        camera.width,
                        camera.height,
                        slam_options.fps};
    auto opened = views::DebugRecordWriter::open(args.debug_out, info, config::to_yaml(config));
    if (!opened) return fail(kCommand, "--debug-out: " + opened.error().message, 2);
    debug = std::move(*opened);
  }

  const std::size_t first = static_cast<std::size_t>(args.first_frame);
  if (first >= (*sequence)->size()) {
    return fail(kCommand,
                "--first-frame " + std::to_string(first) + ": the sequence has " +
                    std::to_string((*sequence)->size()) + " frames",
                2);
  }
  const std::size_t n_frames = args.max_frames > 0
                                   ? std::min<std::size_t>(first + args.max_frames, (*sequence)->size())
                                   : (*sequence)->size();
  TrackedRun tracked;
  if (const int status =
          track(args, **sequence, first, n_frames, detector.get(), **system, debug.get(), tracked);
      status != 0) {
    return status;
  }
  return finish_run(args, config, detector != nullptr, **system, tracked, n_frames - first, debug.get());
}

void add_options(CLI::App& sub, RunArgs& args) {
  sub.add_option("--sequence", args.sequence, "Sequence directory (sitepose/KITTI or EuRoC layout)")
      ->required();
  sub.add_option("--config", args.config_path, "sitepose YAML config (default: built-in defaults)")
      ->check(CLI::ExistingFile);
  sub.add_option("--orbslam2-settings", args.orbslam2_settings,
                 "ORB-SLAM2 stereo settings file: camera and ORB parameters override the config")
      ->check(CLI::ExistingFile);
  sub.add_option("--mode", args.mode,
                 std::string("Masking mode: ") + config::masking_mode_names() +
                     " (default: the config's dynamic.mode, full; full = hierarchical masks + motion "
                     "states + two passes)")
      ->check(CLI::Validator(
          [](std::string& name) {
            return config::parse_masking_mode(name)
                       ? std::string()
                       : "'" + echo_value(name) + "' is not one of " + config::masking_mode_names();
          },
          "MODE"));
  sub.add_option("--detector", args.detector,
                 "Detector for the masking modes: labels (the sequence's labels/), stereo-geometric, "
                 "opencv-dnn, or a plugin .so path (default: the config's detector.name, labels)");
  sub.add_option("--out", args.out, "Trajectory output (T_world_cam, left camera; frames not LOST)")
      ->required();
  sub.add_option("--final-out", args.final_out,
                 "The frames of --out re-expressed in the map as the run left it: each pose moves with "
                 "its keyframe by the later corrections (loop closing, global BA, a provisional map "
                 "joined), as ORB-SLAM2 saves a trajectory; for evaluation, not what was published live; "
                 "frames tracked in a provisional map that was dropped are left out; same --format");
  sub.add_option("--format", args.format,
                 "Trajectory format: tum (t x y z qx qy qz qw), kitti (3x4 rows; times in OUT.times.txt) or "
                 "euroc (CSV, t in ns)")
      ->capture_default_str()
      ->check(CLI::IsMember({"tum", "kitti", "euroc"}));
  sub.add_option("--tracking-out", args.tracking_out,
                 "Tracking state of every frame, CSV frame,t_s,state (OK, RECOVERING or LOST; "
                 "docs/run/README.md, Tracking states)");
  sub.add_option("--states-out", args.states_out,
                 "Motion states CSV, frame,instance,class,state,score,points,reason (--mode full only; "
                 "reason: why unknown)");
  sub.add_option("--stats-out", args.stats_out, "Per-run statistics JSON");
  sub.add_option("--gt", args.gt, "Ground-truth poses file kept apart (real KITTI: poses/NN.txt)");
  sub.add_option("--debug-out", args.debug_out,
                 "Folder for the per-frame debug record that `sitepose view` and `sitepose report` read");
  sub.add_option("--frames", args.max_frames, "Process at most N frames (default: all)")
      ->check(CLI::Range(1, std::numeric_limits<int>::max()));
  sub.add_option("--first-frame", args.first_frame, "Start at frame N (0-based; default 0)")
      ->check(CLI::Range(0, std::numeric_limits<int>::max()));
  sub.add_option("--map-in", args.map_in,
                 "Start in this saved map (sitepose map file): the first frames relocalise in it and the "
                 "trajectory continues in its frame")
      ->check(CLI::ExistingFile);
  sub.add_option(
      "--map-out", args.map_out,
      "Save the map here at the end (atomically: a failed save leaves an existing file as it was)");
  sub.add_option("--vocabulary", args.vocabulary,
                 "Place-recognition vocabulary (sitepose vocab train): relocalisation candidates from "
                 "a keyframe database queried by bag of words instead of the exact vote over all map "
                 "points; its id goes into --map-out")
      ->check(CLI::ExistingFile);
  sub.add_flag("--mapper-thread", args.mapper_thread,
               "Run local mapping on its own thread (as the daemon does); default runs it "
               "inline after each keyframe so results are reproducible");
  sub.add_flag("--quiet", args.quiet, "No progress output");
}

const CommandRegistrar kRun{make_command<RunArgs>(
    "", "run", add_options, run, "Track a recorded stereo sequence and write its trajectory")};

}  // namespace
}  // namespace sitepose::cli
