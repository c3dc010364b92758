// `sitepose bench track`: per-stage tracking times (p50/p99), frames/s and
// memory on a simulated scenario or a recorded sequence. Timings only,
// never pass/fail; rendering time is excluded from the tracking figures.

#include <cstdio>
#include <limits>
#include <memory>

#include "bench_report.hpp"
#include "command_config.hpp"
#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/labelled_source.hpp"

namespace sitepose::cli {
namespace {

struct BenchTrackArgs {
  FrameSourceArgs input{.scenario = "static"};
  int frames = 300;
  bool mapper_thread = true;
  std::vector<int> rss_at_frames{1000, 3000};
};

int bench_track(const BenchTrackArgs& args) {
  install_interrupt_handlers();
  auto loaded = load_command_config(args.input.config_path);
  if (!loaded) return fail("bench track", loaded.error().message, 2);
  config::SiteposeConfig& config = *loaded;
  config.dynamic.mode = config::MaskingMode::kNone;
  experiments::DynamicRunOptions options;
  options.frames = args.frames;
  options.mapper_thread = args.mapper_thread;
  std::vector<std::pair<int, double>> rss_marks;
  options.on_frame = [&](int i, int n, const slam::FrameReport&) {
    for (int mark : args.rss_at_frames) {
      if (i + 1 == mark) rss_marks.emplace_back(mark, slam::current_rss_bytes() / 1048576.0);
    }
    if ((i + 1) % 100 == 0 || i + 1 == n) std::fprintf(stderr, "bench track: %d/%d frames\n", i + 1, n);
  };
  options.stop = [] { return interrupted(); };
  auto source = open_frame_source(args.input, args.frames);
  if (!source) return fail("bench track", source.error().message, 2);
  auto run = experiments::run_dynamic(**source, config, options);
  if (!run) return fail("bench track", run.error().message, 1);
  const auto stages = run->recorder.stage_summaries();
  std::printf("bench track: %s, %d frames at %g frames/s%s, mapper %s\n", run->name.c_str(), run->frames,
              (*source)->fps(), run->partial ? " (interrupted: partial)" : "",
              args.mapper_thread ? "on its own thread" : "inline (excluded from whole_frame)");
  print_stage_table(stages);
  std::printf("frames/s (1000 / mean whole_frame): %.1f\n", run->recorder.frames_per_second());
  std::printf("keyframes in map %zu, points in map %zu\n", run->keyframes, run->points);
  print_tracker_counters(run->tracker_counters);
  print_mapping_stats(run->mapping);
  std::printf("peak RSS %.1f MiB\n", slam::peak_rss_bytes() / 1048576.0);
  for (std::size_t i = 0; i < rss_marks.size(); ++i) {
    std::printf("RSS after %d frames: %.1f MiB", rss_marks[i].first, rss_marks[i].second);
    if (i > 0)
      std::printf(" (%.3f x the RSS after %d frames)", rss_marks[i].second / rss_marks[0].second,
                  rss_marks[0].first);
    std::printf("\n");
  }
  if (run->evaluation) {
    std::printf("ATE rmse %.4f m, coverage OK %.1f %%\n", run->evaluation->ate_m.rmse,
                100.0 * run->coverage_ok());
  }
  if (run->partial) return report_interrupted("bench track", "printed the figures of the frames tracked");
  return 0;
}

void add_options(CLI::App& sub, BenchTrackArgs& args) {
  add_frame_source_options(sub, args.input, "sitepose YAML config (mode is forced to none)");
  add_bounded(sub, "--frames", args.frames, "Frames to track (0 = all)", 0, std::numeric_limits<int>::max());
  sub.add_flag("!--inline-mapper", args.mapper_thread,
               "Run local mapping inline on the tracking thread instead of its own thread");
  sub.add_option("--rss-at", args.rss_at_frames, "Frame counts at which to report the resident set")
      ->capture_default_str();
}

const CommandRegistrar kBenchTrack{make_command<BenchTrackArgs>(
    "bench", "track", add_options, bench_track,
    "Tracking time per stage (p50/p99), frames/s and memory on a simulated scenario or a sequence")};

}  // namespace
}  // namespace sitepose::cli
