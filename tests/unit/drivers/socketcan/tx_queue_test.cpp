#include "sitepose/drivers/socketcan/tx_queue.hpp"

#include <gtest/gtest.h>

namespace sitepose::drivers::socketcan {
namespace {

std::vector<output::CanFrame> pose(std::uint32_t id, std::size_t n) {
  std::vector<output::CanFrame> frames(n);
  for (std::size_t k = 0; k < n; ++k) {
    frames[k].id = id;
    frames[k].dlc = 1;
    frames[k].data[0] = static_cast<std::uint8_t>(k);
  }
  return frames;
}

TEST(PoseTxQueue, AdmitsWholePosesWithinTheFrameCapacity) {
  PoseTxQueue q(20);
  EXPECT_TRUE(q.fits(20));
  EXPECT_FALSE(q.fits(21));
  q.push(pose(1, 13));
  EXPECT_TRUE(q.fits(7));
  EXPECT_FALSE(q.fits(8));
  q.push(pose(2, 7));
  EXPECT_EQ(q.poses(), 2u);
  EXPECT_EQ(q.frames(), 20u);
}

TEST(PoseTxQueue, HandsOutFramesInOrderAndReturnsAPoseWhenItsLastFrameWent) {
  PoseTxQueue q(20);
  q.push(pose(1, 2));
  q.push(pose(2, 1));
  EXPECT_EQ(q.next_frame().id, 1u);
  EXPECT_FALSE(q.frame_written().has_value());
  EXPECT_EQ(q.next_frame().data[0], 1);
  auto done = q.frame_written();
  ASSERT_TRUE(done.has_value());
  EXPECT_EQ(done->size(), 2u);
  EXPECT_EQ(q.next_frame().id, 2u);
  EXPECT_TRUE(q.frame_written().has_value());
  EXPECT_TRUE(q.empty());
  EXPECT_EQ(q.frames(), 0u);
}

TEST(PoseTxQueue, ClearCountsPosesPartlySentAndFramesNotWritten) {
  PoseTxQueue q(40);
  q.push(pose(1, 13));
  q.push(pose(2, 13));
  for (int k = 0; k < 5; ++k) (void)q.frame_written();
  const auto d = q.clear();
  EXPECT_EQ(d.poses, 2u);
  EXPECT_EQ(d.partially_sent, 1u);
  EXPECT_EQ(d.frames, 21u);
  EXPECT_TRUE(q.empty());
  EXPECT_TRUE(q.fits(40));
}

}  // namespace
}  // namespace sitepose::drivers::socketcan
