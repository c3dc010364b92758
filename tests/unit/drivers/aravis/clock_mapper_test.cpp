#include "sitepose/drivers/aravis/clock_mapper.hpp"

#include <gtest/gtest.h>

namespace sitepose::drivers::aravis {
namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kOffset = 1'700'000'000'000'000'000;  // camera counter starts at 0

TEST(ClockMapper, MapsByTheSmallestArrivalDelay) {
  ClockMapper mapper(16);
  // Arrivals 3, 1, 7, 2 ms after capture: the 1 ms one sets the offset.
  const std::int64_t delays_ms[] = {3, 1, 7, 2};
  std::int64_t last = 0;
  for (int i = 0; i < 4; ++i) {
    const std::int64_t camera = i * 50 * kMs;
    last = mapper.map(camera, kOffset + camera + delays_ms[i] * kMs);
  }
  EXPECT_EQ(mapper.offset_ns(), kOffset + 1 * kMs);
  EXPECT_EQ(last, kOffset + 150 * kMs + 1 * kMs);
}

TEST(ClockMapper, ADelayedFrameDoesNotMoveTheEstimate) {
  ClockMapper mapper(16);
  for (int i = 0; i < 8; ++i) mapper.map(i * 50 * kMs, kOffset + i * 50 * kMs + kMs);
  const std::int64_t late = mapper.map(400 * kMs, kOffset + 400 * kMs + 80 * kMs);
  EXPECT_EQ(late, kOffset + 401 * kMs);
}

TEST(ClockMapper, TheWindowFollowsDrift) {
  ClockMapper mapper(8);
  // The camera's oscillator runs 100 ppm slow: +5 us host time per frame.
  std::int64_t error = 0;
  for (int i = 0; i < 200; ++i) {
    const std::int64_t camera = i * 50 * kMs;
    const std::int64_t host = kOffset + camera + i * 5000 + kMs;
    error = mapper.map(camera, host) - (host - kMs);
  }
  // The mapped time is capture + the 1 ms minimum latency, behind by at most
  // the drift over the window (8 frames x 5 us).
  EXPECT_NEAR(static_cast<double>(error), static_cast<double>(kMs), 8 * 5000.0);
}

TEST(ClockMapper, SettlesAfterItsFramesAndAgainAfterAReset) {
  ClockMapper mapper(16, 3);
  EXPECT_TRUE(mapper.empty());
  for (int i = 0; i < 3; ++i) {
    EXPECT_FALSE(mapper.settled()) << i;
    mapper.map(i * 50 * kMs, kOffset + i * 50 * kMs + kMs);
  }
  EXPECT_TRUE(mapper.settled());
  mapper.reset();
  EXPECT_TRUE(mapper.empty());
  EXPECT_FALSE(mapper.settled());
}

TEST(ClockMapper, ResetForgetsTheOldOffset) {
  ClockMapper mapper;
  mapper.map(0, kOffset);
  mapper.reset();
  EXPECT_EQ(mapper.map(0, 5 * kMs), 5 * kMs);  // a camera counter restarted
}

}  // namespace
}  // namespace sitepose::drivers::aravis
