#include "charuco.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <opencv2/aruco.hpp>
#include <utility>

namespace sitepose::calib::detail {

using Name = cv::aruco::PREDEFINED_DICTIONARY_NAME;

// The square ArUco dictionaries; AprilTag ones are left out (their small
// sizes and 4x4 codes are a poor fit for calibration boards).
constexpr std::array<std::pair<const char*, Name>, 17> kDictionaries{{
    {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
    {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
    {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
    {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
    {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
    {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
    {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
    {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
    {"DICT_6X6_50", cv::aruco::DICT_6X6_50},
    {"DICT_6X6_100", cv::aruco::DICT_6X6_100},
    {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
    {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
    {"DICT_7X7_50", cv::aruco::DICT_7X7_50},
    {"DICT_7X7_100", cv::aruco::DICT_7X7_100},
    {"DICT_7X7_250", cv::aruco::DICT_7X7_250},
    {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
    {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
}};

namespace {

// OpenCV 4.6's own refinement of the interpolated corners left them about
// half a pixel off (varying with the view) on rendered views whose
// chessboard corners cv::cornerSubPix finds within 0.1 px; so they are
// refined again as a chessboard's are, the spacing taken from neighbours in
// a row (a 5x5 half window when no two neighbours were found).
void refine_like_a_chessboard(const cv::Mat& gray, int cols, BoardCorners& found) {
  constexpr double kUnknownSpacingPx = 20.0;
  std::map<int, cv::Point2f> by_id;
  for (std::size_t i = 0; i < found.ids.size(); ++i) by_id.emplace(found.ids[i], found.points_px[i]);
  double spacing = 1e9;
  for (const auto& [id, point] : by_id) {
    if ((id + 1) % cols == 0) continue;  // the last corner of its row
    const auto next = by_id.find(id + 1);
    if (next != by_id.end()) spacing = std::min(spacing, static_cast<double>(cv::norm(next->second - point)));
  }
  refine_corners(gray, spacing < 1e9 ? spacing : kUnknownSpacingPx, found.points_px);
}

}  // namespace

Expected<cv::Ptr<cv::aruco::Dictionary>> charuco_dictionary(const std::string& name) {
  for (const auto& [known, id] : kDictionaries) {
    if (name == known) return cv::aruco::getPredefinedDictionary(id);
  }
  std::string names;
  for (const std::string& known : charuco_dictionary_names()) names += (names.empty() ? "" : ", ") + known;
  return make_error(ErrorCode::kInvalidArgument,
                    "ChArUco dictionary \"" + name + "\": unknown; one of " + names);
}

cv::Ptr<cv::aruco::CharucoBoard> make_charuco_board(const BoardSpec& board) {
  auto dictionary = charuco_dictionary(board.markers.dictionary);
  if (!dictionary) return {};
  return cv::aruco::CharucoBoard::create(board.cols + 1, board.rows + 1, static_cast<float>(board.square_m),
                                         static_cast<float>(board.markers.marker_m), *dictionary);
}

BoardCorners find_charuco_corners(const cv::Mat& gray, const BoardSpec& board) {
  const cv::Ptr<cv::aruco::CharucoBoard> charuco = make_charuco_board(board);
  if (!charuco) return {};
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  // Marker corners stay unrefined: the board corners interpolated from
  // them are refined to sub-pixel on the chessboard pattern itself, and
  // refining the marker corners first (CORNER_REFINE_SUBPIX) pulled some of
  // those seeds onto the wrong edge (3-4 px errors on rendered views).
  cv::aruco::detectMarkers(gray, charuco->dictionary, marker_corners, marker_ids);
  if (marker_ids.empty()) return {};
  BoardCorners found;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, charuco, found.points_px, found.ids);
  if (found.ids.size() != found.points_px.size() || found.ids.empty()) return {};
  refine_like_a_chessboard(gray, board.cols, found);
  return found;
}

}  // namespace sitepose::calib::detail

namespace sitepose::calib {

std::vector<std::string> charuco_dictionary_names() {
  std::vector<std::string> names;
  names.reserve(detail::kDictionaries.size());
  for (const auto& [known, id] : detail::kDictionaries) names.emplace_back(known);
  return names;
}

}  // namespace sitepose::calib
