#include "sitepose/calib/rectifier.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "sitepose/io/kitti_calib.hpp"

namespace sitepose::calib {

namespace {

std::string size_text(cv::Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

Expected<StereoRectifier> StereoRectifier::create(const StereoCalibration& calibration) {
  StereoCalibration c = calibration;
  SITEPOSE_TRY_STATUS(validate(c));
  if (c.P1.empty() || c.P2.empty() || c.R1.empty() || c.R2.empty()) {
    SITEPOSE_TRY_STATUS(compute_rectification(c));
  }
  StereoRectifier r;
  SITEPOSE_TRY(r.camera_, rectified_camera(c));
  cv::initUndistortRectifyMap(c.K1, c.D1, c.R1, c.P1, c.image_size, CV_16SC2, r.left_map1_, r.left_map2_);
  cv::initUndistortRectifyMap(c.K2, c.D2, c.R2, c.P2, c.image_size, CV_16SC2, r.right_map1_, r.right_map2_);
  return r;
}

StereoRectifier StereoRectifier::identity(const StereoCamera& camera) {
  StereoRectifier r;
  r.camera_ = camera;
  return r;
}

Status StereoRectifier::rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left_out,
                                cv::Mat& right_out) const {
  for (const cv::Mat* m : {&left_raw, &right_raw}) {
    if (m->type() != CV_8UC1 || m->cols != camera_.width || m->rows != camera_.height) {
      return make_error(ErrorCode::kInvalidArgument,
                        "rectify: image " + std::to_string(m->cols) + "x" + std::to_string(m->rows) +
                            " type " + std::to_string(m->type()) + ", expected " +
                            std::to_string(camera_.width) + "x" + std::to_string(camera_.height) +
                            " 8-bit gray (the calibration's size)");
    }
  }
  if (!remaps()) {
    left_out = left_raw;
    right_out = right_raw;
    return ok_status();
  }
  left_out = cv::Mat();
  right_out = cv::Mat();
  cv::remap(left_raw, left_out, left_map1_, left_map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  cv::remap(right_raw, right_out, right_map1_, right_map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return ok_status();
}

Expected<StereoRectifier> load_stereo_rectifier(const std::string& path, cv::Size image_size) {
  if (ends_with(path, ".txt")) {
    SITEPOSE_TRY(StereoCamera camera, io::read_kitti_calib(path));
    camera.width = image_size.width;
    camera.height = image_size.height;
    if (auto st = camera.validate(); !st)
      return make_error(st.error().code, path + ": " + st.error().message);
    return StereoRectifier::identity(camera);
  }
  SITEPOSE_TRY(const StereoCalibration calibration, read_stereo_calibration(path));
  if (calibration.image_size != image_size) {
    return make_error(ErrorCode::kInvalidArgument,
                      "calibration " + path + " is for " + size_text(calibration.image_size) +
                          " images, the cameras deliver " + size_text(image_size));
  }
  auto rectifier = StereoRectifier::create(calibration);
  if (!rectifier)
    return make_error(rectifier.error().code, "calibration " + path + ": " + rectifier.error().message);
  return rectifier;
}

}  // namespace sitepose::calib
