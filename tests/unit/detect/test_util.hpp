#pragma once
// Helpers shared by the detect tests: synthetic frames (temp folders:
// sitepose/testing/files.hpp).

#include <opencv2/core.hpp>

#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::detect::test {

inline StereoFrame gray_frame(int width, int height, std::int64_t seq = 0) {
  StereoFrame f;
  f.seq = seq;
  f.t_left_ns = f.t_right_ns = seq * 100'000'000;
  f.left = cv::Mat(height, width, CV_8UC1, cv::Scalar(90));
  f.right = cv::Mat(height, width, CV_8UC1, cv::Scalar(90));
  return f;
}

}  // namespace sitepose::detect::test
