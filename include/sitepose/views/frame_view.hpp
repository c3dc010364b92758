#pragma once
// One annotated frame of a run (`sitepose view`): the left image with the
// keypoints coloured by pass and object state, the dynamic boxes (and the
// pixel mask when the frame asked for one) with instance id, verdict and
// statistic, a status bar (tracking state, inliers, mar, pixel mask, map),
// and beside it a top view of the trajectory so far against ground truth.
// Pure drawing; thread-safe.

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/se3.hpp"
#include "sitepose/views/debug_record.hpp"

namespace sitepose::views {

// Colours (BGR). Keypoints: background used / not used, on an object judged
// static and used (pass 2), masked (object not judged static), on an object
// judged moving. Boxes and pixel masks: by the object's state.
struct Palette {
  static cv::Scalar background_inlier() { return {80, 220, 80}; }
  static cv::Scalar background_unused() { return {150, 150, 150}; }
  static cv::Scalar static_unmasked() { return {255, 220, 0}; }
  static cv::Scalar masked() { return {0, 160, 255}; }
  static cv::Scalar moving_keypoint() { return {40, 40, 255}; }
  static cv::Scalar moving() { return {255, 0, 255}; }
  static cv::Scalar unknown_object() { return {0, 160, 255}; }
};

// Top-view positions (x right, z forward of the first camera, metres) of the
// estimate and the ground truth, each relative to its pose at the first
// frame both have: the frame the view and the report draw in.
struct TopViewTracks {
  std::vector<std::optional<cv::Point2d>> estimate;      // per record frame; nullopt when LOST
  std::vector<std::optional<cv::Point2d>> ground_truth;  // per record frame; nullopt without GT
  cv::Rect2d bounds;                                     // of every point, both tracks, padded
};

// The smallest box holding `points` (empty box when there are none).
cv::Rect2d bounds_of(const std::vector<cv::Point2d>& points);

// gt: per sequence frame (index = record seq); empty without ground truth.
TopViewTracks top_view_tracks(const DebugRecord& record, const std::vector<std::optional<SE3>>& gt);

// Frame `index` of the record drawn over `left` (CV_8UC1, the run's image
// size). instance_mask: the sequence's CV_16UC1 instance mask for the frame,
// or empty; drawn only where the run used a pixel mask. The result is BGR,
// left.cols + left.rows wide (the top view is a square panel).
cv::Mat render_frame(const cv::Mat& left, const cv::Mat& instance_mask, const DebugRecord& record,
                     std::size_t index, const TopViewTracks& tracks);

// The top-view panel alone, size x size, tracks up to record frame `index`.
cv::Mat render_top_view(const TopViewTracks& tracks, std::size_t index, int size);

}  // namespace sitepose::views
