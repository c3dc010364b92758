#pragma once
// The positioning core as one object: tracker + local mapper + the dynamic
// layer. `sitepose run`, `sitepose bench track`, the demo and the daemon's
// track stage all drive it the same way: process() once per frame, in
// order, from one thread.
//
// Modes (config.dynamic.mode; ARCHITECTURE.md "Inside the track stage"):
//   none          plain stereo SLAM on every keypoint (process(frame)).
//   bbox | pixel | hierarchical
//                 Algorithm 1 mask; one pass on the unmasked keypoints.
//   full          hierarchical mask; pass 1 on the background, motion states
//                 of the objects (Algorithm 2, with pass 1's pose), the
//                 static ones checked against their map points (sitepose
//                 mode; a failed check masks the object again), pass 2
//                 from pass 1's pose with static objects' keypoints added
//                 (used only if it agrees with pass 1 within pass 1's
//                 uncertainty);
//                 new map points from the background and static objects.
//                 When the background alone gives no pose, pass 1 is rerun
//                 with the objects static up to the last frame (fallback).
// Keypoints are extracted once per frame and tagged with the instance under
// them; pass 1 leaves no trace in the tracker (Tracker::estimate is const).
//
// Mapper threading: with `mapper_thread` the local mapper runs on its own
// thread (the daemon); without it, queued keyframes are processed on the
// caller's thread right after the frame that created them, which makes runs
// reproducible (tests, regression thresholds, ablations).

#include <memory>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/dynamic/masking.hpp"
#include "sitepose/dynamic/motion_classifier.hpp"
#include "sitepose/map/shared_map.hpp"
#include "sitepose/mapping/local_mapper.hpp"
#include "sitepose/tracking/tracker.hpp"

namespace sitepose::slam {

struct SlamOptions {
  bool mapper_thread = false;
  // Frame rate of the source; sets the motion classifier's reference offset
  // (paper mode, when dynamic.reference_offset_frames = 0) and ring length.
  double fps = 6.0;
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
  // Dynamic layer (zero in mode none). detect_ms is filled by the caller
  // that ran the detector (it is outside process()) and counted in total_ms
  // only if the caller adds it.
  double detect_ms = 0.0;
  double mask_ms = 0.0;      // Algorithm 1 incl. pixel segmentation
  double classify_ms = 0.0;  // Algorithm 2 (matching + tests) and the map check
  double pass2_ms = 0.0;     // the second pose estimate
  double total_ms = 0.0;     // the whole frame, excluding inline mapping
};

struct FrameReport {
  PoseEstimate pose;
  FrameTimings timings;
  bool dynamic_layer = false;    // process(frame, objects) ran with a masking mode
  double mar = 0.0;              // Algorithm 1's box-union ratio
  double masked_ratio = 0.0;     // pixels actually masked / image
  bool pixel_mask_used = false;  // the segmenter ran this frame
  // Mode full: pass 1 on the background failed and was rerun with the
  // objects still static from earlier frames (a parked machine filling the
  // view); classification then uses that pose.
  bool pass1_with_known_static = false;
  // Mode full: pass 2 (static objects unmasked) moved the pose beyond pass
  // 1's uncertainty and was not used (the pose is pass 1's); those objects
  // keep their state.
  bool pass2_rejected = false;
  // Mode full: objects called static that failed the map check
  // (MotionClassifier::check_against_map) and were masked again.
  int remasked_by_map_check = 0;
  // Mode full: one entry per dynamic-class box of the frame, in box order
  // (states unknown when pass 1 found no pose). Empty in other modes.
  std::vector<dynamic::ClassifiedObject> objects;
};

class SlamSystem {
 public:
  static Expected<std::unique_ptr<SlamSystem>> create(const StereoCamera& camera,
                                                     const config::SiteposeConfig& config,
                                                     const SlamOptions& options = {});
  ~SlamSystem();
  SlamSystem(const SlamSystem&) = delete;
  SlamSystem& operator=(const SlamSystem&) = delete;

  // Plain stereo SLAM on every keypoint (mode none), whatever
  // config.dynamic.mode says. Frames must come in order of time. Errors are
  // bad input (wrong image size or type); tracking failure is a state in
  // the report, not an error.
  Expected<FrameReport> process(const StereoFrame& frame);

  // The frame with its detections, in config.dynamic.mode (see above).
  // objects.segment is called (at most once, during this call) when the
  // mode needs a pixel mask. Errors: those of process(frame), a pixel mask
  // needed without a segmenter (kUnsupported), the segmenter's own error.
  Expected<FrameReport> process(const StereoFrame& frame, const dynamic::FrameObjects& objects);

  config::MaskingMode mode() const { return config_.dynamic.mode; }

  // Lets the mapper finish its queue (and stops its thread).
  void finish();

  const tracking::TrackerCounters& tracker_counters() const { return tracker_->counters(); }
  mapping::MappingStats mapping_stats() const { return mapper_->stats(); }
  std::size_t keyframe_count() const;
  std::size_t point_count() const;

 private:
  SlamSystem(const StereoCamera& camera, const config::SiteposeConfig& config,
             const SlamOptions& options);

  Expected<FrameReport> process_masked(const StereoFrame& frame, const dynamic::FrameObjects& objects);
  Status run_inline_mapping(FrameReport& report);
  // The map check of `instances` (static objects) with pass 1's pose:
  // their keypoints matched to the local map, then the classifier's test.
  std::vector<dynamic::MapCheck> check_against_map(const tracking::PreparedFrame& prepared,
                                                   const tracking::PassResult& pass1,
                                                   const dynamic::ObjectFeatures& current,
                                                   const std::vector<std::uint16_t>& instances);

  config::SiteposeConfig config_;
  SlamOptions options_;
  std::unique_ptr<dynamic::MotionClassifier> classifier_;
  map::SharedMap map_;
  std::unique_ptr<mapping::LocalMapper> mapper_;
  std::unique_ptr<tracking::Tracker> tracker_;
};

}  // namespace sitepose::slam
