// `sitepose bench loop`: what loop closing costs, in one run.
//  1. Tracking frame time with and without loop closing: the same simulated
//     run (or sequence) tracked twice in mode none, the mapper and the loop
//     closer on their own threads as in the daemon, once with loop closing
//     off and once on; whole-frame p50 / p99 / mean of both and their ratio,
//     and the closer's per-keyframe detection and verification times.
//  2. Closing a loop: the synthetic drifted return of
//     experiments/synthetic_loop.hpp (a lane of N keyframes out and back,
//     the return's odometry drifting), closed inline for each --lane size:
//     correction, pose graph, global BA and the longest write lock on the
//     map, with the error back at the start before and after.
// Timings only, never pass/fail. Ctrl-C / SIGTERM: what was measured,
// marked partial, exit 130.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>
#include <memory>

#include "command_config.hpp"
#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/core/centred_camera.hpp"
#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/experiments/synthetic_loop.hpp"
#include "sitepose/experiments/vocabulary_training.hpp"
#include "sitepose/loop/loop_closer.hpp"
#include "sitepose/placerec/keyframe_database.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "bench loop";

struct Args {
  FrameSourceArgs input{.scenario = "backforth"};
  std::string vocabulary;
  int frames = 230;  // out and back along the backforth lane, then standing
  int train_every = 6;
  std::vector<int> lanes{41, 121};
};

double mean_ms(double total_ms, std::int64_t count) {
  return count > 0 ? total_ms / static_cast<double>(count) : 0.0;
}

void print_frame_row(const char* label, const experiments::DynamicRunResult& run) {
  const auto stages = run.recorder.stage_summaries();
  const auto it = stages.find("whole_frame");
  if (it == stages.end()) return;
  std::printf("%-18s %9.2f %9.2f %9.2f %10zu %10.4f\n", label, it->second.p50_ms, it->second.p99_ms,
              it->second.mean_ms, run.keyframes, run.ate_m());
}

// Part 1. Returns the exit status (0, or 130 when interrupted).
int measure_tracking(const Args& args) {
  auto loaded = load_command_config(args.input.config_path);
  if (!loaded) return fail(kCommand, loaded.error().message, 2);
  config::SiteposeConfig config = *loaded;
  config.dynamic.mode = config::MaskingMode::kNone;
  auto source = open_frame_source(args.input, args.frames);
  if (!source) return fail(kCommand, source.error().message, 2);
  auto vocabulary = load_or_train_vocabulary(args.vocabulary, [&] {
    // Frames 0, every, 2 every, ... below --frames.
    const int max_images = args.frames > 0 ? (args.frames + args.train_every - 1) / args.train_every : 0;
    return experiments::left_image_descriptors(**source, config.orb, args.train_every, max_images);
  });
  if (!vocabulary) return fail(kCommand, vocabulary.error().message, args.vocabulary.empty() ? 1 : 2);
  std::printf(
      "bench loop: tracking %s, %d frames, mode none, mapper and closer on their own threads, "
      "vocabulary %s (%zu words%s)\n",
      (*source)->name().c_str(), std::min(args.frames, (*source)->size()), (*vocabulary)->id().c_str(),
      (*vocabulary)->word_count(), args.vocabulary.empty() ? ", trained on this run's frames" : "");
  experiments::DynamicRunOptions options;
  options.frames = args.frames;
  options.mapper_thread = true;
  options.vocabulary = *vocabulary;
  options.stop = [] { return interrupted(); };
  std::printf("%-18s %9s %9s %9s %10s %10s\n", "loop closing", "p50 ms", "p99 ms", "mean ms", "keyframes",
              "ATE m");
  config.mapping.loop_closing = false;
  auto off = experiments::run_dynamic(**source, config, options);
  if (!off) return fail(kCommand, off.error().message, 1);
  if (off->partial) return report_interrupted(kCommand, "measured nothing: it stopped in the first run");
  print_frame_row("off", *off);
  config.mapping.loop_closing = true;
  auto on = experiments::run_dynamic(**source, config, options);
  if (!on) return fail(kCommand, on.error().message, 1);
  print_frame_row(on->partial ? "on (partial)" : "on", *on);
  // Mean whole-frame time on / off = frames/s off / on.
  const double on_fps = on->recorder.frames_per_second();
  std::printf("whole frame, mean on / off: %.3f\n",
              on_fps > 0.0 ? off->recorder.frames_per_second() / on_fps : 0.0);
  if (on->loop_stats) {
    const loop::LoopClosingStats& s = *on->loop_stats;
    std::printf(
        "closer: %lld keyframes checked, detection %.2f ms mean / %.2f max, %lld candidates verified "
        "(%.2f ms mean / %.2f max), %lld loops closed, %lld refused\n",
        static_cast<long long>(s.keyframes_checked), mean_ms(s.total_detection_ms, s.keyframes_checked),
        s.max_detection_ms, static_cast<long long>(s.consistent_candidates),
        mean_ms(s.total_verification_ms, s.consistent_candidates), s.max_verification_ms,
        static_cast<long long>(s.loops_closed), static_cast<long long>(s.loops_refused));
  }
  if (on->partial) return report_interrupted(kCommand, "printed the figures of the frames tracked");
  return 0;
}

// Part 2, one lane size.
Status measure_closing(int lane_keyframes) {
  const double lane_m = lane_keyframes - 1;
  // The wall's density of the 40 m lane (6000 points over 56 m), for every length.
  const int points = static_cast<int>(6000.0 * (lane_m + 16.0) / 56.0);
  // The rig of tests/unit/loop.
  const StereoCamera camera = centred_camera(640, 360, 500.0, 0.5);
  const experiments::DriftedReturn lane = experiments::make_drifted_return(
      camera, experiments::make_textured_wall(7, lane_m, points), lane_keyframes);
  SITEPOSE_TRY(auto vocabulary, experiments::vocabulary_of(lane.map));
  placerec::KeyFrameDatabase database(vocabulary);
  database.rebuild(lane.map);
  map::SharedMap shared;
  shared.write([&](map::MapData& m) { m = lane.map; });
  loop::LoopCloser closer(camera, shared, database, {});
  for (map::KeyFrameId id : lane.inbound) closer.enqueue(id);
  const auto start = std::chrono::steady_clock::now();
  SITEPOSE_TRY_STATUS(closer.process_pending());
  const double total_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const loop::LoopClosingStats s = closer.stats();
  const map::MapData after = shared.read([](const map::MapData& m) { return m; });
  const double before_m =
      experiments::keyframe_error_m(lane.map, lane.inbound.back(), lane.inbound_truth.back());
  const double after_m = experiments::keyframe_error_m(after, lane.inbound.back(), lane.inbound_truth.back());
  std::printf("%6d %7zu %6lld %10.2f %10.1f %11.1f %6d %10.1f %7d %10.1f %10.1f %9.3f %9.4f %9.1f\n",
              2 * lane_keyframes - 1, after.points().size(), static_cast<long long>(s.loops_closed),
              mean_ms(s.total_detection_ms, s.keyframes_checked), s.max_verification_ms, s.last_correction_ms,
              s.last_graph_nodes, s.last_optimisation_ms, s.last_global_ba_points, s.last_global_ba_ms,
              s.max_write_lock_ms, before_m, after_m, total_ms);
  return {};
}

int run(const Args& args) {
  install_interrupt_handlers();
  if (const int status = measure_tracking(args); status != 0) return status;
  std::printf("\nbench loop: closing the synthetic drifted return (lane out and back, inline)\n");
  std::printf("%6s %7s %6s %10s %10s %11s %6s %10s %7s %10s %10s %9s %9s %9s\n", "kfs", "points", "loops",
              "detect ms", "verify ms", "correct ms", "graph", "graph ms", "BA pts", "BA ms", "lock ms",
              "before m", "after m", "total ms");
  std::size_t lanes_done = 0;
  for (int lane : args.lanes) {
    if (interrupted()) break;
    if (auto st = measure_closing(lane); !st) return fail(kCommand, st.error().message, 1);
    ++lanes_done;
  }
  if (lanes_done < args.lanes.size())
    return report_rows_interrupted(kCommand, lanes_done, args.lanes.size(), "lanes");
  return 0;
}

void add_options(CLI::App& sub, Args& args) {
  add_frame_source_options(sub, args.input, "sitepose YAML config (mode is forced to none)");
  add_bench_vocabulary_option(sub, args.vocabulary, "one trained on the run's frames");
  add_bounded(sub, "--frames", args.frames, "Frames to track, twice (0 = all)", 0,
              std::numeric_limits<int>::max());
  add_bounded(sub, "--train-every", args.train_every, "Without --vocabulary: train on every N-th frame", 1,
              1000);
  add_bounded(sub, "--lanes", args.lanes, "Keyframes per pass of each synthetic lane to close", 12, 2000);
}

const CommandRegistrar kBenchLoop{
    make_command<Args>("bench", "loop", add_options, run,
                       "Loop-closing cost: frame time with it off vs on; closing a synthetic drifted loop")};

}  // namespace
}  // namespace sitepose::cli
