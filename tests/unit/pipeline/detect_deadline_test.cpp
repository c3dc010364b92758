// The detect stage's deadline (DeadlineDetect, issue 20): a detector call
// that overruns is abandoned at the deadline and counted, the frame goes on
// undetected; frames while the detector is still busy are skipped at once;
// once it returns, detection resumes; a detector that never returns does
// not hold the destructor longer than its grace.

#include "sitepose/pipeline/detect_deadline.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <mutex>

#include "sitepose/testing/wait.hpp"

namespace sitepose::pipeline {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// Marks every frame detected with one box whose instance is the frame's
// seq; blocks on frames in [block_from, block_to) until released.
class GateHook final : public DetectHook {
 public:
  GateHook(std::int64_t block_from, std::int64_t block_to) : from_(block_from), to_(block_to) {}
  std::string name() const override { return "gate"; }
  Status annotate(FramePacket& packet) override {
    if (packet.frame.seq >= from_ && packet.frame.seq < to_) {
      std::unique_lock lock(mutex_);
      blocked_ = true;
      cv_.wait(lock, [&] { return released_; });
    }
    packet.detected = true;
    packet.objects = {{static_cast<std::uint16_t>(packet.frame.seq), "truck", 0.9, cv::Rect(0, 0, 2, 2)}};
    calls_.fetch_add(1);
    return ok_status();
  }
  void release() {
    std::lock_guard lock(mutex_);
    released_ = true;
    cv_.notify_all();
  }
  int calls() const { return calls_.load(); }

 private:
  const std::int64_t from_, to_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool blocked_ = false;
  bool released_ = false;
  std::atomic<int> calls_{0};
};

FramePacket frame(std::int64_t seq) {
  FramePacket p;
  p.frame.seq = seq;
  p.frame.left = cv::Mat::zeros(4, 4, CV_8UC1);
  p.frame.right = p.frame.left.clone();
  return p;
}

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

TEST(DeadlineDetect, OverrunIsAbandonedBusyFramesSkippedThenDetectionResumes) {
  auto hook = std::make_unique<GateHook>(2, 3);  // frame 2 blocks until released
  GateHook* gate = hook.get();
  DeadlineDetect detect(std::move(hook), 100ms);
  for (std::int64_t seq = 0; seq < 2; ++seq) {
    FramePacket p = frame(seq);
    ASSERT_TRUE(detect.annotate(p));
    EXPECT_TRUE(p.detected);
    ASSERT_EQ(p.objects.size(), 1u);
    EXPECT_EQ(p.objects[0].instance, static_cast<std::uint16_t>(seq));
  }
  FramePacket stuck = frame(2);
  auto t0 = Clock::now();
  const Status st = detect.annotate(stuck);
  const double waited_ms = ms_since(t0);
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("deadline of 100.0 ms"), std::string::npos) << st.error().message;
  EXPECT_FALSE(stuck.detected);
  EXPECT_TRUE(stuck.objects.empty());
  EXPECT_GE(waited_ms, 95.0);
  EXPECT_LT(waited_ms, 600.0);  // the deadline, not the detector, decides
  // Still busy: the next frames are not given to it, and not held.
  for (std::int64_t seq = 3; seq < 5; ++seq) {
    FramePacket p = frame(seq);
    t0 = Clock::now();
    EXPECT_FALSE(detect.annotate(p));
    EXPECT_LT(ms_since(t0), 50.0);
    EXPECT_FALSE(p.detected);
  }
  gate->release();
  // The late result is dropped; the next frame is detected again (the
  // worker may need a moment to come back from the released call).
  std::int64_t seq = 5;
  FramePacket p;
  const bool resumed = sitepose::testing::wait_for(
      [&] {
        p = frame(seq++);
        return detect.annotate(p).has_value();
      },
      2s, 5ms);
  ASSERT_TRUE(resumed);
  ASSERT_EQ(p.objects.size(), 1u);
  EXPECT_EQ(p.objects[0].instance, static_cast<std::uint16_t>(seq - 1));  // its own result, not frame 2's
  const DetectDeadlineCounters c = detect.counters();
  EXPECT_EQ(c.timeouts, 1u);
  EXPECT_GE(c.skipped_busy, 2u);
  EXPECT_EQ(c.late_returns, 1u);
}

TEST(DeadlineDetect, DetectorThatNeverReturnsDoesNotHoldTheStop) {
  auto hook = std::make_unique<GateHook>(0, 1);  // never released
  auto* detect = new DeadlineDetect(std::move(hook), 50ms, 200ms);
  FramePacket p = frame(0);
  EXPECT_FALSE(detect->annotate(p));
  const auto t0 = Clock::now();
  delete detect;  // gives up on the worker after the grace
  EXPECT_LT(ms_since(t0), 1000.0);
  EXPECT_GE(ms_since(t0), 150.0);
  // The worker and the hook stay (leaked by design): the process ends with them.
}

}  // namespace
}  // namespace sitepose::pipeline
