// `sitepose bench pipeline`: the daemon's pipeline (capture -> detect ->
// track -> publish threads, SPSC rings, SLAM with its mapper thread) on a
// recorded sequence held in memory (PNG decoding excluded: a camera hands
// over raw pixels). Two runs:
//   1. throughput: the source as fast as the pipeline takes frames
//      (lossless back-pressure) -> frames/s;
//   2. latency: the source paced live at --pace-fps (default 80 % of the
//      measured throughput; a full ring drops its oldest frame) ->
//      frame-to-publish latency p50/p99 (exact, from capture to the end of
//      the publish stage) and drops.
// --source aravis adds a third run beside the second, at the same pace
// (default 30 frames/s): the same frames served by two in-process Aravis
// fake cameras through the Aravis source (pairing, clock mapping, the
// camera stream threads), latency also from the camera timestamp.
// A timing, never pass/fail.

#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "command_config.hpp"
#include "command_registry.hpp"
#include "interrupt.hpp"
#include "pipeline_bench.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/drivers/aravis/aravis_source.hpp"
#include "sitepose/drivers/aravis/fake_stereo_feed.hpp"
#include "sitepose/pipeline/pipeline.hpp"
#include "sitepose/pipeline/slam_tracker.hpp"
#include "sitepose/slam/run_recorder.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "bench pipeline";
using pipeline::SteadyClock;

struct BenchPipelineArgs {
  std::string sequence;
  PipelineConfigArgs settings{.mode = "none"};
  int opencv_threads = 0;
  int frames = 0;
  double pace_fps = 0.0;
  std::string source = "replay";
};

// Frames from memory; live at `fps` (> 0) or as fast as taken (0).
class MemorySource final : public pipeline::FrameSource {
 public:
  MemorySource(const std::vector<StereoFrame>& frames, const StereoCamera& camera, double fps)
      : frames_(frames), camera_(camera), fps_(fps) {}
  const StereoCamera& camera() const override { return camera_; }
  std::string describe() const override { return "memory"; }
  bool live() const override { return fps_ > 0.0; }
  Expected<pipeline::SourceEvent> next(std::stop_token stop, pipeline::SteadyTime deadline) override {
    // Ctrl-C ends the source: the pipeline drains and the figures so far are printed.
    if (next_ >= frames_.size() || stop.stop_requested() || interrupted())
      return pipeline::SourceEvent{pipeline::SourceEventKind::kEnd, {}};
    if (fps_ > 0.0) {
      if (next_ == 0) start_ = SteadyClock::now();
      const auto due = start_ + std::chrono::duration_cast<SteadyClock::duration>(
                                    std::chrono::duration<double>(static_cast<double>(next_) / fps_));
      std::unique_lock lock(mutex_);
      cv_.wait_until(lock, stop, std::min(due, deadline), [] { return false; });
      if (stop.stop_requested()) return pipeline::SourceEvent{pipeline::SourceEventKind::kEnd, {}};
      if (SteadyClock::now() < due) return pipeline::SourceEvent{pipeline::SourceEventKind::kTimeout, {}};
    }
    return pipeline::SourceEvent{pipeline::SourceEventKind::kFrame, frames_[next_++]};
  }

 private:
  const std::vector<StereoFrame>& frames_;
  StereoCamera camera_;
  double fps_;
  std::size_t next_ = 0;
  pipeline::SteadyTime start_{};
  std::mutex mutex_;
  std::condition_variable_any cv_;
};

struct RunResult {
  double wall_s = 0.0;
  std::vector<double> latencies_ms;         // from the source's hand-over to the end of publishing
  std::vector<double> camera_latencies_ms;  // from the frame's time stamp (CLOCK_REALTIME sources)
  int ok = 0;
  pipeline::PipelineHealth health;
  drivers::aravis::AravisSourceStats aravis;
};

// Records the exact latency of each pose (publish thread only; read after
// the pipeline ended).
class LatencyOutput final : public pipeline::PoseOutput {
 public:
  explicit LatencyOutput(RunResult& r, bool realtime_stamps) : r_(r), realtime_stamps_(realtime_stamps) {}
  std::string name() const override { return "latency"; }
  Status publish(const pipeline::PosePacket& p) override {
    if (!p.from_stall) {
      r_.latencies_ms.push_back(publish_latency_ms(p));
      if (realtime_stamps_) {
        const auto now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                                std::chrono::system_clock::now().time_since_epoch())
                                .count();
        r_.camera_latencies_ms.push_back(static_cast<double>(now_ns - p.pose.t_ns) * 1e-6);
      }
      r_.ok += p.pose.state == TrackingState::kOk;
    }
    return ok_status();
  }
  Status retry() override { return ok_status(); }

 private:
  RunResult& r_;
  bool realtime_stamps_;
};

Expected<RunResult> run_once(const std::vector<StereoFrame>& frames, const StereoCamera& camera,
                             const config::SiteposeConfig& config, const std::string& sequence_dir,
                             double recorded_fps, double fps) {
  RunResult r;
  SITEPOSE_TRY(auto tracker, pipeline::SlamPoseTracker::create(camera, config, recorded_fps));
  SITEPOSE_TRY(auto p, make_bench_pipeline(config, camera, sequence_dir,
                                           std::make_unique<MemorySource>(frames, camera, fps),
                                           std::move(tracker), std::make_unique<LatencyOutput>(r, false)));
  const auto t0 = SteadyClock::now();
  p->start();
  SITEPOSE_TRY_STATUS(p->wait());
  r.wall_s = std::chrono::duration<double>(SteadyClock::now() - t0).count();
  r.health = p->health();
  return r;
}

// The frames served by two in-process Aravis fake cameras at `fps` (one
// image per period, then the pipeline is stopped), through the Aravis
// source with a KITTI calibration (no remap, as the in-memory run).
Expected<RunResult> run_aravis(const std::vector<StereoFrame>& frames, const StereoCamera& camera,
                               const config::SiteposeConfig& config, const std::string& sequence_dir,
                               double recorded_fps, double fps) {
  namespace a = drivers::aravis;
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("sitepose-bench-aravis-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string calibration = (dir / "calib.txt").string();
  std::ofstream(calibration) << "P0: " << camera.fx << " 0 " << camera.cx << " 0 0 " << camera.fy << " "
                             << camera.cy << " 0 0 0 1 0\nP1: " << camera.fx << " 0 " << camera.cx << " "
                             << -camera.fx * camera.baseline_m << " 0 " << camera.fy << " " << camera.cy
                             << " 0 0 0 1 0\n";
  std::vector<cv::Mat> left, right;
  for (const StereoFrame& f : frames) {
    left.push_back(f.left);
    right.push_back(f.right);
  }
  a::FakeStereoFeed feed(left, right, fps, a::FakeStereoFeed::Playback::kOnce);
  a::AravisSourceOptions o;
  o.left_id = "Fake_L";
  o.right_id = "Fake_R";
  o.calibration = calibration;
  o.camera.roi = a::Roi{0, 0, camera.width, camera.height};
  o.camera.frame_rate_hz = fps;
  o.camera.exposure_auto = false;
  o.camera.gain_auto = false;
  o.pair_tolerance_ms = 0.4 * 1000.0 / fps;  // the fake cameras wake on the same period boundaries
  auto source = a::AravisSource::open(o, a::aravis_camera_opener(feed.opener_options()));
  std::filesystem::remove_all(dir);
  if (!source) return make_error(source.error().code, "aravis fake cameras: " + source.error().message);
  const a::AravisSource* raw = source->get();
  RunResult r;
  SITEPOSE_TRY(auto tracker, pipeline::SlamPoseTracker::create(camera, config, recorded_fps));
  SITEPOSE_TRY(auto p, make_bench_pipeline(config, camera, sequence_dir, std::move(*source),
                                           std::move(tracker), std::make_unique<LatencyOutput>(r, true)));
  const auto t0 = SteadyClock::now();
  p->start();
  feed.start();
  // Every image once, and half a second for the last ones to come through.
  std::this_thread::sleep_for(std::chrono::duration<double>(static_cast<double>(frames.size()) / fps + 0.5));
  p->stop();
  SITEPOSE_TRY_STATUS(p->wait());
  r.wall_s = std::chrono::duration<double>(SteadyClock::now() - t0).count();
  r.health = p->health();
  r.aravis = raw->stats();  // the capture thread has ended
  return r;
}

void print_latency(const char* what, double pace, const RunResult& r) {
  const auto lat = slam::summarize(r.latencies_ms);
  std::printf(
      "latency (%s at %.1f frames/s): frame-to-publish p50 %.1f ms p99 %.1f ms max %.1f ms, "
      "published %zu, drops %llu, %d OK\n",
      what, pace, lat.p50_ms, lat.p99_ms, lat.max_ms, r.latencies_ms.size(),
      static_cast<unsigned long long>(r.health.total_drops()), r.ok);
}

int run_bench_pipeline(const BenchPipelineArgs& a) {
  install_interrupt_handlers();
  auto loaded = load_pipeline_config(a.settings);
  if (!loaded) return fail(kCommand, loaded.error().message, 2);
  config::SiteposeConfig& config = *loaded;
  // 0 keeps OpenCV's default pool, as siteposed does. (A/B on 2 cores at
  // 30 frames/s, 600 frames: 1 thread did not lower p99 beyond the noise.)
  if (a.opencv_threads > 0) cv::setNumThreads(a.opencv_threads);
  auto sequence = load_memory_sequence(a.sequence, static_cast<std::size_t>(a.frames));
  if (!sequence) return fail(kCommand, sequence.error().message, 2);
  const std::vector<StereoFrame>& frames = sequence->frames;
  const std::size_t n = frames.size();
  const StereoCamera camera = config.camera.stereo ? *config.camera.stereo : sequence->camera;
  const double recorded_fps = sequence->recorded_fps;
  std::printf("sequence %s: %zu frames %dx%d, %u hardware threads, dynamic.mode %s%s\n", a.sequence.c_str(),
              n, camera.width, camera.height, std::thread::hardware_concurrency(),
              config::to_string(config.dynamic.mode),
              config.dynamic.mode == config::MaskingMode::kNone
                  ? ""
                  : (", detector " + config.detector.name).c_str());

  auto fast = run_once(frames, camera, config, a.sequence, recorded_fps, 0.0);
  if (!fast) return fail(kCommand, fast.error().message, 1);
  if (interrupted()) {
    std::printf("throughput (interrupted: partial): %zu frames published in %.1f s\n",
                fast->latencies_ms.size(), fast->wall_s);
    return report_interrupted(kCommand, "printed the figures so far");
  }
  const double fps = static_cast<double>(n) / fast->wall_s;
  const auto fast_lat = slam::summarize(fast->latencies_ms);
  std::printf(
      "throughput (lossless, as fast as possible): %.1f frames/s, %d/%zu OK, track p50 %.1f ms p99 %.1f ms\n",
      fps, fast->ok, n, fast->health.stages[2].p50_ms, fast->health.stages[2].p99_ms);
  std::printf("  latency incl. queueing behind full rings: p50 %.1f ms p99 %.1f ms\n", fast_lat.p50_ms,
              fast_lat.p99_ms);

  const bool aravis = a.source == "aravis";
  const double pace = a.pace_fps > 0.0 ? a.pace_fps : aravis ? 30.0 : 0.8 * fps;
  auto paced = run_once(frames, camera, config, a.sequence, recorded_fps, pace);
  if (!paced) return fail(kCommand, paced.error().message, 1);
  if (interrupted()) std::printf("latency run interrupted: partial\n");
  const auto lat = slam::summarize(paced->latencies_ms);
  print_latency("replay, live source", pace, *paced);
  if (aravis) {
    auto cams = run_aravis(frames, camera, config, a.sequence, recorded_fps, pace);
    if (!cams) return fail(kCommand, cams.error().message, 1);
    print_latency("aravis, two in-process fake cameras", pace, *cams);
    const auto from_camera = slam::summarize(cams->camera_latencies_ms);
    const auto& pairing = cams->aravis.pairing;
    std::printf(
        "  from the camera time stamp: p50 %.1f ms p99 %.1f ms max %.1f ms; pairs %llu, unpaired %llu, "
        "skipped at start %llu, failed buffers %llu, underruns %llu\n",
        from_camera.p50_ms, from_camera.p99_ms, from_camera.max_ms,
        static_cast<unsigned long long>(pairing.pairs),
        static_cast<unsigned long long>(pairing.unpaired_left) +
            static_cast<unsigned long long>(pairing.unpaired_right),
        static_cast<unsigned long long>(pairing.skipped_at_start),
        static_cast<unsigned long long>(cams->aravis.failed_buffers),
        static_cast<unsigned long long>(cams->aravis.underruns));
  }
  std::printf("goal: >= 30 frames/s with p99 <= 60 ms: %s\n",
              fps >= 30.0 && lat.p99_ms <= 60.0 ? "met" : "not met on this machine");
  return interrupted() ? report_interrupted(kCommand, "printed the figures so far") : 0;
}

void add_options(CLI::App& sub, BenchPipelineArgs& args) {
  sub.add_option("--sequence", args.sequence,
                 "Sequence directory (e.g. from `sitepose sim --scenario static --out DIR --frames 120`)")
      ->required();
  sub.add_option("--config", args.settings.config_path, "sitepose YAML config (default: built-in defaults)");
  sub.add_option("--mode", args.settings.mode,
                 "Masking mode none|bbox|pixel|hierarchical|full (default none; other modes run the "
                 "detector in the detect stage, as siteposed does)");
  sub.add_option("--detector", args.settings.detector,
                 "Detector for the masking modes (default: the config's, labels)");
  sub.add_option("--opencv-threads", args.opencv_threads,
                 "OpenCV worker threads (default 0: OpenCV's own pool, as siteposed)")
      ->check(CLI::Range(0, 256));
  sub.add_option("--frames", args.frames, "Use the first N frames (0 = all; all are held in memory)")
      ->check(CLI::Range(0, std::numeric_limits<int>::max()));
  sub.add_option("--pace-fps", args.pace_fps,
                 "Frame rate of the live run (default: 80 % of the measured throughput; 30 with "
                 "--source aravis)");
  sub.add_option("--source", args.source,
                 "replay: the live run from memory; aravis: also the same frames from two in-process "
                 "Aravis fake cameras through the Aravis source, printed beside it")
      ->check(CLI::IsMember({"replay", "aravis"}));
}

const CommandRegistrar kBenchPipeline{make_command<BenchPipelineArgs>(
    "bench", "pipeline", add_options, run_bench_pipeline,
    "Daemon pipeline on a sequence in memory: frames/s (lossless) and frame-to-publish latency "
    "p50/p99 at a live pace (timings, never pass/fail)")};

}  // namespace
}  // namespace sitepose::cli
