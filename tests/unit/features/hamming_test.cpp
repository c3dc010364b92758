#include "sitepose/features/hamming.hpp"

#include <gtest/gtest.h>

#include <bitset>
#include <random>

namespace sitepose::features {
namespace {

int reference_distance(const std::uint8_t* a, const std::uint8_t* b) {
  int d = 0;
  for (int i = 0; i < kDescriptorBytes; ++i) d += static_cast<int>(std::bitset<8>(a[i] ^ b[i]).count());
  return d;
}

TEST(Hamming, MatchesBitByBitCount) {
  std::mt19937 rng(42);
  cv::Mat a(100, kDescriptorBytes, CV_8UC1);
  cv::Mat b(100, kDescriptorBytes, CV_8UC1);
  for (int r = 0; r < 100; ++r) {
    for (int c = 0; c < kDescriptorBytes; ++c) {
      a.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(rng());
      b.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(rng());
    }
  }
  for (int r = 0; r < 100; ++r) {
    EXPECT_EQ(hamming_distance(a, r, b, r), reference_distance(a.ptr(r), b.ptr(r)));
    EXPECT_EQ(hamming_distance(a, r, a, r), 0);
  }
  // Agrees with OpenCV's NORM_HAMMING.
  EXPECT_EQ(hamming_distance(a, 3, b, 7), static_cast<int>(cv::norm(a.row(3), b.row(7), cv::NORM_HAMMING)));
}

TEST(Hamming, ExtremesAndUnalignedRows) {
  std::uint8_t buffer[1 + 2 * kDescriptorBytes] = {};
  std::uint8_t* a = buffer + 1;  // deliberately not 8-byte aligned
  std::uint8_t* b = a + kDescriptorBytes;
  for (int i = 0; i < kDescriptorBytes; ++i) b[i] = 0xFF;
  EXPECT_EQ(hamming_distance(a, b), kDescriptorBits);
  b[5] = 0xFE;
  EXPECT_EQ(hamming_distance(a, b), kDescriptorBits - 1);
  EXPECT_EQ(detail::popcount64(0x8000000000000001ULL), 2);
}

}  // namespace
}  // namespace sitepose::features
