#include "sitepose/drivers/camera/stereo_pairer.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

namespace sitepose::drivers::camera {
namespace {

constexpr std::int64_t kMs = 1'000'000;

// A frame is its id here; the pairer never looks inside.
using Pairer = StereoPairer<int>;

Pairer tolerance_ms(std::int64_t ms, std::size_t max_pending = 4) { return Pairer(ms * kMs, max_pending); }

TEST(StereoPairer, PairsFramesWithinTheTolerance) {
  Pairer pairer = tolerance_ms(2);
  for (int i = 0; i < 5; ++i) {
    pairer.push(Side::kLeft, (100 + 50 * i) * kMs, i);
    pairer.push(Side::kRight, (101 + 50 * i) * kMs, i);  // 1 ms later
    const auto pair = pairer.pop();
    ASSERT_TRUE(pair) << i;
    EXPECT_EQ(pair->left, i);
    EXPECT_EQ(pair->right, i);
  }
  EXPECT_EQ(pairer.counts().pairs, 5u);
  EXPECT_EQ(pairer.counts().unpaired_left + pairer.counts().unpaired_right, 0u);
}

TEST(StereoPairer, WaitsForTheLaterSide) {
  Pairer pairer = tolerance_ms(2);
  pairer.push(Side::kLeft, 100 * kMs, 0);
  pairer.push(Side::kRight, 100 * kMs, 0);
  ASSERT_TRUE(pairer.pop());
  pairer.push(Side::kLeft, 150 * kMs, 1);
  pairer.push(Side::kLeft, 200 * kMs, 2);
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.pending(Side::kLeft), 2u);
  pairer.push(Side::kRight, 151 * kMs, 1);
  EXPECT_TRUE(pairer.pop());
  EXPECT_EQ(pairer.counts().unpaired_left, 0u);
}

TEST(StereoPairer, DropsAndCountsAFrameWhosePartnerWasLost) {
  Pairer pairer = tolerance_ms(2);
  pairer.push(Side::kLeft, 100 * kMs, 0);
  pairer.push(Side::kRight, 100 * kMs, 0);
  ASSERT_TRUE(pairer.pop());
  pairer.push(Side::kLeft, 150 * kMs, 1);  // right frame 1 lost on the wire
  pairer.push(Side::kLeft, 200 * kMs, 2);
  pairer.push(Side::kRight, 200 * kMs, 2);
  const auto pair = pairer.pop();
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->left, 2);
  EXPECT_EQ(pairer.counts().unpaired_left, 1u);
  EXPECT_EQ(pairer.counts().unpaired_right, 0u);
}

TEST(StereoPairer, PairsAThirtyHertzStreamWithLossesOnBothSides) {
  Pairer pairer(5 * kMs, 8);
  // 30 fps, the right camera 1.5 ms late; left frame 2 and right frame 4 lost.
  const std::vector<double> left_ms = {0.0, 33.3, 100.0, 133.3};
  const std::vector<double> right_ms = {1.5, 34.8, 68.2, 101.5};
  for (std::size_t i = 0; i < left_ms.size(); ++i) {
    pairer.push(Side::kLeft, static_cast<std::int64_t>(left_ms[i] * 1e6), static_cast<int>(i));
  }
  for (std::size_t i = 0; i < right_ms.size(); ++i) {
    pairer.push(Side::kRight, static_cast<std::int64_t>(right_ms[i] * 1e6), static_cast<int>(10 + i));
  }
  std::vector<std::pair<int, int>> pairs;
  while (auto p = pairer.pop()) pairs.emplace_back(p->left, p->right);
  const std::vector<std::pair<int, int>> expected = {{0, 10}, {1, 11}, {2, 13}};
  EXPECT_EQ(pairs, expected);
  EXPECT_EQ(pairer.counts().unpaired_right, 1u);  // 68.2 had no left frame
  EXPECT_EQ(pairer.pending(Side::kLeft), 1u);     // 133.3 waits for its partner
  pairer.push(Side::kRight, 200 * kMs, 14);
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.counts().unpaired_left, 1u);  // 133.3 can no longer pair
}

TEST(StereoPairer, OffsetBeyondTheToleranceNeverPairs) {
  Pairer pairer = tolerance_ms(2);
  pairer.push(Side::kLeft, 0, 0);
  pairer.push(Side::kRight, 0, 0);
  ASSERT_TRUE(pairer.pop());
  for (int i = 1; i <= 4; ++i) {
    pairer.push(Side::kLeft, 50 * i * kMs, i);
    pairer.push(Side::kRight, (50 * i + 25) * kMs, i);  // half a period apart
    EXPECT_FALSE(pairer.pop());
  }
  EXPECT_EQ(pairer.counts().pairs, 1u);
  EXPECT_EQ(pairer.counts().unpaired_left, 4u);  // each left older than the waiting right
}

TEST(StereoPairer, BoundsTheFramesWaitingForASilentSide) {
  Pairer pairer = tolerance_ms(2, 3);
  pairer.push(Side::kLeft, 0, 0);
  pairer.push(Side::kRight, 0, 0);
  ASSERT_TRUE(pairer.pop());
  for (int i = 0; i < 10; ++i) pairer.push(Side::kLeft, (100 + 50 * i) * kMs, i);  // right went silent
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.pending(Side::kLeft), 3u);
  EXPECT_EQ(pairer.counts().unpaired_left, 7u);
}

TEST(StereoPairer, FramesBeforeTheOtherCameraStartsAreSkippedNotUnpaired) {
  Pairer pairer = tolerance_ms(2);
  pairer.push(Side::kLeft, 0, 0);
  pairer.push(Side::kLeft, 50 * kMs, 1);
  pairer.push(Side::kRight, 100 * kMs, 0);
  pairer.push(Side::kLeft, 100 * kMs, 2);
  EXPECT_TRUE(pairer.pop());
  EXPECT_EQ(pairer.counts().skipped_at_start, 2u);
  EXPECT_EQ(pairer.counts().unpaired_left + pairer.counts().unpaired_right, 0u);
}

TEST(StereoPairer, ResetCountsWaitingFramesAndStartsAfresh) {
  Pairer pairer = tolerance_ms(2);
  pairer.push(Side::kLeft, 0, 0);
  pairer.push(Side::kRight, 0, 0);
  ASSERT_TRUE(pairer.pop());
  pairer.push(Side::kLeft, 50 * kMs, 1);
  pairer.reset();
  EXPECT_EQ(pairer.counts().unpaired_left, 1u);
  EXPECT_EQ(pairer.pending(Side::kLeft), 0u);
  pairer.push(Side::kLeft, 100 * kMs, 2);  // the right camera comes back only later
  pairer.push(Side::kRight, 200 * kMs, 2);
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.counts().skipped_at_start, 1u);
  EXPECT_EQ(pairer.counts().unpaired_left, 1u);
}

// The right side's times come from an estimate still settling (its first
// frame arrived 30 ms late): a left frame older than them waits instead of
// being dropped, and pairs once the estimate has come down. Settled, the
// same gap drops the older frame.
TEST(StereoPairer, AFrameOlderThanASettlingSideWaitsForItsEstimate) {
  Pairer pairer = tolerance_ms(2);
  pairer.set_settling(Side::kRight, true);
  pairer.push(Side::kLeft, 101 * kMs, 0);
  pairer.push(Side::kRight, 130 * kMs, 0);
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.pending(Side::kLeft), 1u);
  pairer.shift(Side::kRight, -29 * kMs);  // a frame 1 ms late: the estimate falls by 29 ms
  pairer.push(Side::kRight, 151 * kMs, 1);
  pairer.push(Side::kLeft, 151 * kMs, 1);
  for (int i = 0; i < 2; ++i) {
    const auto pair = pairer.pop();
    ASSERT_TRUE(pair) << i;
    EXPECT_EQ(pair->left, i);
    EXPECT_EQ(pair->right, i);
  }
  pairer.set_settling(Side::kRight, false);
  pairer.push(Side::kLeft, 201 * kMs, 2);
  pairer.push(Side::kRight, 230 * kMs, 2);
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.pending(Side::kLeft), 0u);
  EXPECT_EQ(pairer.counts().unpaired_left, 1u);
  EXPECT_EQ(pairer.counts().pairs, 2u);
}

// The wait lasts until max_pending frames of the settling side wait: if they
// do not bring the estimate down, the older frame is dropped.
TEST(StereoPairer, AFrameWaitsForTheSettlingSideUpToMaxPending) {
  Pairer pairer = tolerance_ms(2, 3);
  pairer.set_settling(Side::kRight, true);
  pairer.push(Side::kLeft, 101 * kMs, 0);
  for (int i = 0; i < 2; ++i) {
    pairer.push(Side::kRight, (130 + 50 * i) * kMs, i);
    EXPECT_FALSE(pairer.pop()) << i;
    EXPECT_EQ(pairer.pending(Side::kLeft), 1u) << i;
  }
  pairer.push(Side::kRight, 230 * kMs, 2);
  EXPECT_FALSE(pairer.pop());
  EXPECT_EQ(pairer.pending(Side::kLeft), 0u);
  EXPECT_EQ(pairer.pending(Side::kRight), 3u);
  EXPECT_EQ(pairer.counts().skipped_at_start, 1u);
}

TEST(StereoPairer, KeepsMoveOnlyFrames) {
  StereoPairer<std::unique_ptr<int>> pairer(kMs, 2);
  pairer.push(Side::kLeft, 0, std::make_unique<int>(1));
  pairer.push(Side::kRight, 0, std::make_unique<int>(2));
  const auto pair = pairer.pop();
  ASSERT_TRUE(pair);
  EXPECT_EQ(*pair->left, 1);
  EXPECT_EQ(*pair->right, 2);
}

}  // namespace
}  // namespace sitepose::drivers::camera
