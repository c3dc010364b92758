#include "sitepose/pipeline/pipeline.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "sitepose/testing/pipeline_fakes.hpp"
#include "sitepose/testing/wait.hpp"

namespace sitepose::pipeline {
namespace {

using namespace std::chrono_literals;
using testing::FakeTracker;
using testing::Recording;
using testing::RecordingOutput;
using testing::ScriptedSource;
using Step = ScriptedSource::Step;

std::unique_ptr<Pipeline> make_pipeline(const PipelineOptions& options,
                                        std::unique_ptr<FrameSource> source,
                                        std::unique_ptr<PoseTracker> tracker,
                                        std::vector<std::unique_ptr<PoseOutput>> outputs) {
  auto p = Pipeline::create(options, std::move(source), std::make_unique<PassThroughDetect>(),
                            std::move(tracker), std::move(outputs));
  EXPECT_TRUE(p.has_value()) << (p ? "" : p.error().message);
  return p ? std::move(p).value() : nullptr;
}

std::vector<std::unique_ptr<PoseOutput>> outputs_of(std::unique_ptr<PoseOutput> a,
                                                    std::unique_ptr<PoseOutput> b = nullptr) {
  std::vector<std::unique_ptr<PoseOutput>> v;
  v.push_back(std::move(a));
  if (b) v.push_back(std::move(b));
  return v;
}

TEST(PipelineOptions, ReportsEveryBrokenKey) {
  PipelineOptions o;
  o.capture_ring_capacity = 6;
  o.publish_max_attempts = 0;
  o.stall_timeout_s = 0.0;
  auto st = check_pipeline_options(o);
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("pipeline.capture_ring_capacity = 6"), std::string::npos);
  EXPECT_NE(st.error().message.find("pipeline.publish_max_attempts = 0"), std::string::npos);
  EXPECT_NE(st.error().message.find("pipeline.stall_timeout_s"), std::string::npos);
  EXPECT_TRUE(check_pipeline_options(PipelineOptions{}));
}

TEST(Pipeline, NonLiveSourceIsLosslessAndInOrder) {
  auto rec = std::make_shared<Recording>();
  auto finished = std::make_shared<std::atomic<int>>(0);
  PipelineOptions o;
  o.capture_ring_capacity = 2;
  o.detect_ring_capacity = 2;
  o.publish_ring_capacity = 2;
  // A slow tracker behind a fast source: a dropping pipeline would lose most.
  auto p = make_pipeline(o, std::make_unique<ScriptedSource>(ScriptedSource::frames(60), false),
                         std::make_unique<FakeTracker>(1ms, std::vector<std::int64_t>{}, finished),
                         outputs_of(std::make_unique<RecordingOutput>("rec", rec)));
  ASSERT_TRUE(p);
  EXPECT_EQ(p->overflow_policy(), OverflowPolicy::kBlock);
  p->start();
  ASSERT_TRUE(p->wait());
  EXPECT_TRUE(p->finished());
  ASSERT_EQ(rec->poses.size(), 60u);
  for (std::size_t i = 0; i < rec->poses.size(); ++i) {
    EXPECT_EQ(rec->poses[i].pose.seq, static_cast<std::int64_t>(i));
    EXPECT_EQ(rec->poses[i].pose.t_ns, 1'000'000'000 + static_cast<std::int64_t>(i) * 100'000'000);
    EXPECT_EQ(rec->poses[i].pose.state, TrackingState::kOk);
  }
  const PipelineHealth h = p->health();
  EXPECT_EQ(h.total_drops(), 0u);
  EXPECT_EQ(h.frames_captured, 60u);
  EXPECT_EQ(h.frames_tracked, 60u);
  EXPECT_EQ(h.poses_published, 60u);
  EXPECT_FALSE(h.running);
  EXPECT_TRUE(h.source_ended);
  ASSERT_EQ(h.stages.size(), 4u);
  EXPECT_EQ(h.stages[2].name, "track");
  EXPECT_GE(h.stages[2].p50_ms, 0.9);  // the 1 ms of work shows
  ASSERT_EQ(h.outputs.size(), 1u);
  EXPECT_EQ(h.outputs[0].published, 60u);
  EXPECT_EQ(finished->load(), 1);
  // The final health report reached the output.
  ASSERT_FALSE(rec->health.empty());
  EXPECT_EQ(rec->health.back().poses_published, 60u);
}

TEST(Pipeline, LiveSourceDropsOldestAndCountsIt) {
  auto rec = std::make_shared<Recording>();
  PipelineOptions o;
  o.capture_ring_capacity = 2;
  o.detect_ring_capacity = 2;
  auto p = make_pipeline(o, std::make_unique<ScriptedSource>(ScriptedSource::frames(200), true),
                         std::make_unique<FakeTracker>(2ms),
                         outputs_of(std::make_unique<RecordingOutput>("rec", rec)));
  ASSERT_TRUE(p);
  EXPECT_EQ(p->overflow_policy(), OverflowPolicy::kDropOldest);
  p->start();
  ASSERT_TRUE(p->wait());
  const PipelineHealth h = p->health();
  EXPECT_GT(h.total_drops(), 0u);
  // Every frame is either published or counted as dropped.
  EXPECT_EQ(h.frames_captured, 200u);
  EXPECT_EQ(rec->poses.size() + h.total_drops(), 200u);
  // The newest frame always survives, and order is kept.
  ASSERT_FALSE(rec->poses.empty());
  EXPECT_EQ(rec->poses.back().pose.seq, 199);
  for (std::size_t i = 1; i < rec->poses.size(); ++i) {
    EXPECT_LT(rec->poses[i - 1].pose.seq, rec->poses[i].pose.seq);
  }
}

TEST(Pipeline, StalledSourceYieldsLostPosesThenRecovers) {
  auto rec = std::make_shared<Recording>();
  PipelineOptions o;
  o.stall_timeout_s = 0.05;
  std::vector<Step> steps = {Step::kFrame, Step::kFrame, Step::kFrame, Step::kSilence,
                             Step::kSilence, Step::kFrame, Step::kFrame};
  // Lossless (not live), so the count below does not depend on scheduling.
  auto p = make_pipeline(o, std::make_unique<ScriptedSource>(steps, false),
                         std::make_unique<FakeTracker>(),
                         outputs_of(std::make_unique<RecordingOutput>("rec", rec)));
  ASSERT_TRUE(p);
  p->start();
  ASSERT_TRUE(p->wait());
  ASSERT_EQ(rec->poses.size(), 7u);
  for (int i : {3, 4}) {
    const PosePacket& s = rec->poses[i];
    EXPECT_TRUE(s.from_stall);
    EXPECT_EQ(s.pose.state, TrackingState::kLost);
    EXPECT_NE(s.pose.state_reason.find("source stalled"), std::string::npos) << s.pose.state_reason;
    EXPECT_EQ(s.pose.seq, 2);  // repeats the last frame
    EXPECT_GT(s.pose.t_ns, rec->poses[2].pose.t_ns);
    EXPECT_DOUBLE_EQ(s.pose.T_world_cam.translation().x(), 2.0);
  }
  EXPECT_EQ(rec->poses[5].pose.state, TrackingState::kOk);
  EXPECT_EQ(rec->poses[5].pose.seq, 3);
  const PipelineHealth h = p->health();
  EXPECT_EQ(h.stalls, 2u);
  EXPECT_EQ(h.frames_tracked, 5u);
}

TEST(Pipeline, RejectedFrameIsPublishedLostWithTheReason) {
  auto rec = std::make_shared<Recording>();
  auto p = make_pipeline(PipelineOptions{}, std::make_unique<ScriptedSource>(ScriptedSource::frames(5), false),
                         std::make_unique<FakeTracker>(0ms, std::vector<std::int64_t>{2}),
                         outputs_of(std::make_unique<RecordingOutput>("rec", rec)));
  ASSERT_TRUE(p);
  p->start();
  ASSERT_TRUE(p->wait());
  ASSERT_EQ(rec->poses.size(), 5u);
  EXPECT_EQ(rec->poses[2].pose.state, TrackingState::kLost);
  EXPECT_NE(rec->poses[2].pose.state_reason.find("frame rejected: bad frame"), std::string::npos);
  EXPECT_EQ(rec->poses[3].pose.state, TrackingState::kOk);
  EXPECT_EQ(p->health().track_errors, 1u);
}

TEST(Pipeline, FailingOutputIsRetriedAndCountedWithoutHurtingOthers) {
  auto flaky = std::make_shared<Recording>();
  auto dead = std::make_shared<Recording>();
  PipelineOptions o;
  o.publish_max_attempts = 3;
  o.publish_retry_delay_s = 0.0;
  // flaky: even seqs fail twice, then succeed on the third attempt.
  auto flaky_out = std::make_unique<RecordingOutput>(
      "flaky", flaky, 2, [](const PosePacket& p) { return p.pose.seq % 2 == 0; });
  auto dead_out = std::make_unique<RecordingOutput>("dead", dead, 0, nullptr, true);
  auto p = make_pipeline(o, std::make_unique<ScriptedSource>(ScriptedSource::frames(10), false),
                         std::make_unique<FakeTracker>(),
                         outputs_of(std::move(flaky_out), std::move(dead_out)));
  ASSERT_TRUE(p);
  p->start();
  ASSERT_TRUE(p->wait());
  EXPECT_EQ(flaky->poses.size(), 10u);  // nothing lost, nothing duplicated
  for (std::size_t i = 0; i < flaky->poses.size(); ++i) EXPECT_EQ(flaky->poses[i].pose.seq, (std::int64_t)i);
  EXPECT_TRUE(dead->poses.empty());
  const PipelineHealth h = p->health();
  ASSERT_EQ(h.outputs.size(), 2u);
  EXPECT_EQ(h.outputs[0].published, 10u);
  EXPECT_EQ(h.outputs[0].errors, 10u);   // 5 poses x 2 failed attempts
  EXPECT_EQ(h.outputs[0].retries, 10u);
  EXPECT_EQ(h.outputs[0].failed, 0u);
  EXPECT_EQ(h.outputs[1].published, 0u);
  EXPECT_EQ(h.outputs[1].errors, 30u);   // 10 poses x 3 attempts
  EXPECT_EQ(h.outputs[1].retries, 20u);
  EXPECT_EQ(h.outputs[1].failed, 10u);
  EXPECT_EQ(flaky->retry_calls, 10);
}

TEST(Pipeline, StopEndsPromptlyAndPublishesEveryTrackedPose) {
  for (bool live : {true, false}) {
    auto rec = std::make_shared<Recording>();
    auto finished = std::make_shared<std::atomic<int>>(0);
    auto p = make_pipeline(PipelineOptions{}, std::make_unique<ScriptedSource>(std::vector<Step>{}, live, true, 1ms),
                           std::make_unique<FakeTracker>(3ms, std::vector<std::int64_t>{}, finished),
                           outputs_of(std::make_unique<RecordingOutput>("rec", rec)));
    ASSERT_TRUE(p);
    p->start();
    // Stop mid-run, once a few frames went through.
    testing::wait_for([&] { return p->frames_tracked() > 5; }, 10s);
    const auto t0 = std::chrono::steady_clock::now();
    p->stop();
    ASSERT_TRUE(p->wait());
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 500ms);
    const PipelineHealth h = p->health();
    EXPECT_GT(h.frames_tracked, 5u);
    EXPECT_EQ(rec->poses.size(), h.frames_tracked) << "live " << live;
    EXPECT_EQ(h.poses_published, h.frames_tracked);
    EXPECT_EQ(finished->load(), 1);
  }
}

TEST(Pipeline, StopBeforeStartAndDestroyWithoutStartAreSafe) {
  auto rec = std::make_shared<Recording>();
  auto p = make_pipeline(PipelineOptions{}, std::make_unique<ScriptedSource>(ScriptedSource::frames(3), false),
                         std::make_unique<FakeTracker>(),
                         outputs_of(std::make_unique<RecordingOutput>("rec", rec)));
  ASSERT_TRUE(p);
  p->stop();
  EXPECT_TRUE(p->wait());
  EXPECT_TRUE(rec->poses.empty());
}

TEST(Pipeline, CreateRejectsMissingHooks) {
  auto p = Pipeline::create(PipelineOptions{}, nullptr, std::make_unique<PassThroughDetect>(),
                            std::make_unique<FakeTracker>(), {});
  ASSERT_FALSE(p);
  EXPECT_EQ(p.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace sitepose::pipeline
