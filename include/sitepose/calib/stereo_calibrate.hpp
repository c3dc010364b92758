#pragma once
// Stereo calibration from chessboard views (`sitepose calibrate`): corners by
// cv::findChessboardCorners + cv::cornerSubPix, each camera by
// cv::calibrateCamera, then both jointly by cv::stereoCalibrate (intrinsics
// refined, not fixed) and rectified by cv::stereoRectify.
//
// A view folder holds left/NAME.png and right/NAME.png (the same NAMEs).
// Views where the board is not found in both images are skipped and named.

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "sitepose/calib/calibration_file.hpp"
#include "sitepose/core/expected.hpp"

namespace sitepose::calib {

// A chessboard counted by inner corners (9x6 has 10 x 7 squares).
struct BoardSpec {
  int cols = 0;  // inner corners along a row
  int rows = 0;  // inner corners along a column
  double square_m = 0.0;
};

// "COLSxROWS" (inner corners, each >= 2, not both equal: an asymmetric board
// fixes the orientation) and the square size (> 0 m).
Expected<BoardSpec> parse_board(const std::string& cols_x_rows, double square_m);

// The board's corners in its own plane (z = 0), row by row, metres.
std::vector<cv::Point3f> board_points(const BoardSpec& board);

// Sub-pixel corners of the board in an 8-bit gray image, in
// findChessboardCorners order; empty when the board is not found.
std::vector<cv::Point2f> find_board_corners(const cv::Mat& gray, const BoardSpec& board);

struct CalibrationView {
  std::string name;  // file name without folder, e.g. "000007.png"
  cv::Mat left;      // 8-bit gray
  cv::Mat right;
};

struct ViewResult {
  std::string name;
  bool used = false;
  std::string why_skipped;   // when not used: "board not found in the left image", ...
  double rms_left_px = 0.0;  // when used: the view's reprojection RMS
  double rms_right_px = 0.0;
};

struct CalibrateOptions {
  int min_views = 5;   // fewer usable views: kInvalidArgument
  bool fix_k3 = true;  // radial k3 is poorly observed with few views
  // Called after each view's corner search: done of total, the view's result.
  std::function<void(int done, int total, const ViewResult& view)> progress;
};

struct CalibrationReport {
  StereoCalibration calibration;  // rectification filled
  std::vector<ViewResult> views;  // every view, in input order
  int views_used = 0;
  double rms_left_px = 0.0;  // cv::calibrateCamera of each camera alone
  double rms_right_px = 0.0;
};

// The view names (left/*.png with a right/ twin, sorted). Fails when the
// folder or its left/ right/ folders are missing, a left image has no right
// twin (or the reverse), or there are no views.
Expected<std::vector<std::string>> list_calibration_views(const std::string& dir);

// Calibrates from views given one by one by `load` (so only one pair is in
// memory at a time): load(i) returns view i of `count`. All views must have
// the same size. Fails with kInvalidArgument naming the reason when fewer
// than min_views views show the board in both images.
Expected<CalibrationReport> calibrate_stereo(
    std::size_t count, const std::function<Expected<CalibrationView>(std::size_t)>& load,
    const BoardSpec& board, const CalibrateOptions& options);

// Reads view `name` of a folder (left/NAME, right/NAME as gray).
Expected<CalibrationView> load_calibration_view(const std::string& dir, const std::string& name);

}  // namespace sitepose::calib
