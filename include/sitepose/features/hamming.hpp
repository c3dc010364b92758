#pragma once
// Hamming distance between 256-bit ORB descriptors (32 bytes, one row of a
// CV_8UC1 N x 32 cv::Mat). Used by every matcher in sitepose; pure, thread-safe.

#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>

namespace sitepose::features {

inline constexpr int kDescriptorBytes = 32;  // 256-bit rBRIEF
inline constexpr int kDescriptorBits = 8 * kDescriptorBytes;

namespace detail {
// Bit count of a 64-bit word. With -mpopcnt (CPU flags only come from
// presets, STYLE.md §10) the builtin is one instruction; without it GCC would
// call a libgcc routine, so the branch-free SWAR sum is used instead.
inline int popcount64(std::uint64_t x) {
#if defined(__POPCNT__)
  return __builtin_popcountll(x);
#else
  x = x - ((x >> 1) & 0x5555555555555555ULL);
  x = (x & 0x3333333333333333ULL) + ((x >> 2) & 0x3333333333333333ULL);
  x = (x + (x >> 4)) & 0x0f0f0f0f0f0f0f0fULL;
  return static_cast<int>((x * 0x0101010101010101ULL) >> 56);
#endif
}
}  // namespace detail

// Number of differing bits (0..256) of two 32-byte descriptors.
inline int hamming_distance(const std::uint8_t* a, const std::uint8_t* b) {
  int distance = 0;
  for (int word = 0; word < kDescriptorBytes / 8; ++word) {
    std::uint64_t wa = 0;
    std::uint64_t wb = 0;
    std::memcpy(&wa, a + 8 * word, 8);  // memcpy: rows need not be 8-aligned
    std::memcpy(&wb, b + 8 * word, 8);
    distance += detail::popcount64(wa ^ wb);
  }
  return distance;
}

// Row i of `a` against row j of `b` (both N x 32 CV_8UC1).
inline int hamming_distance(const cv::Mat& a, int i, const cv::Mat& b, int j) {
  return hamming_distance(a.ptr<std::uint8_t>(i), b.ptr<std::uint8_t>(j));
}

// The nearest and the second nearest of n candidate descriptors to `d`
// (descriptor_of(i) gives candidate i's 32 bytes). Ties keep the earlier
// candidate; with no candidate, index -1 and both distances
// kDescriptorBits + 1.
struct NearestTwo {
  int index = -1;
  int distance = kDescriptorBits + 1;
  int second_distance = kDescriptorBits + 1;
};

template <typename DescriptorOf>
NearestTwo nearest_two(const std::uint8_t* d, int n, DescriptorOf&& descriptor_of) {
  NearestTwo out;
  for (int i = 0; i < n; ++i) {
    const int distance = hamming_distance(d, descriptor_of(i));
    if (distance < out.distance) {
      out.second_distance = out.distance;
      out.distance = distance;
      out.index = i;
    } else if (distance < out.second_distance) {
      out.second_distance = distance;
    }
  }
  return out;
}

}  // namespace sitepose::features
