#pragma once
// Stereo calibration from board views (`sitepose calibrate`): corners of a
// chessboard by cv::findChessboardCorners + cv::cornerSubPix, or of a
// ChArUco board by cv::aruco marker detection + corner interpolation; each
// camera by cv::calibrateCamera, then both jointly by cv::stereoCalibrate
// (intrinsics refined, not fixed) and rectified by cv::stereoRectify.
//
// A ChArUco board is found when it is partly hidden or partly outside the
// image: each corner carries its id, and a view uses the corners that both
// cameras see. A chessboard has to be seen whole in both images.
//
// A view folder holds left/NAME.png and right/NAME.png (the same NAMEs).
// Views where the board is not found in both images are skipped and named.

#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/calib/calibration_file.hpp"
#include "sitepose/core/expected.hpp"

namespace sitepose::calib {

enum class BoardKind { kChessboard, kCharuco };

// What a ChArUco board adds to the squares: an ArUco marker of side
// `marker_m` in each white square, from a predefined OpenCV dictionary.
struct CharucoMarkers {
  double marker_m = 0.0;                    // < the square side
  std::string dictionary = "DICT_5X5_100";  // cv::aruco::PREDEFINED_DICTIONARY_NAME without the prefix
};

// A board counted by inner corners (9x6 has 10 x 7 squares), for both kinds.
struct BoardSpec {
  BoardKind kind = BoardKind::kChessboard;
  int cols = 0;  // inner corners along a row
  int rows = 0;  // inner corners along a column
  double square_m = 0.0;
  CharucoMarkers markers;  // kCharuco only
};

// "COLSxROWS" (inner corners, each >= 2) and the square size (> 0 m); a
// chessboard when `markers` is empty, else a ChArUco board. A chessboard
// must not be square (an asymmetric board fixes the orientation; a ChArUco
// board's markers fix it); a ChArUco board needs a known dictionary with at
// least as many markers as the board has white squares, and markers smaller
// than the squares.
Expected<BoardSpec> parse_board(const std::string& cols_x_rows, double square_m,
                                const std::optional<CharucoMarkers>& markers = std::nullopt);

// The dictionary names parse_board accepts, e.g. "DICT_4X4_50".
std::vector<std::string> charuco_dictionary_names();

// The board's inner corners in its own plane (z = 0), metres, indexed by
// corner id: row by row for a chessboard; for a ChArUco board OpenCV's own
// corner positions (cv::aruco::CharucoBoard::chessboardCorners).
std::vector<cv::Point3f> board_points(const BoardSpec& board);

// Corners found in one image: ids index board_points().
struct BoardCorners {
  std::vector<int> ids;
  std::vector<cv::Point2f> points_px;
  bool empty() const { return ids.empty(); }
};

// Sub-pixel corners of the board in an 8-bit gray image; empty when the
// board is not found (a chessboard: not whole; a ChArUco board: no corner).
BoardCorners find_board_corners(const cv::Mat& gray, const BoardSpec& board);

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
  int min_views = 5;  // fewer usable views: kInvalidArgument
  // A ChArUco view is used when both cameras see at least this many of the
  // same corners (enough to fit each camera's board pose robustly).
  int min_common_corners = 8;
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
