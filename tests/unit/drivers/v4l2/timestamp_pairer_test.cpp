#include "sitepose/drivers/v4l2/timestamp_pairer.hpp"

#include <gtest/gtest.h>

namespace sitepose::drivers::v4l2 {
namespace {

RawFrame at_ms(double t_ms) {
  RawFrame f;
  f.t_ns = static_cast<std::int64_t>(t_ms * 1e6);
  return f;
}

TEST(TimestampPairer, PairsWithinTheToleranceAndCountsTheRest) {
  TimestampPairer pairer(5'000'000, 8);
  // 30 fps, the right camera 1.5 ms late; left frame 2 and right frame 4 lost.
  for (double t : {0.0, 33.3, 100.0, 133.3}) pairer.push(Side::kLeft, at_ms(t));
  for (double t : {1.5, 34.8, 68.2, 101.5}) pairer.push(Side::kRight, at_ms(t));
  std::vector<std::pair<double, double>> pairs;
  while (auto p = pairer.pop()) pairs.emplace_back(p->first.t_ns / 1e6, p->second.t_ns / 1e6);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_DOUBLE_EQ(pairs[0].first, 0.0);
  EXPECT_DOUBLE_EQ(pairs[1].second, 34.8);
  EXPECT_DOUBLE_EQ(pairs[2].first, 100.0);
  EXPECT_EQ(pairer.counts().pairs, 3u);
  EXPECT_EQ(pairer.counts().unpaired_right, 1u);  // 68.2 had no left frame
  EXPECT_EQ(pairer.pending(Side::kLeft), 1u);     // 133.3 waits for its partner
  pairer.push(Side::kRight, at_ms(200.0));
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.counts().unpaired_left, 1u);  // 133.3 can no longer pair
  pairer.reset();
  EXPECT_EQ(pairer.counts().unpaired_right, 2u);
  EXPECT_EQ(pairer.pending(Side::kRight), 0u);
}

TEST(TimestampPairer, BoundsTheFramesWaitingForASilentSide) {
  TimestampPairer pairer(1'000'000, 3);
  for (int i = 0; i < 10; ++i) pairer.push(Side::kLeft, at_ms(i * 33.3));
  EXPECT_EQ(pairer.pending(Side::kLeft), 3u);
  EXPECT_EQ(pairer.counts().unpaired_left, 7u);
  EXPECT_FALSE(pairer.pop());
}

}  // namespace
}  // namespace sitepose::drivers::v4l2
