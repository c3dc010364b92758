#pragma once
// The daemon's pipeline (ARCHITECTURE.md "One frame's way through the
// daemon"): four stages, each a named std::jthread, joined by SPSC rings
// (link.hpp):
//
//   capture ──ring──▶ detect ──ring──▶ track ──ring──▶ publish
//   FrameSource        DetectHook        PoseTracker      PoseOutput...
//
// * capture asks the source for a frame with a deadline of
//   stall_timeout_s; a silent source yields a kStall packet per timeout,
//   which the track stage turns into a LOST pose ("source stalled") so the
//   outputs show it. A source error ends the stream (wait() returns it).
// * Full rings drop the oldest packet and count it, unless the source is
//   not live (FrameSource::live()): then every link blocks (lossless).
// * publish hands each pose to every output in order; a failed output is
//   retried (max_attempts, retry_delay_s) through PoseOutput::retry() and
//   the errors are counted per output. Health goes to the outputs every
//   health_interval_s, and once more at the end.
//
// Stopping: at the end of the stream every captured frame is processed and
// published, then the threads end (finished() turns true). stop() (SIGTERM)
// ends capture at once, lets detect and track finish the packet in hand,
// discards (and counts) frames still queued before them, and publishes
// every pose already tracked. The tracker's finish() runs on the track
// thread before it ends.
//
// Threads: create/start/stop/wait/health from one supervising thread
// (health() and the counters from any thread). The destructor stops and
// joins.

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/pipeline/frame_source.hpp"
#include "sitepose/pipeline/health.hpp"
#include "sitepose/pipeline/hooks.hpp"
#include "sitepose/pipeline/latency_histogram.hpp"
#include "sitepose/pipeline/link.hpp"

namespace sitepose::pipeline {

struct PipelineOptions {
  std::size_t capture_ring_capacity = 4;   // capture -> detect, frames
  std::size_t detect_ring_capacity = 2;    // detect -> track, frames
  std::size_t publish_ring_capacity = 16;  // track -> publish, poses (small)
  double stall_timeout_s = 1.0;            // no frame for this long -> a LOST report
  int publish_max_attempts = 3;            // per output and pose, first try included
  double publish_retry_delay_s = 0.005;    // wait before each retry
  double health_interval_s = 1.0;          // health to the outputs
};

// Every rule, all problems in one message naming the key under `prefix`
// ("pipeline.capture_ring_capacity = 6: must be a power of two ...").
Status check_pipeline_options(const PipelineOptions& options, const std::string& prefix = "pipeline");

class Pipeline {
 public:
  // Fails (kInvalidArgument) when the options break a rule or a hook is
  // missing. Starts nothing.
  static Expected<std::unique_ptr<Pipeline>> create(const PipelineOptions& options,
                                                    std::unique_ptr<FrameSource> source,
                                                    std::unique_ptr<DetectHook> detect,
                                                    std::unique_ptr<PoseTracker> tracker,
                                                    std::vector<std::unique_ptr<PoseOutput>> outputs);
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  // Starts the four threads (once).
  void start();
  // Asks every stage to stop (see above); returns at once. Idempotent.
  void stop();
  // True once all four threads have ended.
  bool finished() const { return threads_done_.load(std::memory_order_acquire) == 4; }
  // Joins the threads (after the end of the stream or stop()). The source's
  // error if it failed, else ok.
  Status wait();

  PipelineHealth health() const;
  std::uint64_t frames_captured() const { return frames_captured_.load(std::memory_order_relaxed); }
  std::uint64_t frames_tracked() const { return frames_tracked_.load(std::memory_order_relaxed); }
  OverflowPolicy overflow_policy() const { return overflow_; }

 private:
  struct OutputSlot {
    std::unique_ptr<PoseOutput> output;
    std::string name;
    std::atomic<std::uint64_t> published{0};
    std::atomic<std::uint64_t> errors{0};
    std::atomic<std::uint64_t> retries{0};
    std::atomic<std::uint64_t> failed{0};
    std::atomic<std::uint64_t> health_errors{0};
  };
  struct StageStats {
    std::atomic<std::uint64_t> items{0};
    LatencyHistogram time;
  };

  Pipeline(const PipelineOptions& options, std::unique_ptr<FrameSource> source,
           std::unique_ptr<DetectHook> detect, std::unique_ptr<PoseTracker> tracker,
           std::vector<std::unique_ptr<PoseOutput>> outputs);

  void capture_loop(const std::stop_token& stop);
  void detect_loop(const std::stop_token& stop);
  void track_loop(const std::stop_token& stop);
  void publish_loop();
  void publish_to(OutputSlot& slot, const PosePacket& packet);
  void publish_health_to_outputs();
  void record_track_rate(SteadyTime now);
  void thread_done() { threads_done_.fetch_add(1, std::memory_order_acq_rel); }

  const PipelineOptions options_;
  const OverflowPolicy overflow_;
  const SteadyTime created_;
  std::unique_ptr<FrameSource> source_;
  std::unique_ptr<DetectHook> detect_;
  std::unique_ptr<PoseTracker> tracker_;
  std::vector<std::unique_ptr<OutputSlot>> outputs_;

  Link<FramePacket> to_detect_;
  Link<FramePacket> to_track_;
  Link<PosePacket> to_publish_;

  StageStats capture_stats_, detect_stats_, track_stats_, publish_stats_;
  LatencyHistogram latency_;
  std::atomic<std::uint64_t> frames_captured_{0};
  std::atomic<std::uint64_t> frames_tracked_{0};
  std::atomic<std::uint64_t> stalls_{0};
  std::atomic<std::uint64_t> detect_errors_{0};
  std::atomic<std::uint64_t> track_errors_{0};
  std::atomic<std::uint64_t> discarded_at_stop_{0};
  std::atomic<std::uint64_t> poses_published_{0};
  std::atomic<bool> source_ended_{false};
  std::atomic<bool> started_{false};
  std::atomic<bool> stop_requested_{false};
  std::atomic<int> threads_done_{0};
  // Frame rate of the track stage: exponentially averaged interval, ns.
  std::atomic<std::int64_t> last_track_ns_{0};
  std::atomic<std::int64_t> track_interval_ns_{0};

  // Written by the capture thread (source error) and the publish thread
  // (last state); read by health()/wait().
  mutable std::mutex mutex_;
  Status source_status_;                        // guarded by mutex_
  TrackingState last_state_ = TrackingState::kLost;  // guarded by mutex_
  std::string last_reason_ = "no pose yet";     // guarded by mutex_

  // Owned by the publish thread.
  SteadyTime last_health_published_{};

  std::jthread capture_thread_, detect_thread_, track_thread_, publish_thread_;
};

}  // namespace sitepose::pipeline
