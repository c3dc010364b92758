#include "sitepose/calib/stereo_calibrate.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "charuco.hpp"

namespace sitepose::calib {

namespace fs = std::filesystem;

namespace {

// A ChArUco board's own checks: markers inside their squares, and a
// dictionary with a marker for every white square.
Status check_charuco(const BoardSpec& board) {
  const CharucoMarkers& m = board.markers;
  if (!(m.marker_m > 0.0) || !(m.marker_m < board.square_m)) {
    return make_error(ErrorCode::kInvalidArgument, "marker size " + std::to_string(m.marker_m) +
                                                       " m: must be > 0 and smaller than the square (" +
                                                       std::to_string(board.square_m) + " m)");
  }
  SITEPOSE_TRY(const auto dictionary, detail::charuco_dictionary(m.dictionary));
  const int squares = (board.cols + 1) * (board.rows + 1);
  const int markers_needed = squares / 2;
  if (dictionary->bytesList.rows < markers_needed) {
    return make_error(ErrorCode::kInvalidArgument,
                      "ChArUco dictionary " + m.dictionary + " has " +
                          std::to_string(dictionary->bytesList.rows) + " markers; a board of " +
                          std::to_string(board.cols + 1) + "x" + std::to_string(board.rows + 1) +
                          " squares needs " + std::to_string(markers_needed));
  }
  return ok_status();
}

}  // namespace

Expected<BoardSpec> parse_board(const std::string& text, double square_m,
                                const std::optional<CharucoMarkers>& markers) {
  BoardSpec board;
  const auto x = text.find_first_of("xX");
  auto parse_int = [](const std::string& s, int& out) {
    if (s.empty() || s.size() > 4 || !std::all_of(s.begin(), s.end(), ::isdigit)) return false;
    out = std::stoi(s);
    return true;
  };
  if (x == std::string::npos || !parse_int(text.substr(0, x), board.cols) ||
      !parse_int(text.substr(x + 1), board.rows)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "board \"" + text + "\": expected COLSxROWS, inner corners, e.g. 9x6");
  }
  if (board.cols < 2 || board.rows < 2) {
    return make_error(ErrorCode::kInvalidArgument,
                      "board \"" + text + "\": needs at least 2x2 inner corners");
  }
  if (board.cols == board.rows && !markers) {
    return make_error(ErrorCode::kInvalidArgument,
                      "board \"" + text +
                          "\": a square board has an ambiguous orientation; use one with "
                          "different inner-corner counts (e.g. 9x6)");
  }
  if (!(square_m > 0.0) || !std::isfinite(square_m)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "square size " + std::to_string(square_m) + " m: must be > 0");
  }
  board.square_m = square_m;
  if (markers) {
    board.kind = BoardKind::kCharuco;
    board.markers = *markers;
    SITEPOSE_TRY_STATUS(check_charuco(board));
  }
  return board;
}

std::vector<cv::Point3f> board_points(const BoardSpec& board) {
  if (board.kind == BoardKind::kCharuco) {
    const auto charuco = detail::make_charuco_board(board);
    return charuco ? charuco->chessboardCorners : std::vector<cv::Point3f>{};
  }
  std::vector<cv::Point3f> points;
  points.reserve(static_cast<std::size_t>(board.cols) * static_cast<std::size_t>(board.rows));
  for (int r = 0; r < board.rows; ++r) {
    for (int c = 0; c < board.cols; ++c) {
      points.emplace_back(static_cast<float>(c * board.square_m), static_cast<float>(r * board.square_m),
                          0.0f);
    }
  }
  return points;
}

namespace {

std::vector<cv::Point2f> find_chessboard_corners(const cv::Mat& gray, const BoardSpec& board) {
  std::vector<cv::Point2f> corners;
  const cv::Size pattern(board.cols, board.rows);
  const int flags = cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE;
  if (!cv::findChessboardCorners(gray, pattern, corners, flags)) return {};
  double spacing = 1e9;
  for (int r = 0; r < board.rows; ++r) {
    for (int c = 0; c + 1 < board.cols; ++c) {
      const std::size_t i =
          static_cast<std::size_t>(r) * static_cast<std::size_t>(board.cols) + static_cast<std::size_t>(c);
      spacing = std::min(spacing, cv::norm(corners[i + 1] - corners[i]));
    }
  }
  detail::refine_corners(gray, spacing, corners);
  return corners;
}

}  // namespace

void detail::refine_corners(const cv::Mat& gray, double min_spacing_px, std::vector<cv::Point2f>& corners) {
  const int half = std::clamp(static_cast<int>(min_spacing_px / 4.0), 2, 11);
  cv::cornerSubPix(gray, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
}

BoardCorners find_board_corners(const cv::Mat& gray, const BoardSpec& board) {
  if (board.kind == BoardKind::kCharuco) return detail::find_charuco_corners(gray, board);
  BoardCorners found;
  found.points_px = find_chessboard_corners(gray, board);
  found.ids.resize(found.points_px.size());
  for (std::size_t i = 0; i < found.ids.size(); ++i) found.ids[i] = static_cast<int>(i);
  return found;
}

Expected<std::vector<std::string>> list_calibration_views(const std::string& dir) {
  const fs::path left = fs::path(dir) / "left";
  const fs::path right = fs::path(dir) / "right";
  for (const fs::path& p : {fs::path(dir), left, right}) {
    if (!fs::is_directory(p)) {
      return make_error(ErrorCode::kNotFound,
                        "calibration views: no folder " + p.string() + " (expected DIR/left, DIR/right)");
    }
  }
  auto pngs = [](const fs::path& folder) {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(folder)) {
      if (e.is_regular_file() && e.path().extension() == ".png") names.insert(e.path().filename());
    }
    return names;
  };
  const std::set<std::string> l = pngs(left);
  const std::set<std::string> r = pngs(right);
  for (const auto& n : l) {
    if (!r.count(n)) {
      return make_error(ErrorCode::kInvalidArgument,
                        "calibration views: " + (left / n).string() + " has no twin in " + right.string());
    }
  }
  for (const auto& n : r) {
    if (!l.count(n)) {
      return make_error(ErrorCode::kInvalidArgument,
                        "calibration views: " + (right / n).string() + " has no twin in " + left.string());
    }
  }
  if (l.empty()) {
    return make_error(ErrorCode::kInvalidArgument, "calibration views: no .png images in " + left.string());
  }
  return std::vector<std::string>(l.begin(), l.end());
}

Expected<CalibrationView> load_calibration_view(const std::string& dir, const std::string& name) {
  CalibrationView view;
  view.name = name;
  for (auto [side, mat] : {std::pair{"left", &view.left}, std::pair{"right", &view.right}}) {
    const std::string path = (fs::path(dir) / side / name).string();
    *mat = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (mat->empty()) {
      return make_error(ErrorCode::kInvalidArgument, "calibration view " + path + ": cannot read the image");
    }
  }
  return view;
}

}  // namespace sitepose::calib
