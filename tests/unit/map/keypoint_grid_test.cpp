#include "sitepose/map/keypoint_grid.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace sitepose::map {
namespace {

TEST(KeypointGrid, QueryMatchesBruteForce) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 640), v(0, 480);
  std::vector<Eigen::Vector2d> uv;
  std::vector<int> octave;
  for (int i = 0; i < 2000; ++i) {
    uv.emplace_back(u(rng), v(rng));
    octave.push_back(i % 8);
  }
  const KeypointGrid grid(640, 480, uv, octave, 32);
  for (int q = 0; q < 50; ++q) {
    const Eigen::Vector2d c(u(rng), v(rng));
    const double r = 5.0 + q;
    auto got = grid.query(c, r, 2, 5);
    std::vector<int> expected;
    for (int i = 0; i < 2000; ++i) {
      if ((uv[i] - c).norm() <= r && octave[i] >= 2 && octave[i] <= 5) expected.push_back(i);
    }
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, expected);
  }
}

}  // namespace
}  // namespace sitepose::map
