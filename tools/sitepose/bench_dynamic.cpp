// `sitepose bench dynamic`: the share of frame time spent in the dynamic
// layer (detect + mask + classify + pass 2) in mode full with the `labels`
// detector, measured in one run. Timings only, never pass/fail. Local
// mapping runs inline after each frame and is not part of the frame time.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>

#include <unistd.h>

#include "bench_report.hpp"
#include "command_config.hpp"
#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/detect/create_detector.hpp"
#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/slam/detector_objects.hpp"
#include "sitepose/slam/run_recorder.hpp"
#include "sitepose/slam/slam_system.hpp"
#include "sitepose/views/debug_record.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "bench dynamic";

struct Args {
  experiments::SourceRequest source;
  std::string config_path;
  std::string detector = "labels";
  std::string mode = "full";
  std::string debug_out;
};

// The stage table of the run: mean ms per frame and share of the whole
// frame for each part of the dynamic layer, the tracker's counters and the
// frame time's p50/p99.
void print_stage_shares(const slam::RunRecorder& recorder, const slam::SlamSystem& system,
                        const std::string& dir, int frames, const config::SiteposeConfig& config,
                        const std::string& detector) {
  const double whole = recorder.stage_total_ms("whole_frame");
  const double detect = recorder.stage_total_ms("detect");
  const double mask = recorder.stage_total_ms("mask");
  const double segment = recorder.stage_total_ms("segment");
  const double classify = recorder.stage_total_ms("classify");
  const double pass2 = recorder.stage_total_ms("pass2");
  const double extract = recorder.stage_total_ms("extract_left");
  const double dynamic_ms = detect + mask + classify + pass2;
  std::printf("bench dynamic: %s, %d frames%s, mode %s, detector %s, %d frames OK\n", dir.c_str(), frames,
              interrupted() ? " (interrupted: partial)" : "", config::to_string(config.dynamic.mode),
              detector.c_str(), recorder.frames_ok());
  std::printf("%-22s %10s %10s\n", "stage", "mean ms", "share");
  const auto row = [&](const char* name, double total) {
    std::printf("%-22s %10.2f %9.1f %%\n", name, total / std::max(1, frames),
                whole > 0 ? 100.0 * total / whole : 0.0);
  };
  row("detect", detect);
  row("mask (Algorithm 1)", mask);
  row("  of it: segment", segment);
  row("classify (Algorithm 2)", classify);
  row("pass 2", pass2);
  row("dynamic layer", dynamic_ms);
  row("whole frame", whole);
  std::printf(
      "dynamic layer share of frame time: %.1f %% (not in it: left ORB extraction, %.1f %% of the "
      "frame, which includes the masked areas' own feature budget)\n",
      whole > 0 ? 100.0 * dynamic_ms / whole : 0.0, whole > 0 ? 100.0 * extract / whole : 0.0);
  print_tracker_counters(system.tracker_counters());
  print_mapping_stats(system.mapping_stats());
  const auto stages = recorder.stage_summaries();
  print_stage_table(stages);
  if (const auto it = stages.find("whole_frame"); it != stages.end()) {
    std::printf("whole frame p50 %.2f ms, p99 %.2f ms (detect included)\n", it->second.p50_ms,
                it->second.p99_ms);
  }
  if (const auto it = stages.find("frame_excl_detector"); it != stages.end()) {
    std::printf(
        "whole frame without the detector's detect + segment (the part of it the frame waited for "
        "beside the pyramids): p50 %.2f ms, p99 %.2f ms\n",
        it->second.p50_ms, it->second.p99_ms);
  }
}

// The record `--debug-out` asks for, as `run --debug-out` writes it.
Expected<std::unique_ptr<views::DebugRecordWriter>> open_debug_record(const Args& args,
                                                                      const std::string& dir,
                                                                      const config::SiteposeConfig& config,
                                                                      const StereoCamera& camera,
                                                                      double fps) {
  views::RunInfo info{"",
                      "",
                      dir,
                      args.source.scenario,
                      config::to_string(config.dynamic.mode),
                      args.detector,
                      camera.width,
                      camera.height,
                      fps};
  return views::DebugRecordWriter::open(args.debug_out, info, config::to_yaml(config));
}

// Tracks the first `frames` frames, timing the detector as a stage of the
// frame; interrupted, `frames` becomes the number done. `trace_ms`: the
// time spent filling the debug record's traces. Returns 0 or the exit status.
int track_frames(const io::Sequence& sequence, detect::Detector& detector, slam::SlamSystem& system,
                 views::DebugRecordWriter* debug, int& frames, slam::RunRecorder& recorder,
                 double& trace_ms) {
  for (int i = 0; i < frames; ++i) {
    if (interrupted()) {
      frames = i;  // the figures are of the frames done
      break;
    }
    auto frame = sequence.read_frame(i);
    if (!frame) return fail(kCommand, frame.error().message, 2);
    const auto t0 = std::chrono::steady_clock::now();
    auto objects = slam::detect_objects(detector, *frame);
    if (!objects) return fail(kCommand, objects.error().message, 1);
    const double detect_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    auto report = system.process(*frame, *objects);
    if (!report) return fail(kCommand, report.error().message, 1);
    report->timings.detect_ms = detect_ms;
    report->timings.total_ms += detect_ms;
    recorder.add(*report);
    if (debug != nullptr) {
      trace_ms += report->trace.fill_ms;
      if (auto st = debug->write(*report); !st) return fail(kCommand, st.error().message, 1);
    }
    if ((i + 1) % 50 == 0 || i + 1 == frames)
      std::fprintf(stderr, "bench dynamic: %d/%d frames\n", i + 1, frames);
  }
  return 0;
}

int run(Args args) {
  install_interrupt_handlers();
  auto loaded = load_command_config(args.config_path, args.mode);
  if (!loaded) return fail(kCommand, loaded.error().message, 2);
  config::SiteposeConfig& config = *loaded;
  config.detector.name = args.detector;
  if (auto st = experiments::check_fps_for_source(!args.source.sequence.empty(), args.source.fps); !st) {
    return fail(kCommand, st.error().message, 2);
  }
  if (args.source.sequence.empty() && args.source.scenario.empty()) args.source.scenario = "crowded";
  std::string dir = args.source.sequence;
  // The folder a scenario is simulated into is this run's own (under the
  // system's temp folder): removed when the run ends, however it ends.
  struct RemoveOnExit {
    std::filesystem::path path;
    ~RemoveOnExit() {
      std::error_code ec;
      if (!path.empty()) std::filesystem::remove_all(path, ec);
    }
  } simulated;
  if (!args.source.scenario.empty()) {
    // Simulate to disk: the labels detector reads the sequence's labels/.
    simulated.path =
        std::filesystem::temp_directory_path() / ("sitepose-bench-dynamic-" + std::to_string(::getpid()));
    args.source.temp_dir = simulated.path.string();
    auto written = experiments::open_ablation_source(args.source, &dir);
    if (!written) return fail(kCommand, written.error().message, 2);
  }
  auto sequence = io::open_sequence(dir);
  if (!sequence) return fail(kCommand, sequence.error().message, 2);
  detect::DetectorContext context;
  context.sequence_dir = dir;
  context.camera = (*sequence)->camera();
  auto detector = detect::create_detector(config.detector, context);
  if (!detector) return fail(kCommand, "--detector " + args.detector + ": " + detector.error().message, 2);
  detect::add_inherent_dynamic_classes(config.detector, config.dynamic);
  slam::SlamOptions options;
  if (const double hz = io::mean_frame_rate_hz(**sequence); hz > 0.0) options.fps = hz;
  options.trace = !args.debug_out.empty();
  std::unique_ptr<views::DebugRecordWriter> debug;
  if (options.trace) {
    auto opened = open_debug_record(args, dir, config, (*sequence)->camera(), options.fps);
    if (!opened) return fail(kCommand, "--debug-out: " + opened.error().message, 2);
    debug = std::move(*opened);
  }
  const std::size_t n = (*sequence)->size();
  auto system = slam::SlamSystem::create((*sequence)->camera(), config, options);
  if (!system) return fail(kCommand, system.error().message, 2);
  int frames = args.source.sequence.empty() || args.source.frames <= 0
                   ? static_cast<int>(n)
                   : std::min<int>(args.source.frames, static_cast<int>(n));
  slam::RunRecorder recorder;
  double trace_ms = 0.0;
  if (const int status =
          track_frames(**sequence, **detector, **system, debug.get(), frames, recorder, trace_ms);
      status != 0) {
    return status;
  }
  (*system)->finish();
  print_stage_shares(recorder, **system, dir, frames, config, args.detector);
  const double whole = recorder.stage_total_ms("whole_frame");
  if (debug) {
    if (auto st = debug->close(); !st) return fail(kCommand, st.error().message, 1);
    // Filling the trace and writing the record, outside the frame times.
    const double cost = trace_ms + debug->write_ms();
    std::printf("debug record (--debug-out %s): %.2f ms per frame = %.2f %% of tracking time (whole frame)\n",
                args.debug_out.c_str(), cost / std::max(1, frames), whole > 0 ? 100.0 * cost / whole : 0.0);
  }
  return interrupted() ? report_interrupted(kCommand, "printed the figures of the frames done") : 0;
}

void add_options(CLI::App& sub, Args& args) {
  sub.add_option("--sequence", args.source.sequence, "Sequence directory with labels");
  sub.add_option("--scenario", args.source.scenario,
                 "Scenario simulated into a temporary folder instead, removed at the end (default: crowded)");
  sub.add_option("--frames", args.source.frames, "Frames (0 = all)")
      ->check(CLI::Range(0, std::numeric_limits<int>::max()));
  add_fps_option(sub, args.source.fps);
  sub.add_option("--detector", args.detector, "Detector (default labels)");
  sub.add_option("--mode", args.mode, "Masking mode (default full)");
  sub.add_option("--config", args.config_path, "sitepose YAML config");
  sub.add_option("--debug-out", args.debug_out,
                 "Also write the debug record (as `run --debug-out`) and report its cost");
}

const CommandRegistrar kBenchDynamic{
    make_command<Args>("bench", "dynamic", add_options, run,
                       "Share of frame time in the dynamic layer (detect + mask + classify + pass 2), labels "
                       "detector, one run")};

}  // namespace
}  // namespace sitepose::cli
