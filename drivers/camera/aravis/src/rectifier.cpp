#include "sitepose/drivers/aravis/rectifier.hpp"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "sitepose/io/kitti_calib.hpp"

namespace sitepose::drivers::aravis {
namespace {

Expected<cv::Mat> read_matrix(const cv::FileStorage& fs, const std::string& path, const char* key, int rows,
                              int min_cols, int max_cols) {
  cv::Mat m;
  fs[key] >> m;
  if (m.empty() || m.rows != rows || m.cols < min_cols || m.cols > max_cols) {
    return make_error(
        ErrorCode::kParseError,
        path + ": " + key + ": missing or not a " + std::to_string(rows) + "x" +
            (min_cols == max_cols ? std::to_string(min_cols)
                                  : std::to_string(min_cols) + ".." + std::to_string(max_cols)) +
            " matrix");
  }
  cv::Mat out;
  m.convertTo(out, CV_64F);
  return out;
}

}  // namespace

Expected<StereoCalibration> read_stereo_calibration(const std::string& path) {
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ)) {
      return make_error(ErrorCode::kNotFound, path + ": cannot open the stereo calibration");
    }
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kParseError, path + ": not an OpenCV FileStorage file: " + e.what());
  }
  StereoCalibration c;
  SITEPOSE_TRY(c.K1, read_matrix(fs, path, "K1", 3, 3, 3));
  SITEPOSE_TRY(c.D1, read_matrix(fs, path, "D1", 1, 4, 14));
  SITEPOSE_TRY(c.K2, read_matrix(fs, path, "K2", 3, 3, 3));
  SITEPOSE_TRY(c.D2, read_matrix(fs, path, "D2", 1, 4, 14));
  SITEPOSE_TRY(c.R, read_matrix(fs, path, "R", 3, 3, 3));
  SITEPOSE_TRY(c.T, read_matrix(fs, path, "T", 3, 1, 1));
  fs["image_width"] >> c.width;
  fs["image_height"] >> c.height;
  if (c.width <= 0 || c.height <= 0) {
    return make_error(ErrorCode::kParseError,
                      path + ": image_width and image_height: expected positive integers");
  }
  return c;
}

Expected<Rectifier> Rectifier::from_calibration(const StereoCalibration& c) {
  const cv::Size size(c.width, c.height);
  Rectifier r;
  try {
    cv::Mat R1, R2, P1, P2, Q;
    cv::stereoRectify(c.K1, c.D1, c.K2, c.D2, size, c.R, c.T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY,
                      0.0, size);
    r.camera_.fx = P1.at<double>(0, 0);
    r.camera_.fy = P1.at<double>(1, 1);
    r.camera_.cx = P1.at<double>(0, 2);
    r.camera_.cy = P1.at<double>(1, 2);
    r.camera_.baseline_m = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
    r.camera_.width = c.width;
    r.camera_.height = c.height;
    if (!(r.camera_.baseline_m > 0.0) ||
        std::abs(P2.at<double>(1, 3)) > 1e-6 * std::abs(P2.at<double>(0, 3))) {
      return make_error(
          ErrorCode::kInvalidArgument,
          "stereo calibration: T puts the right camera left of or above the left one; expected a "
          "horizontal pair with the right camera at +x");
    }
    cv::initUndistortRectifyMap(c.K1, c.D1, R1, P1, size, CV_16SC2, r.map_left_a_, r.map_left_b_);
    cv::initUndistortRectifyMap(c.K2, c.D2, R2, P2, size, CV_16SC2, r.map_right_a_, r.map_right_b_);
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kInvalidArgument, std::string("stereo rectification failed: ") + e.what());
  }
  SITEPOSE_TRY_STATUS(r.camera_.validate());
  return r;
}

Rectifier Rectifier::identity(const StereoCamera& camera) {
  Rectifier r;
  r.camera_ = camera;
  return r;
}

Expected<Rectifier> Rectifier::load(const std::string& path, int width, int height) {
  const bool kitti = path.size() > 4 && path.compare(path.size() - 4, 4, ".txt") == 0;
  if (kitti) {
    SITEPOSE_TRY(StereoCamera camera, io::read_kitti_calib(path));
    camera.width = width;
    camera.height = height;
    if (auto st = camera.validate(); !st)
      return make_error(st.error().code, path + ": " + st.error().message);
    return identity(camera);
  }
  SITEPOSE_TRY(const StereoCalibration calibration, read_stereo_calibration(path));
  if (calibration.width != width || calibration.height != height) {
    return make_error(ErrorCode::kInvalidArgument,
                      path + ": calibrated for " + std::to_string(calibration.width) + "x" +
                          std::to_string(calibration.height) + " images, the cameras deliver " +
                          std::to_string(width) + "x" + std::to_string(height));
  }
  auto r = from_calibration(calibration);
  if (!r) return make_error(r.error().code, path + ": " + r.error().message);
  return r;
}

Expected<std::pair<cv::Mat, cv::Mat>> Rectifier::rectify(const cv::Mat& left, const cv::Mat& right) const {
  const cv::Size size(camera_.width, camera_.height);
  if (left.size() != size || right.size() != size) {
    return make_error(ErrorCode::kInvalidArgument,
                      "images " + std::to_string(left.cols) + "x" + std::to_string(left.rows) + " / " +
                          std::to_string(right.cols) + "x" + std::to_string(right.rows) +
                          ": expected the calibrated " + std::to_string(size.width) + "x" +
                          std::to_string(size.height));
  }
  if (!remaps()) return std::pair{left, right};
  std::pair<cv::Mat, cv::Mat> out;
  cv::remap(left, out.first, map_left_a_, map_left_b_, cv::INTER_LINEAR);
  cv::remap(right, out.second, map_right_a_, map_right_b_, cv::INTER_LINEAR);
  return out;
}

}  // namespace sitepose::drivers::aravis
