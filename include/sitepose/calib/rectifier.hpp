#pragma once
// Rectifies raw stereo pairs with maps computed once from a calibration
// (cv::initUndistortRectifyMap, fixed-point maps for a fast cv::remap).
// Thread-safety: immutable after create(); rectify() may run concurrently.

#include <opencv2/core.hpp>

#include "sitepose/calib/calibration_file.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::calib {

class StereoRectifier {
 public:
  // Fails when the calibration is invalid.
  static Expected<StereoRectifier> create(const StereoCalibration& calibration);

  // The rectified rig (rectified_camera(calibration)).
  const StereoCamera& camera() const { return camera_; }
  cv::Size image_size() const { return {camera_.width, camera_.height}; }

  // Raw pair (the calibration's size, CV_8UC1) -> rectified pair (new
  // buffers). Fails naming the size or type that does not match.
  Status rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left_out,
                 cv::Mat& right_out) const;

 private:
  StereoCamera camera_;
  cv::Mat left_map1_, left_map2_, right_map1_, right_map2_;
};

}  // namespace sitepose::calib
