#pragma once
// Plain types of the dynamic layer: what a detector reports about one object
// in the left image, and what the motion-state classifier concludes.
// The `detect` module comes after `dynamic` in the module order, so the
// dynamic layer defines its own detection type; the slam module converts.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"

namespace sitepose::dynamic {

// One detected object in the LEFT image (pixels).
struct ObjectBox {
  std::uint16_t instance = 0;  // > 0; stable across frames only if the detector says so
  std::string class_name;      // truck, roller, excavator, person, cone, ...
  double score = 1.0;          // detector confidence, [0, 1]
  cv::Rect box;                // left-image pixels
};

// Pixel segmentation of the given boxes: a CV_16UC1 image of the frame's
// size, pixel = instance id of the box it belongs to, 0 = background. Called
// by Algorithm 1 only when the box union is large (mar >= tau_mar).
using PixelSegmenter = std::function<Expected<cv::Mat>(const std::vector<ObjectBox>& boxes)>;

// A frame's detections as the dynamic layer consumes them.
struct FrameObjects {
  std::vector<ObjectBox> boxes;
  PixelSegmenter segment;  // empty = no segmenter available (pixel modes fail)
};

enum class MotionState { kUnknown, kStatic, kMoving };
const char* to_string(MotionState state);

// Why a verdict's state is unknown (kNone when it is not).
enum class UnknownReason {
  kNone,
  kNoReference,   // no reference frame yet, or the object is not in it
  kTooFewPoints,  // fewer than min_object_points matched (or agreeing) points; an
                  // excavator: too few of them on its upper structure
  kAmbiguous,     // the points contradict each other or "static" without proving motion
  kSettling,      // static evidence, not yet long enough to unmask (hysteresis)
};
const char* to_string(UnknownReason reason);

// The classifier's verdict for one object of the current frame.
struct ObjectVerdict {
  std::uint16_t instance = 0;
  std::string class_name;
  MotionState raw = MotionState::kUnknown;    // this frame's test alone
  MotionState state = MotionState::kUnknown;  // after hysteresis (paper mode: = raw)
  // The test statistic: paper mode = fraction of kept points within
  // 3 sigma_bkg; sitepose mode = the 70 % quantile of the points' squared
  // Mahalanobis distances (static when below chi2_static_3dof).
  double score = 0.0;
  // sitepose mode: squared Mahalanobis distance of the object's mean
  // displacement (inlier points), a second test with gate chi2 3 dof 99.9 %.
  double pooled_statistic = 0.0;
  // sitepose mode, objects that were static: the map check's statistic
  // (MotionClassifier::check_against_map); empty when not run.
  std::optional<double> map_statistic;
  int points = 0;          // 3D point pairs the decision used
  int matched_points = 0;  // point pairs matched to the reference object, before any cut
  // sitepose mode: squared Mahalanobis distance of the mean displacement of
  // the points that left the common displacement and move on their own (a
  // slewing house on standing tracks); 0 when there is no such part.
  double part_statistic = 0.0;
  UnknownReason unknown_reason = UnknownReason::kNone;
  std::uint16_t reference_instance = 0;  // associated object in the reference frame, 0 = none
  std::int64_t reference_seq = -1;       // the reference frame, -1 = none
};

}  // namespace sitepose::dynamic
