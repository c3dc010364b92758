#pragma once
// ChArUco boards for stereo_calibrate.cpp (private to the calib module):
// the board OpenCV builds from a BoardSpec, its dictionary by name, and the
// corner search; and the corner refinement both board kinds share. OpenCV's
// aruco module stays out of the public headers.

#include <opencv2/aruco/charuco.hpp>
#include <string>
#include <vector>

#include "sitepose/calib/stereo_calibrate.hpp"
#include "sitepose/core/expected.hpp"

namespace sitepose::calib::detail {

// Sub-pixel refinement of board corners in an 8-bit gray image (both board
// kinds): cv::cornerSubPix with a window that grows with the smallest corner
// spacing, a quarter of it, from 5x5 up to 23x23 (half sizes 2..11).
void refine_corners(const cv::Mat& gray, double min_spacing_px, std::vector<cv::Point2f>& corners);

// cv::aruco's predefined dictionary of that name ("DICT_5X5_100"), or
// kInvalidArgument naming the known ones.
Expected<cv::Ptr<cv::aruco::Dictionary>> charuco_dictionary(const std::string& name);

// The board of `board` (cols+1 x rows+1 squares). Expects a spec that
// parse_board accepted.
cv::Ptr<cv::aruco::CharucoBoard> make_charuco_board(const BoardSpec& board);

// Markers detected, then the corners between them interpolated and refined
// to sub-pixel by OpenCV; ids are OpenCV's ChArUco corner ids.
BoardCorners find_charuco_corners(const cv::Mat& gray, const BoardSpec& board);

}  // namespace sitepose::calib::detail
