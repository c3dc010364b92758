#include "sitepose/drivers/aravis/stereo_pairer.hpp"

#include <gtest/gtest.h>

namespace sitepose::drivers::aravis {
namespace {

constexpr std::int64_t kMs = 1'000'000;

CameraFrame at(std::int64_t host_ms, std::uint64_t id = 0, std::int64_t camera_ms = -1) {
  CameraFrame f;
  f.host_t_ns = host_ms * kMs;
  f.camera_t_ns = (camera_ms < 0 ? host_ms : camera_ms) * kMs;
  f.frame_id = id;
  return f;
}

PairerOptions tolerance_ms(std::int64_t ms) {
  PairerOptions o;
  o.tolerance_ns = ms * kMs;
  return o;
}

TEST(StereoPairer, PairsFramesWithinTheTolerance) {
  StereoPairer pairer(tolerance_ms(2));
  for (int i = 0; i < 5; ++i) {
    pairer.push(Side::kLeft, at(100 + 50 * i, i));
    pairer.push(Side::kRight, at(101 + 50 * i, i));  // 1 ms later
    const auto pair = pairer.pop();
    ASSERT_TRUE(pair) << i;
    EXPECT_EQ(pair->left.frame_id, static_cast<std::uint64_t>(i));
    EXPECT_EQ(pair->right.frame_id, static_cast<std::uint64_t>(i));
  }
  EXPECT_EQ(pairer.counts().pairs, 5u);
  EXPECT_EQ(pairer.counts().unpaired_left + pairer.counts().unpaired_right, 0u);
}

TEST(StereoPairer, WaitsForTheLaterSide) {
  StereoPairer pairer(tolerance_ms(2));
  pairer.push(Side::kLeft, at(100));
  pairer.push(Side::kRight, at(100));
  ASSERT_TRUE(pairer.pop());
  pairer.push(Side::kLeft, at(150));
  pairer.push(Side::kLeft, at(200));
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.pending(Side::kLeft), 2u);
  pairer.push(Side::kRight, at(151));
  EXPECT_TRUE(pairer.pop());
  EXPECT_EQ(pairer.counts().unpaired_left, 0u);
}

TEST(StereoPairer, DropsAndCountsAFrameWhosePartnerWasLost) {
  StereoPairer pairer(tolerance_ms(2));
  pairer.push(Side::kLeft, at(100, 0));
  pairer.push(Side::kRight, at(100, 0));
  ASSERT_TRUE(pairer.pop());
  pairer.push(Side::kLeft, at(150, 1));  // right frame 1 lost on the wire
  pairer.push(Side::kLeft, at(200, 2));
  pairer.push(Side::kRight, at(200, 2));
  const auto pair = pairer.pop();
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->left.frame_id, 2u);
  EXPECT_EQ(pairer.counts().unpaired_left, 1u);
  EXPECT_EQ(pairer.counts().unpaired_right, 0u);
}

TEST(StereoPairer, OffsetBeyondTheToleranceNeverPairs) {
  StereoPairer pairer(tolerance_ms(2));
  pairer.push(Side::kLeft, at(0));
  pairer.push(Side::kRight, at(0));
  ASSERT_TRUE(pairer.pop());
  for (int i = 1; i <= 4; ++i) {
    pairer.push(Side::kLeft, at(50 * i));
    pairer.push(Side::kRight, at(50 * i + 25));  // half a period apart
    EXPECT_FALSE(pairer.pop());
  }
  EXPECT_EQ(pairer.counts().pairs, 1u);
  EXPECT_EQ(pairer.counts().unpaired_left, 4u);  // each left older than the waiting right
}

TEST(StereoPairer, BoundsTheFramesWaitingForASilentSide) {
  PairerOptions o = tolerance_ms(2);
  o.max_pending = 3;
  StereoPairer pairer(o);
  pairer.push(Side::kLeft, at(0));
  pairer.push(Side::kRight, at(0));
  ASSERT_TRUE(pairer.pop());
  for (int i = 0; i < 10; ++i) pairer.push(Side::kLeft, at(100 + 50 * i));  // right went silent
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.pending(Side::kLeft), 3u);
  EXPECT_EQ(pairer.counts().unpaired_left, 7u);
}

TEST(StereoPairer, FramesBeforeTheOtherCameraStartsAreSkippedNotUnpaired) {
  StereoPairer pairer(tolerance_ms(2));
  pairer.push(Side::kLeft, at(0));
  pairer.push(Side::kLeft, at(50));
  pairer.push(Side::kRight, at(100));
  pairer.push(Side::kLeft, at(100));
  EXPECT_TRUE(pairer.pop());
  EXPECT_EQ(pairer.counts().skipped_at_start, 2u);
  EXPECT_EQ(pairer.counts().unpaired_left + pairer.counts().unpaired_right, 0u);
}

TEST(StereoPairer, CameraClockPairsOnCameraTimestamps) {
  PairerOptions o = tolerance_ms(2);
  o.clock = PairClock::kCamera;
  StereoPairer pairer(o);
  // PTP-synchronised cameras, the right image arriving 30 ms later on the host.
  pairer.push(Side::kLeft, at(1000, 1, 500));
  pairer.push(Side::kRight, at(1030, 1, 500));
  EXPECT_TRUE(pairer.pop());
}

TEST(StereoPairer, ResetCountsWaitingFramesAndStartsAfresh) {
  StereoPairer pairer(tolerance_ms(2));
  pairer.push(Side::kLeft, at(0));
  pairer.push(Side::kRight, at(0));
  ASSERT_TRUE(pairer.pop());
  pairer.push(Side::kLeft, at(50));
  pairer.reset();
  EXPECT_EQ(pairer.counts().unpaired_left, 1u);
  pairer.push(Side::kLeft, at(100));  // the right camera comes back only later
  pairer.push(Side::kRight, at(200));
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.counts().skipped_at_start, 1u);
  EXPECT_EQ(pairer.counts().unpaired_left, 1u);
}

}  // namespace
}  // namespace sitepose::drivers::aravis
