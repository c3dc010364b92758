// `sitepose bench soak`: the daemon's pipeline (capture -> detect -> track
// -> publish threads, SLAM with its mapper thread) on a recorded sequence
// held in memory and looped, with continuing frame numbers and times, for
// --frames frames at the pipeline's own pace (lossless back-pressure). Every
// --sample-every published frames one CSV row: RSS, keyframes, map points,
// drops, track errors and the frame-to-publish latency p99 of the window,
// and beside the CSV a PNG of RSS, map size and p99 over the frames.
// The looped part (--loop-from to the end) should end where it starts, or
// every loop is a jump the tracker must relocalise from. backforth's first
// pass starts from standing and does not: its frame 215 is 4.3 m from frame
// 0 and moving; from frame 216 on it is periodic (frames 216 and 432 within
// 0.3 mm): `sitepose sim --scenario backforth --frames 432` with
// --loop-from 216.
// With --max-rss-growth PCT it is a check: exit 1 when the last RSS exceeds
// the RSS at the end of the warm-up (--warmup-frames) by more than PCT %.
// Ctrl-C / SIGTERM ends the source: the pipeline drains, the last row and
// the PNG are written, the summary says partial, exit 130.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <thread>
#include <vector>

#include "command_config.hpp"
#include "command_registry.hpp"
#include "interrupt.hpp"
#include "pipeline_bench.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/experiments/charts.hpp"
#include "sitepose/pipeline/pipeline.hpp"
#include "sitepose/pipeline/slam_tracker.hpp"
#include "sitepose/slam/run_recorder.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "bench soak";

struct BenchSoakArgs {
  std::string sequence;
  PipelineConfigArgs settings{.mode = "full"};
  std::string csv;
  int frames = 20000;
  int sample_every = 1000;
  int warmup_frames = 2000;
  int loop_from = 0;
  double max_rss_growth_pct = -1.0;  // < 0: no check
};

// Frames [0, loop_from) once, then frames [loop_from, end) again and again;
// loop k's times are shifted by k periods of the looped part. The frame
// numbers (seq) restart with each loop: the labels detector finds a frame's
// boxes by them.
class LoopingSource final : public pipeline::FrameSource {
 public:
  LoopingSource(const std::vector<StereoFrame>& frames, const StereoCamera& camera, std::size_t total,
                std::size_t loop_from)
      : frames_(frames), camera_(camera), total_(total), loop_from_(loop_from) {
    const std::int64_t span = frames_.back().t_ns() - frames_.front().t_ns();
    const std::int64_t step =
        frames_.size() > 1 ? span / static_cast<std::int64_t>(frames_.size() - 1) : 100'000'000;
    period_ns_ = frames_.back().t_ns() - frames_[loop_from_].t_ns() + step;
  }
  const StereoCamera& camera() const override { return camera_; }
  std::string describe() const override { return "memory (looped)"; }
  bool live() const override { return false; }
  Expected<pipeline::SourceEvent> next(std::stop_token stop, pipeline::SteadyTime) override {
    if (next_ >= total_ || stop.stop_requested() || interrupted())
      return pipeline::SourceEvent{pipeline::SourceEventKind::kEnd, {}};
    std::size_t index = next_;  // frame.seq stays the recorded index
    std::size_t loop = 0;
    if (next_ >= loop_from_) {
      const std::size_t looped = frames_.size() - loop_from_;
      loop = (next_ - loop_from_) / looped;
      index = loop_from_ + (next_ - loop_from_) % looped;
    }
    StereoFrame frame = frames_[index];
    const std::int64_t shift = static_cast<std::int64_t>(loop) * period_ns_;
    ++next_;
    frame.t_left_ns += shift;
    frame.t_right_ns += shift;
    return pipeline::SourceEvent{pipeline::SourceEventKind::kFrame, std::move(frame)};
  }

 private:
  const std::vector<StereoFrame>& frames_;
  StereoCamera camera_;
  std::size_t total_;
  std::size_t loop_from_;
  std::size_t next_ = 0;
  std::int64_t period_ns_ = 0;
};

// Latencies of the current window (publish thread adds, main thread takes).
class WindowOutput final : public pipeline::PoseOutput {
 public:
  std::string name() const override { return "soak"; }
  Status publish(const pipeline::PosePacket& p) override {
    if (p.from_stall) return ok_status();
    const double ms = publish_latency_ms(p);
    std::lock_guard lock(mutex_);
    window_ms_.push_back(ms);
    ++published_;
    return ok_status();
  }
  Status retry() override { return ok_status(); }
  std::size_t published() const {
    std::lock_guard lock(mutex_);
    return published_;
  }
  std::vector<double> take_window() {
    std::lock_guard lock(mutex_);
    return std::exchange(window_ms_, {});
  }

 private:
  mutable std::mutex mutex_;
  std::vector<double> window_ms_;
  std::size_t published_ = 0;
};

struct Sample {
  std::size_t frames = 0;
  double rss_mb = 0.0;
  std::size_t keyframes = 0, points = 0;
  std::uint64_t drops = 0, track_errors = 0;
  double p99_ms = 0.0;
};

Expected<std::vector<Sample>> soak(const BenchSoakArgs& a, const config::SiteposeConfig& config,
                                   const std::vector<StereoFrame>& frames, const StereoCamera& camera,
                                   double fps, std::FILE* csv) {
  SITEPOSE_TRY(auto tracker, pipeline::SlamPoseTracker::create(camera, config, fps));
  const pipeline::SlamPoseTracker* slam = tracker.get();
  auto output = std::make_unique<WindowOutput>();
  WindowOutput* window = output.get();
  SITEPOSE_TRY(auto p, make_bench_pipeline(
                           config, camera, a.sequence,
                           std::make_unique<LoopingSource>(frames, camera, static_cast<std::size_t>(a.frames),
                                                           static_cast<std::size_t>(a.loop_from)),
                           std::move(tracker), std::move(output)));
  std::vector<Sample> samples;
  auto take = [&](std::size_t published) {
    const auto h = p->health();
    Sample s{published,
             static_cast<double>(slam::current_rss_bytes()) / 1048576.0,
             slam->keyframe_count(),
             slam->point_count(),
             h.total_drops(),
             h.track_errors,
             slam::summarize(window->take_window()).p99_ms};
    std::fprintf(csv, "%zu,%.1f,%zu,%zu,%llu,%llu,%.1f\n", s.frames, s.rss_mb, s.keyframes, s.points,
                 static_cast<unsigned long long>(s.drops), static_cast<unsigned long long>(s.track_errors),
                 s.p99_ms);
    std::fflush(csv);
    std::printf("frames %zu: RSS %.1f MB, keyframes %zu, points %zu, drops %llu, p99 %.1f ms\n", s.frames,
                s.rss_mb, s.keyframes, s.points, static_cast<unsigned long long>(s.drops), s.p99_ms);
    samples.push_back(s);
  };
  p->start();
  std::size_t next_sample = static_cast<std::size_t>(a.sample_every);
  while (!p->finished()) {
    const std::size_t published = window->published();
    if (published >= next_sample) {
      take(published);
      next_sample += static_cast<std::size_t>(a.sample_every);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  SITEPOSE_TRY_STATUS(p->wait());
  if (samples.empty() || samples.back().frames < window->published()) take(window->published());
  return samples;
}

// The CSV's neighbour: same name, .png.
std::string png_path_of(const std::string& csv) {
  return std::filesystem::path(csv).replace_extension(".png").string();
}

// RSS, map points, keyframes and the frame-to-publish latency p99 of each
// window over the frames, one panel each (their scales differ by orders of
// magnitude), stacked in one image.
Status write_soak_png(const std::string& path, const std::vector<Sample>& samples, const std::string& what) {
  struct Panel {
    const char* title;
    const char* y_label;
    double (*value)(const Sample&);
    cv::Scalar color_bgr;
  };
  const Panel panels[] = {
      {"RSS", "MB", [](const Sample& s) { return s.rss_mb; }, {180, 60, 20}},
      {"map points", "points", [](const Sample& s) { return static_cast<double>(s.points); }, {40, 40, 200}},
      {"keyframes",
       "keyframes",
       [](const Sample& s) { return static_cast<double>(s.keyframes); },
       {40, 150, 40}},
      {"latency p99", "ms", [](const Sample& s) { return s.p99_ms; }, {150, 40, 150}},
  };
  std::vector<cv::Mat> images;
  for (const Panel& panel : panels) {
    experiments::ChartSeries series{panel.title, {}, {}, panel.color_bgr};
    for (const Sample& s : samples) {
      series.x.push_back(static_cast<double>(s.frames));
      series.y.push_back(panel.value(s));
    }
    experiments::ChartOptions options;
    options.title = std::string(panel.title) + ": " + what;
    options.x_label = "frames published";
    options.y_label = panel.y_label;
    options.height_px = 320;
    images.push_back(experiments::render_line_chart({series}, options));
  }
  cv::Mat stacked;
  cv::vconcat(images, stacked);
  return experiments::write_png(path, stacked);
}

// Exit status of the --max-rss-growth check over the samples.
int check_rss_growth(const BenchSoakArgs& a, const std::vector<Sample>& samples) {
  const Sample* warm = nullptr;
  for (const Sample& s : samples) {
    if (s.frames >= static_cast<std::size_t>(a.warmup_frames) && warm == nullptr) warm = &s;
  }
  if (warm == nullptr || warm == &samples.back()) {
    return fail(kCommand, "no sample after the warm-up of " + std::to_string(a.warmup_frames) + " frames", 2);
  }
  const double growth_pct = 100.0 * (samples.back().rss_mb / warm->rss_mb - 1.0);
  std::printf(
      "RSS after warm-up (%zu frames) %.1f MB, at the end (%zu frames) %.1f MB: %+.1f %% (limit %.1f %%)\n",
      warm->frames, warm->rss_mb, samples.back().frames, samples.back().rss_mb, growth_pct,
      a.max_rss_growth_pct);
  return growth_pct <= a.max_rss_growth_pct ? 0 : 1;
}

int run_bench_soak(const BenchSoakArgs& a) {
  install_interrupt_handlers();
  auto loaded = load_pipeline_config(a.settings);
  if (!loaded) return fail(kCommand, loaded.error().message, 2);
  config::SiteposeConfig& config = *loaded;
  auto sequence = load_memory_sequence(a.sequence, 0);
  if (!sequence) return fail(kCommand, sequence.error().message, 2);
  const std::vector<StereoFrame>& frames = sequence->frames;
  if (frames.empty()) return fail(kCommand, a.sequence + ": no frames", 2);
  const StereoCamera camera = config.camera.stereo ? *config.camera.stereo : sequence->camera;
  if (static_cast<std::size_t>(a.loop_from) >= frames.size()) {
    return fail(kCommand,
                "--loop-from " + std::to_string(a.loop_from) + ": the sequence has " +
                    std::to_string(frames.size()) + " frames",
                2);
  }
  std::FILE* csv = std::fopen(a.csv.c_str(), "w");
  if (csv == nullptr) return fail(kCommand, a.csv + ": cannot write", 2);
  std::fprintf(csv, "frames,rss_mb,keyframes,map_points,drops,track_errors,latency_p99_ms\n");
  std::printf("soak: %d frames, looping frames %d-%zu of %s, dynamic.mode %s\n", a.frames, a.loop_from,
              frames.size() - 1, a.sequence.c_str(), config::to_string(config.dynamic.mode));
  auto samples = soak(a, config, frames, camera, sequence->recorded_fps, csv);
  const bool written = std::ferror(csv) == 0;
  if (std::fclose(csv) != 0 || !written) return fail(kCommand, a.csv + ": write failed", 1);
  if (!samples) return fail(kCommand, samples.error().message, 1);
  const std::size_t done = samples->empty() ? 0 : samples->back().frames;
  const bool partial = interrupted() && done < static_cast<std::size_t>(a.frames);
  const std::string png = png_path_of(a.csv);
  const std::string what =
      std::to_string(done) + " frames looping " + std::filesystem::path(a.sequence).filename().string() +
      ", dynamic.mode " + config::to_string(config.dynamic.mode) + (partial ? " (interrupted: partial)" : "");
  if (auto st = write_soak_png(png, *samples, what); !st) return fail(kCommand, st.error().message, 1);
  std::printf("soak: %zu of %d frames%s; wrote %s and %s\n", done, a.frames,
              partial ? " (interrupted: partial)" : "", a.csv.c_str(), png.c_str());
  if (partial) return report_interrupted(kCommand, "wrote the CSV rows and the PNG of the frames done");
  if (a.max_rss_growth_pct < 0.0) return 0;
  return check_rss_growth(a, *samples);
}

void add_options(CLI::App& sub, BenchSoakArgs& args) {
  sub.add_option("--sequence", args.sequence,
                 "Sequence directory whose frames from --loop-from on end where they start (e.g. "
                 "`sitepose sim --scenario backforth --frames 432 --out DIR` with --loop-from 216)")
      ->required();
  sub.add_option("--loop-from", args.loop_from,
                 "Frames before this one run once, the rest loop (default 0: the whole sequence); "
                 "backforth is periodic from its second pass (frame 216 at 6 fps) on, its first pass "
                 "starts from standing")
      ->check(CLI::Range(0, 100'000'000));
  sub.add_option("--csv", args.csv, "CSV of the samples; the PNG of them goes beside it (.png)")->required();
  sub.add_option("--config", args.settings.config_path, "sitepose YAML config (default: built-in defaults)");
  sub.add_option("--mode", args.settings.mode,
                 "Masking mode none|bbox|pixel|hierarchical|full (default full)");
  sub.add_option("--frames", args.frames, "Frames to run (default 20000)")->check(CLI::Range(1, 100'000'000));
  sub.add_option("--sample-every", args.sample_every, "Frames between samples (default 1000)")
      ->check(CLI::Range(1, 100'000'000));
  sub.add_option("--warmup-frames", args.warmup_frames,
                 "Frames before the RSS reference of --max-rss-growth (default 2000)")
      ->check(CLI::Range(0, 100'000'000));
  sub.add_option("--max-rss-growth", args.max_rss_growth_pct,
                 "Exit 1 when RSS grows by more than this many percent after the warm-up")
      ->check(CLI::Range(0.0, 1000.0));
}

const CommandRegistrar kBenchSoak{make_command<BenchSoakArgs>(
    "bench", "soak", add_options, run_bench_soak,
    "Daemon pipeline on a looped sequence for many frames: RSS, map size, drops and latency p99 every "
    "--sample-every frames to a CSV; with --max-rss-growth a check on memory growth after the warm-up")};

}  // namespace
}  // namespace sitepose::cli
