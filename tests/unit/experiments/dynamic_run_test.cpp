#include <gtest/gtest.h>

#include <vector>

#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/roc.hpp"

namespace sitepose::experiments {
namespace {

ObjectSample make_sample(std::int64_t frame, std::uint16_t instance, bool moving, dynamic::MotionState state,
                         std::vector<double> statistics = {}, int points = 20) {
  ObjectSample s;
  s.object.verdict.points = points;
  s.frame = frame;
  s.moving_gt = moving;
  s.object.verdict.instance = instance;
  s.object.verdict.state = state;
  s.object.statistics = std::move(statistics);
  return s;
}

TEST(DynamicRun, RemaskLatencyCountsFramesFromTheFirstMovingFrame) {
  using dynamic::MotionState;
  std::vector<ObjectSample> samples{
      make_sample(10, 3, false, MotionState::kStatic), make_sample(11, 3, false, MotionState::kStatic),
      make_sample(12, 3, true, MotionState::kStatic),  make_sample(13, 3, true, MotionState::kStatic),
      make_sample(14, 3, true, MotionState::kMoving),  make_sample(15, 3, true, MotionState::kMoving),
      // Instance 4 moves from its first frame: no start event.
      make_sample(10, 4, true, MotionState::kUnknown)};
  const auto events = remask_latencies(samples);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].instance, 3);
  EXPECT_EQ(events[0].start_frame, 12);
  EXPECT_EQ(events[0].latency_frames, 2);
}

TEST(DynamicRun, StaticFlipsIgnoreTheInitialUnknownFrames) {
  using dynamic::MotionState;
  std::vector<ObjectSample> samples{
      make_sample(0, 1, false, MotionState::kUnknown), make_sample(1, 1, false, MotionState::kStatic),
      make_sample(2, 1, false, MotionState::kMoving),  make_sample(3, 1, false, MotionState::kStatic),
      make_sample(0, 2, false, MotionState::kUnknown), make_sample(1, 2, false, MotionState::kStatic)};
  EXPECT_EQ(static_flips(samples, 8), 2);
}

TEST(DynamicRun, StaticFlipsIgnoreLosingTheEvidenceButCountItsReturn) {
  using dynamic::MotionState;
  std::vector<ObjectSample> samples{
      make_sample(0, 1, false, MotionState::kStatic),
      // Leaves the view: unknown with 3 points is no flicker...
      make_sample(1, 1, false, MotionState::kUnknown, {}, 3),
      // ...turning static again is one, and being masked with points another.
      make_sample(2, 1, false, MotionState::kStatic), make_sample(3, 1, false, MotionState::kUnknown, {}, 20)};
  EXPECT_EQ(static_flips(samples, 8), 2);
}

TEST(DynamicRun, RocOfAPerfectSeparatorHasAreaOne) {
  using dynamic::MotionState;
  std::vector<ObjectSample> samples;
  for (int i = 0; i < 10; ++i) {
    samples.push_back(make_sample(i, 1, false, MotionState::kStatic, std::vector<double>(10, 0.1)));
    samples.push_back(make_sample(i, 2, true, MotionState::kMoving, std::vector<double>(10, 5.0)));
  }
  const auto curve = roc_curve(samples, {0.05, 1.0, 10.0}, 0.7, 8);
  ASSERT_EQ(curve.size(), 3u);
  EXPECT_DOUBLE_EQ(curve[0].tpr, 0.0);
  EXPECT_DOUBLE_EQ(curve[1].tpr, 1.0);
  EXPECT_DOUBLE_EQ(curve[1].fpr, 0.0);
  EXPECT_DOUBLE_EQ(curve[2].fpr, 1.0);
  EXPECT_NEAR(roc_auc(curve), 1.0, 1e-12);
  // Too few points: never predicted static.
  samples.push_back(make_sample(0, 3, false, MotionState::kUnknown, std::vector<double>(3, 0.1)));
  EXPECT_LT(roc_curve(samples, {1.0}, 0.7, 8)[0].tpr, 1.0);
}

TEST(DynamicRun, RocAucOfChanceIsOneHalf) {
  EXPECT_NEAR(roc_auc({{1.0, 0.5, 0.5}}), 0.5, 1e-12);
}

}  // namespace
}  // namespace sitepose::experiments
