#pragma once
// A ChArUco board as a planar target for checkerboard.hpp's renderer, drawn
// by OpenCV itself (cv::aruco::CharucoBoard::draw), so the pictures and
// OpenCV's corner ids and positions agree. Needs OpenCV aruco.

#include <opencv2/aruco/charuco.hpp>

#include "sitepose/testing/checkerboard.hpp"

namespace sitepose::testing {

// cols x rows inner corners ((cols+1) x (rows+1) squares), markers of
// `marker_m` from `dictionary`.
inline PlanarTarget charuco_target(int cols, int rows, double square_m, double marker_m,
                                   cv::aruco::PREDEFINED_DICTIONARY_NAME dictionary) {
  constexpr int kPxPerSquare = 60;
  constexpr int kMarginPx = kPxPerSquare;  // one square of white around the board
  const auto board = cv::aruco::CharucoBoard::create(cols + 1, rows + 1, static_cast<float>(square_m),
                                                     static_cast<float>(marker_m),
                                                     cv::aruco::getPredefinedDictionary(dictionary));
  PlanarTarget target;
  // At exactly the board's proportions plus the margins, draw() puts the
  // board's outer corner (OpenCV's board origin) at pixel edge kMarginPx
  // with x and y along the board's: board = (pixel centre + 0.5 - margin) * s.
  board->draw(cv::Size((cols + 1) * kPxPerSquare + 2 * kMarginPx, (rows + 1) * kPxPerSquare + 2 * kMarginPx),
              target.texture, kMarginPx, 1);
  const double s = square_m / kPxPerSquare;
  const double origin = (0.5 - kMarginPx) * s;
  target.texture_to_board = cv::Matx33d(s, 0, origin, 0, s, origin, 0, 0, 1);
  target.centre_on_board = cv::Vec3d((cols + 1) * square_m / 2.0, (rows + 1) * square_m / 2.0, 0.0);
  return target;
}

}  // namespace sitepose::testing
