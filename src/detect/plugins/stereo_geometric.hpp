#pragma once
// Weight-free object detector (METHOD.md "Where sitepose goes further"):
// things standing above the ground found from dense disparity.
//
//   1. SGBM disparity at `scale` of the input (left-padded so the left
//      border keeps valid disparities);
//   2. 3D points in the left camera frame; ground plane by RANSAC on points
//      of the lower image half, constrained to a near-horizontal plane below
//      the camera; the previous frame's plane is the fallback;
//   3. object pixels: height above the plane > grow_height_m and depth <=
//      max_range_m; components of those (after a morphological open/close)
//      are kept when they contain >= min_seed_fraction pixels higher than
//      min_height_m, cover >= min_area_fraction of the image, are at least
//      min_height_m tall in metres and stand on the ground (lowest point
//      <= max_foot_height_m, or cut by the bottom image border);
//   4. boxes and pixel masks from the same components; instance ids tracked
//      frame to frame by greedy box IoU (stable ids).
// Units: metres, pixels of the full-size input. Not thread-safe: one frame
// at a time (it keeps the previous boxes and plane).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"

namespace sitepose::detect::plugin {

struct StereoGeometricOptions {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0, baseline_m = 0.0;  // full-size camera
  double scale = 0.5;               // processing resolution / input resolution
  double min_depth_m = 2.5;         // sets the SGBM disparity range
  double max_range_m = 16.0;        // farther pixels are never objects (see the note below)
  double min_height_m = 0.4;        // "clearly above the ground"
  double grow_height_m = 0.2;       // pixels joining an object's component
  double max_height_m = 8.0;        // higher points are structures/noise, not objects
  double max_foot_height_m = 0.6;   // an object's lowest point (it stands on the ground)
  double min_area_fraction = 0.001;   // component area / image area
  double min_seed_fraction = 0.2;     // of a component's pixels above min_height_m
  double plane_inlier_m = 0.08;     // RANSAC distance threshold
  double max_plane_tilt_deg = 30.0; // plane normal vs the camera's up (-y) axis
  double track_iou = 0.3;           // box IoU to keep an instance id
  int seed = 7;                     // RANSAC seed (deterministic output)
};
// max_range_m: in the simulated site the hoarding line stands 18 m from the
// lane and machines work within ~14 m of the camera, so 16 m separates the two.

struct GeometricObject {
  cv::Rect box;           // full-size pixels
  std::uint16_t instance = 0;
  double score = 0.0;     // fraction of the box covered by the object's pixels
};

class StereoGeometric {
 public:
  explicit StereoGeometric(const StereoGeometricOptions& options);
  static Status validate(const StereoGeometricOptions& options);

  // Objects of one frame; remembers their pixel masks for segment().
  Expected<std::vector<GeometricObject>> detect(const cv::Mat& left, const cv::Mat& right,
                                                std::int64_t seq);
  // Writes `instance` into `mask` (full size, CV_16UC1) on the pixels of that
  // object of the last detect() call; kInvalidArgument for another frame.
  Status paint(std::int64_t seq, std::uint16_t instance, cv::Mat& mask) const;

  // Plane n.p + d = 0 in the scaled camera frame (n up, d = camera height), last frame.
  const std::optional<Eigen::Vector4d>& ground_plane() const { return plane_; }

 private:
  cv::Mat disparity(const cv::Mat& left, const cv::Mat& right) const;
  std::optional<Eigen::Vector4d> fit_ground(const cv::Mat& points, const cv::Mat& valid);
  std::uint16_t next_id();

  StereoGeometricOptions options_;
  std::optional<Eigen::Vector4d> plane_;
  std::vector<GeometricObject> previous_;
  std::uint16_t last_id_ = 0;
  std::int64_t last_seq_ = -1;
  cv::Mat last_labels_;                      // CV_32S component labels, scaled size
  std::vector<std::pair<std::uint16_t, int>> last_instance_label_;  // instance -> label
  cv::Size last_input_size_;
};

}  // namespace sitepose::detect::plugin
