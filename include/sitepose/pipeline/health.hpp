#pragma once
// Health of the running pipeline: per-stage counts and processing times,
// ring depths and drops, output errors, tracking state, frame rate and
// frame-to-publish latency. A value snapshot (Pipeline::health()); the
// supervisor logs it and puts it in systemd STATUS= lines, the publish
// stage hands it to the outputs (LCM health_t).

#include <cstdint>
#include <string>
#include <vector>

#include "sitepose/core/pose_estimate.hpp"

namespace sitepose::pipeline {

struct StageHealth {
  std::string name;               // capture, detect, track, publish
  std::uint64_t items = 0;        // packets this stage finished (frames and stall reports)
  std::uint64_t drops = 0;        // dropped at the ring into this stage (full ring: oldest)
  std::uint64_t queue_depth = 0;  // waiting in the ring into this stage now
  // Time per packet (ms, histogram estimate within 4 %). capture: the wait
  // for the source plus reading the frame; the others: pop to push.
  double p50_ms = 0.0;
  double p99_ms = 0.0;
};

struct OutputHealth {
  std::string name;             // e.g. "lcm", "can", "trajectory"
  std::uint64_t published = 0;  // poses this output took in full
  std::uint64_t errors = 0;     // failed publish/retry calls (each attempt counts)
  std::uint64_t retries = 0;    // retry calls made
  std::uint64_t failed = 0;     // poses given up after the last attempt
  std::uint64_t health_errors = 0;  // failed health reports (not retried)
};

struct PipelineHealth {
  std::int64_t uptime_ns = 0;
  bool running = false;       // threads started and not all ended
  bool source_ended = false;  // end of stream or stop
  std::uint64_t frames_captured = 0;
  std::uint64_t frames_tracked = 0;   // frames the tracker answered (not stall reports)
  std::uint64_t stalls = 0;           // stall reports (source silent for stall_timeout)
  std::uint64_t detect_errors = 0;    // hook errors (frame went on unannotated)
  std::uint64_t track_errors = 0;     // frames the tracker rejected (published as LOST)
  std::uint64_t discarded_at_stop = 0;  // frames left in the rings by a stop
  std::uint64_t poses_published = 0;  // packets through the publish stage
  double fps = 0.0;                   // tracked frames per second, recent; 0 when none flow
  double latency_p50_ms = 0.0;        // capture -> every output done, frames only
  double latency_p99_ms = 0.0;
  TrackingState state = TrackingState::kLost;  // of the last published pose
  std::string state_reason;
  std::vector<StageHealth> stages;    // capture, detect, track, publish
  std::vector<OutputHealth> outputs;  // in the order given to the pipeline

  std::uint64_t total_drops() const;
};

// One line for sd_notify STATUS= and the periodic log:
// "OK 29.8 fps, 1234 frames, drops 0/3/0, stalls 0, latency p50 31.0 ms p99 52.3 ms, errors lcm 0 can 2".
std::string format_status(const PipelineHealth& health);

}  // namespace sitepose::pipeline
