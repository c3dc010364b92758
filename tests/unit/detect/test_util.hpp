#pragma once
// Helpers shared by the detect tests: a scratch folder and synthetic frames.

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>
#include <gtest/gtest.h>

#include "sitepose/core/stereo_frame.hpp"

namespace sitepose::detect::test {

// A fresh empty folder named after the running test.
inline std::filesystem::path scratch_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const auto dir = std::filesystem::temp_directory_path() / "sitepose_detect_test" /
                   (std::string(info->test_suite_name()) + "." + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline StereoFrame gray_frame(int width, int height, std::int64_t seq = 0) {
  StereoFrame f;
  f.seq = seq;
  f.t_left_ns = f.t_right_ns = seq * 100'000'000;
  f.left = cv::Mat(height, width, CV_8UC1, cv::Scalar(90));
  f.right = cv::Mat(height, width, CV_8UC1, cv::Scalar(90));
  return f;
}

}  // namespace sitepose::detect::test
