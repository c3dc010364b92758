#pragma once
// The positioning core as one object: tracker + local mapper (+ the dynamic
// layer when a masking mode is on). `sitepose run`, `sitepose bench track`,
// the demo and the daemon's track stage all drive it the same way:
// process() once per frame, in order, from one thread.
//
// Mapper threading: with `mapper_thread` the local mapper runs on its own
// thread (the daemon); without it, queued keyframes are processed on the
// caller's thread right after the frame that created them, which makes runs
// reproducible (tests, regression thresholds, ablations).

#include <memory>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/map/shared_map.hpp"
#include "sitepose/mapping/local_mapper.hpp"
#include "sitepose/tracking/tracker.hpp"

namespace sitepose::slam {

struct SlamOptions {
  bool mapper_thread = false;
};

// Wall time of each stage of one frame (ms).
struct FrameTimings {
  double extract_left_ms = 0.0;
  double extract_right_ms = 0.0;
  double stereo_match_ms = 0.0;
  double prepare_ms = 0.0;  // extraction + matching (L and R run concurrently)
  double motion_model_ms = 0.0;
  double local_map_ms = 0.0;
  double motion_ba_ms = 0.0;
  double mapping_inline_ms = 0.0;  // local mapping run on this thread (no mapper thread)
  double total_ms = 0.0;           // the whole frame, excluding inline mapping
};

struct FrameReport {
  PoseEstimate pose;
  FrameTimings timings;
};

class SlamSystem {
 public:
  static Expected<std::unique_ptr<SlamSystem>> create(const StereoCamera& camera,
                                                     const config::SiteposeConfig& config,
                                                     const SlamOptions& options = {});
  ~SlamSystem();
  SlamSystem(const SlamSystem&) = delete;
  SlamSystem& operator=(const SlamSystem&) = delete;

  // Frames must come in order of time. Errors are bad input (wrong image
  // size or type); tracking failure is a state in the report, not an error.
  Expected<FrameReport> process(const StereoFrame& frame);

  // Lets the mapper finish its queue (and stops its thread).
  void finish();

  const tracking::TrackerCounters& tracker_counters() const { return tracker_->counters(); }
  mapping::MappingStats mapping_stats() const { return mapper_->stats(); }
  std::size_t keyframe_count() const;
  std::size_t point_count() const;

 private:
  SlamSystem(const StereoCamera& camera, const config::SiteposeConfig& config,
             const SlamOptions& options);

  config::SiteposeConfig config_;
  SlamOptions options_;
  map::SharedMap map_;
  std::unique_ptr<mapping::LocalMapper> mapper_;
  std::unique_ptr<tracking::Tracker> tracker_;
};

}  // namespace sitepose::slam
