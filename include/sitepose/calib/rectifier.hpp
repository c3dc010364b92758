#pragma once
// Rectifies raw stereo pairs with maps computed once from a calibration
// (cv::initUndistortRectifyMap, fixed-point maps for a fast cv::remap), or
// passes through the pairs of a rig that is rectified already (on the
// camera, by the rig's firmware; a KITTI calib.txt describes it).
// Thread-safety: immutable after create(); rectify() may run concurrently.

#include <opencv2/core.hpp>
#include <string>

#include "sitepose/calib/calibration_file.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::calib {

class StereoRectifier {
 public:
  // Fails when the calibration is invalid.
  static Expected<StereoRectifier> create(const StereoCalibration& calibration);
  // Images that are rectified already, in `camera` (size included): no remap.
  static StereoRectifier identity(const StereoCamera& camera);

  // The rectified rig (rectified_camera(calibration)).
  const StereoCamera& camera() const { return camera_; }
  cv::Size image_size() const { return {camera_.width, camera_.height}; }
  bool remaps() const { return !left_map1_.empty(); }

  // Raw pair (the calibration's size, CV_8UC1) -> rectified pair (new
  // buffers; the inputs themselves when nothing is remapped). Fails naming
  // the size or type that does not match.
  Status rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left_out,
                 cv::Mat& right_out) const;

 private:
  StereoCamera camera_;
  cv::Mat left_map1_, left_map2_, right_map1_, right_map2_;
};

// The rectifier of a camera source whose cameras deliver `image_size`
// images. `path` ending in .txt: a KITTI calib.txt of an already rectified
// rig (io/kitti_calib.hpp; identity). Otherwise the calibration file above,
// whose image size must equal image_size. Errors name the file (kNotFound
// for a missing one).
Expected<StereoRectifier> load_stereo_rectifier(const std::string& path, cv::Size image_size);

}  // namespace sitepose::calib
