#include "sitepose/calib/calibration_file.hpp"

#include <filesystem>
#include <opencv2/calib3d.hpp>

namespace sitepose::calib {

namespace {

bool has_shape(const cv::Mat& m, int rows, int cols) {
  return !m.empty() && m.type() == CV_64F && m.rows == rows && m.cols == cols;
}

bool valid_distortion(const cv::Mat& d) {
  if (d.empty() || d.type() != CV_64F || (d.rows != 1 && d.cols != 1)) return false;
  const int n = static_cast<int>(d.total());
  return n == 4 || n == 5 || n == 8 || n == 12 || n == 14;
}

std::string shape_text(const cv::Mat& m) {
  if (m.empty()) return "missing";
  return std::to_string(m.rows) + "x" + std::to_string(m.cols) +
         (m.depth() == CV_64F ? " double" : " (not double)");
}

// Reads matrix `key`: a missing key stays empty (validate() names it).
Expected<cv::Mat> read_matrix(const cv::FileStorage& fs, const std::string& key, const std::string& path) {
  const cv::FileNode node = fs[key];
  if (node.empty() || node.isNone()) return cv::Mat();
  cv::Mat m;
  try {
    node >> m;
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kParseError,
                      "calibration " + path + ": " + key + " is not an OpenCV matrix: " + e.what());
  }
  if (m.empty()) {
    return make_error(ErrorCode::kParseError,
                      "calibration " + path + ": " + key + " is not an OpenCV matrix (!!opencv-matrix)");
  }
  cv::Mat out;
  m.convertTo(out, CV_64F);
  return out;
}

}  // namespace

Status validate(const StereoCalibration& c) {
  std::string bad;
  auto need = [&bad](bool ok, const std::string& what) {
    if (!ok) bad += (bad.empty() ? "" : "; ") + what;
  };
  need(c.image_size.width > 0 && c.image_size.height > 0, "image size " + std::to_string(c.image_size.width) +
                                                              "x" + std::to_string(c.image_size.height) +
                                                              " must be positive");
  need(has_shape(c.K1, 3, 3), "K1 must be a 3x3 double matrix, is " + shape_text(c.K1));
  need(has_shape(c.K2, 3, 3), "K2 must be a 3x3 double matrix, is " + shape_text(c.K2));
  need(valid_distortion(c.D1), "D1 must hold 4, 5, 8, 12 or 14 doubles, is " + shape_text(c.D1));
  need(valid_distortion(c.D2), "D2 must hold 4, 5, 8, 12 or 14 doubles, is " + shape_text(c.D2));
  need(has_shape(c.R, 3, 3), "R must be a 3x3 double matrix, is " + shape_text(c.R));
  need(has_shape(c.T, 3, 1) || has_shape(c.T, 1, 3), "T must hold 3 doubles, is " + shape_text(c.T));
  if (!bad.empty()) return make_error(ErrorCode::kInvalidArgument, bad);
  for (const auto* k : {&c.K1, &c.K2}) {
    if (!(k->at<double>(0, 0) > 0.0 && k->at<double>(1, 1) > 0.0)) {
      return make_error(ErrorCode::kInvalidArgument, "focal lengths in K1 and K2 must be positive");
    }
  }
  if (!(cv::norm(c.T) > 0.0)) {
    return make_error(ErrorCode::kInvalidArgument, "T (the baseline) must not be zero");
  }
  return ok_status();
}

Status compute_rectification(StereoCalibration& c) {
  SITEPOSE_TRY_STATUS(validate(c));
  try {
    cv::stereoRectify(c.K1, c.D1, c.K2, c.D2, c.image_size, c.R, c.T.reshape(1, 3), c.R1, c.R2, c.P1, c.P2,
                      c.Q, cv::CALIB_ZERO_DISPARITY, 0.0);
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kInvalidArgument, std::string("cv::stereoRectify failed: ") + e.what());
  }
  return ok_status();
}

Status write_stereo_calibration(const std::string& path, const StereoCalibration& c) {
  SITEPOSE_TRY_STATUS(validate(c));
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) {
      return make_error(ErrorCode::kIoError, "calibration " + path + ": cannot open for writing");
    }
    fs.writeComment(
        "sitepose stereo calibration: x_right = R x_left + T (T in metres); "
        "R1 R2 P1 P2 Q from cv::stereoRectify");
    fs << "image_width" << c.image_size.width << "image_height" << c.image_size.height;
    fs << "K1" << c.K1 << "D1" << c.D1 << "K2" << c.K2 << "D2" << c.D2;
    fs << "R" << c.R << "T" << c.T.reshape(1, 3);
    if (!c.P1.empty()) fs << "R1" << c.R1 << "R2" << c.R2 << "P1" << c.P1 << "P2" << c.P2 << "Q" << c.Q;
    fs << "rms" << c.rms_px;
    fs.release();
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kIoError, "calibration " + path + ": write failed: " + e.what());
  }
  if (!std::filesystem::exists(path)) {
    return make_error(ErrorCode::kIoError, "calibration " + path + ": not written");
  }
  return ok_status();
}

Expected<StereoCalibration> read_stereo_calibration(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) {
    return make_error(ErrorCode::kNotFound, "calibration " + path + ": no such file");
  }
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ)) {
      return make_error(ErrorCode::kParseError, "calibration " + path + ": not an OpenCV YAML file");
    }
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kParseError, "calibration " + path + ": " + e.what());
  }
  StereoCalibration c;
  const cv::FileNode w = fs["image_width"];
  const cv::FileNode h = fs["image_height"];
  if (!w.isInt() || !h.isInt()) {
    return make_error(ErrorCode::kParseError,
                      "calibration " + path + ": image_width and image_height must be integers");
  }
  c.image_size = {static_cast<int>(w), static_cast<int>(h)};
  struct Entry {
    const char* key;
    cv::Mat* m;
  };
  for (const Entry& e : {Entry{"K1", &c.K1}, Entry{"D1", &c.D1}, Entry{"K2", &c.K2}, Entry{"D2", &c.D2},
                         Entry{"R", &c.R}, Entry{"T", &c.T}, Entry{"R1", &c.R1}, Entry{"R2", &c.R2},
                         Entry{"P1", &c.P1}, Entry{"P2", &c.P2}, Entry{"Q", &c.Q}}) {
    SITEPOSE_TRY(*e.m, read_matrix(fs, e.key, path));
  }
  if (fs["rms"].isReal() || fs["rms"].isInt()) c.rms_px = static_cast<double>(fs["rms"]);
  if (!c.T.empty()) c.T = c.T.reshape(1, 3).clone();
  if (auto st = validate(c); !st) {
    return make_error(ErrorCode::kParseError, "calibration " + path + ": " + st.error().message);
  }
  const bool has_rect =
      has_shape(c.R1, 3, 3) && has_shape(c.R2, 3, 3) && has_shape(c.P1, 3, 4) && has_shape(c.P2, 3, 4);
  if (!has_rect) {
    if (auto st = compute_rectification(c); !st) {
      return make_error(ErrorCode::kParseError, "calibration " + path + ": " + st.error().message);
    }
  }
  return c;
}

Expected<StereoCamera> rectified_camera(const StereoCalibration& c) {
  if (!has_shape(c.P1, 3, 4) || !has_shape(c.P2, 3, 4)) {
    return make_error(ErrorCode::kInvalidArgument, "calibration has no rectified P1 P2");
  }
  StereoCamera camera;
  camera.fx = c.P1.at<double>(0, 0);
  camera.fy = c.P1.at<double>(1, 1);
  camera.cx = c.P1.at<double>(0, 2);
  camera.cy = c.P1.at<double>(1, 2);
  camera.baseline_m = -c.P2.at<double>(0, 3) / c.P2.at<double>(0, 0);
  camera.width = c.image_size.width;
  camera.height = c.image_size.height;
  if (auto st = camera.validate(); !st) {
    return make_error(ErrorCode::kInvalidArgument,
                      "calibration gives an implausible rectified camera: " + st.error().message);
  }
  return camera;
}

}  // namespace sitepose::calib
