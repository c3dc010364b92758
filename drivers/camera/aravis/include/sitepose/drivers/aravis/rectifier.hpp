#pragma once
// Rectification of a raw stereo pair, with maps computed once from the
// calibration file. Two kinds of file:
//   - an OpenCV FileStorage YAML of a stereo calibration (what
//     `sitepose calibrate` writes): K1 D1 K2 D2 (3x3, 1xN), R (3x3), T
//     (3x1, metres; p_right = R p_left + T, OpenCV's convention),
//     image_width, image_height. cv::stereoRectify (CALIB_ZERO_DISPARITY,
//     alpha 0) and initUndistortRectifyMap give the maps and the
//     rectified StereoCamera.
//   - a KITTI calib.txt (io/kitti_calib.hpp) of a pair that is already
//     rectified (on the camera or by the rig): no remap; the size is the
//     camera's image size.
// Threads: immutable after create(); rectify() may run on any thread.

#include <opencv2/core.hpp>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::drivers::aravis {

struct StereoCalibration {
  cv::Mat K1, D1, K2, D2, R, T;  // CV_64F
  int width = 0;
  int height = 0;
};

// Errors name the file and the missing or malformed entry.
Expected<StereoCalibration> read_stereo_calibration(const std::string& path);

class Rectifier {
 public:
  // `path` ending in .txt: KITTI, rectified already, images width x height.
  // Otherwise an OpenCV stereo calibration whose image size must equal
  // width x height (the cameras' region of interest).
  static Expected<Rectifier> load(const std::string& path, int width, int height);
  static Expected<Rectifier> from_calibration(const StereoCalibration& calibration);
  // Already rectified images of this camera (no remap).
  static Rectifier identity(const StereoCamera& camera);

  const StereoCamera& camera() const { return camera_; }
  bool remaps() const { return !map_left_a_.empty(); }
  // New images; kInvalidArgument when a size differs from the camera's.
  Expected<std::pair<cv::Mat, cv::Mat>> rectify(const cv::Mat& left, const cv::Mat& right) const;

 private:
  StereoCamera camera_;
  cv::Mat map_left_a_, map_left_b_, map_right_a_, map_right_b_;
};

}  // namespace sitepose::drivers::aravis
