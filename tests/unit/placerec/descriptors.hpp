#pragma once
// Synthetic ORB descriptors for the vocabulary tests: random 256-bit rows,
// copies of them, and copies with a few bits flipped.

#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/core.hpp>

namespace sitepose::placerec::testing {

inline cv::Mat random_descriptors(int n, std::mt19937& rng) {
  cv::Mat d(n, 32, CV_8UC1);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < 32; ++c) d.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(rng() & 0xFFU);
  }
  return d;
}

inline cv::Mat flip_bits(const cv::Mat& d, int bits, std::mt19937& rng) {
  cv::Mat out = d.clone();
  for (int r = 0; r < out.rows; ++r) {
    for (int b = 0; b < bits; ++b) {
      const int bit = static_cast<int>(rng() % 256);
      out.at<std::uint8_t>(r, bit / 8) ^= static_cast<std::uint8_t>(1U << (bit % 8));
    }
  }
  return out;
}

// `copies` rows each equal to row `row` of `prototypes`.
inline cv::Mat repeat_row(const cv::Mat& prototypes, int row, int copies) {
  cv::Mat out;
  for (int i = 0; i < copies; ++i) out.push_back(prototypes.row(row));
  return out;
}

}  // namespace sitepose::placerec::testing
