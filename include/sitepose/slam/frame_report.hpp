#pragma once
// What SlamSystem::process() reports about one frame.

#include <cstdint>
#include <vector>

#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/dynamic/motion_classifier.hpp"
#include "sitepose/tracking/tracker.hpp"

namespace sitepose::slam {

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
  double mask_ms = 0.0;     // Algorithm 1 incl. pixel segmentation
  double segment_ms = 0.0;  // of mask_ms: the detector's pixel segmentation
  // The mask is made beside the image pyramids: how long the frame waited
  // on it beyond them (features::StereoTimings::mask_overrun_ms), so the
  // segmentation's share of the frame is min(segment_ms, this).
  double mask_overrun_ms = 0.0;
  double classify_ms = 0.0;  // Algorithm 2 (matching + tests) and the map check
  double pass2_ms = 0.0;     // the second pose estimate
  double total_ms = 0.0;     // the whole frame, excluding inline mapping
};

// One left keypoint as the views draw it (FrameTrace).
struct KeypointTrace {
  static constexpr std::uint8_t kUsablePass1 = 1;  // offered to pass 1 (not masked)
  static constexpr std::uint8_t kInlierPass1 = 2;
  static constexpr std::uint8_t kUsablePass2 = 4;  // offered to pass 2 (pass 2 ran)
  static constexpr std::uint8_t kInlierPass2 = 8;
  float u_px = 0.0F;
  float v_px = 0.0F;
  std::uint16_t instance = 0;  // object under the keypoint, 0 = background
  std::uint8_t flags = 0;
};

// What the views need beyond the report (`sitepose run --debug-out`); filled
// only when SlamOptions::trace is set, so plain runs pay nothing.
struct FrameTrace {
  std::vector<KeypointTrace> keypoints;
  std::vector<dynamic::ObjectBox> boxes;  // the mask's dynamic boxes, clipped
  bool pass2_ran = false;
  bool pass2_used = false;
  std::size_t keyframes_in_map = 0;
  std::size_t points_in_map = 0;
  int keyframes_created = 0;  // since the start of the run
  double fill_ms = 0.0;       // time spent filling this trace (not in timings)
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
  FrameTrace trace;  // empty unless SlamOptions::trace
};

// The keypoints of `prepared` with the pass-1 flags of `usable` and `pass`.
inline std::vector<KeypointTrace> trace_keypoints(const tracking::PreparedFrame& prepared,
                                                  const std::vector<std::uint8_t>& usable,
                                                  const tracking::PassResult& pass) {
  std::vector<KeypointTrace> keypoints(prepared.uv_px.size());
  for (std::size_t k = 0; k < keypoints.size(); ++k) {
    KeypointTrace& out = keypoints[k];
    out.u_px = static_cast<float>(prepared.uv_px[k].x());
    out.v_px = static_cast<float>(prepared.uv_px[k].y());
    out.instance = k < prepared.instance.size() ? prepared.instance[k] : 0;
    if (k < usable.size() && usable[k] != 0) out.flags |= KeypointTrace::kUsablePass1;
    if (k < pass.point_of_keypoint.size() && pass.point_of_keypoint[k] != map::kNoPoint) {
      out.flags |= KeypointTrace::kInlierPass1;
    }
  }
  return keypoints;
}

// The extraction timings of `prepared` and the estimate timings of `pass`.
inline void copy_stage_timings(const tracking::PreparedFrame& prepared, const tracking::PassResult& pass,
                               FrameTimings& timings) {
  timings.extract_left_ms = prepared.timings.extract_left_ms;
  timings.extract_right_ms = prepared.timings.extract_right_ms;
  timings.stereo_match_ms = prepared.timings.stereo_match_ms;
  timings.prepare_ms = prepared.timings.total_ms;
  timings.mask_overrun_ms = prepared.timings.mask_overrun_ms;
  timings.motion_model_ms = pass.timings.motion_model_ms;
  timings.local_map_ms = pass.timings.local_map_ms;
  timings.motion_ba_ms = pass.timings.motion_ba_ms;
}

}  // namespace sitepose::slam
