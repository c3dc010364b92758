#pragma once
// The paper's two-pass coarse-to-fine tracking with its dynamic layer
// (METHOD.md "Two-pass coarse-to-fine tracking"): the masking modes of
// SlamSystem (bbox, pixel, hierarchical, full). Per frame:
//
//   mask       Algorithm 1; keypoints extracted once, each tagged with the
//              instance under it.
//   pass 1     a pose from the background keypoints. Mode full: when the
//              background alone gives none, again with the objects that were
//              static up to the last frame.
//   classify   (full) Algorithm 2 with pass 1's pose.
//   map check  (full, sitepose classifier) the objects called static against
//              their own map points; one that fails is masked again.
//   pass 2     (full) from pass 1's pose, the static objects' keypoints added.
//   gate       (full) pass 2 is used only if it agrees with pass 1 within
//              pass 1's uncertainty; then it keeps what pass 1 found.
//   commit     the chosen pass to the tracker (motion model, keyframes), and
//              (full) the frame with its final pose to the classifier's ring.
//
// The steps live where they belong: tracking::Tracker estimates and commits,
// dynamic/ masks, classifies and gates; this class only orders them.
// Thread: one thread, like the tracker it drives.

#include <optional>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/dynamic/masking.hpp"
#include "sitepose/dynamic/motion_classifier.hpp"
#include "sitepose/dynamic/two_pass.hpp"
#include "sitepose/slam/frame_report.hpp"
#include "sitepose/tracking/tracker.hpp"

namespace sitepose::slam {

class TwoPassTracker {
 public:
  // fps: the source's frame rate (the classifier's reference offset).
  // trace: fill FrameReport::trace's keypoints and boxes.
  TwoPassTracker(tracking::Tracker& tracker, const StereoCamera& camera, const config::SiteposeConfig& config,
                 double fps, bool trace = false);

  // One frame in config.dynamic.mode (not none). Errors: those of
  // dynamic::build_mask and Tracker::prepare.
  Expected<FrameReport> process(const StereoFrame& frame, const dynamic::FrameObjects& objects);

 private:
  // The two passes of one frame and the keypoints each used.
  struct Passes {
    dynamic::KeypointMask usable1;
    tracking::PassResult pass1;
    dynamic::KeypointMask usable2;
    tracking::PassResult pass2;
    bool pass2_used = false;
    int static_objects = 0;  // unmasked for pass 2

    const tracking::PassResult& final_pass() const { return pass2_used ? pass2 : pass1; }
    const dynamic::KeypointMask& final_usable() const { return pass2_used ? usable2 : usable1; }
  };

  bool full() const { return config_.mode == config::MaskingMode::kFull; }

  Expected<dynamic::MaskResult> build_mask(const StereoFrame& frame, const dynamic::FrameObjects& objects,
                                           FrameReport& report) const;
  Passes track_pass1(const tracking::PreparedFrame& prepared, FrameReport& report) const;
  dynamic::ObjectFeatures classify(const tracking::PreparedFrame& prepared, const dynamic::MaskResult& mask,
                                   const tracking::PassResult& pass1, FrameReport& report);
  dynamic::InstanceSet check_against_map(const tracking::PreparedFrame& prepared,
                                         const tracking::PassResult& pass1,
                                         const dynamic::ObjectFeatures& current, FrameReport& report);
  void track_pass2(const tracking::PreparedFrame& prepared, const dynamic::InstanceSet& static_objects,
                   Passes& passes, FrameReport& report) const;
  void commit(const tracking::PreparedFrame& prepared, const Passes& passes, FrameReport& report);
  void remember(const tracking::PreparedFrame& prepared, const dynamic::MaskResult& mask,
                const tracking::PassResult& final_pass, std::optional<dynamic::ObjectFeatures> current,
                const PoseEstimate& pose);

  void fill_trace(const tracking::PreparedFrame& prepared, const dynamic::MaskResult& mask,
                  const Passes& passes, FrameReport& report) const;

  tracking::Tracker& tracker_;
  config::DynamicConfig config_;
  bool trace_ = false;
  dynamic::MotionClassifier classifier_;
};

}  // namespace sitepose::slam
