#include "sitepose/mapping/keyframe_worker.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

namespace sitepose::mapping {
namespace {

// Records the keyframes it is given; keyframe 2 fails.
struct Recorder {
  std::mutex mutex;
  std::vector<map::KeyFrameId> seen;

  KeyFrameWorker::Process process() {
    return [this](map::KeyFrameId id) -> Status {
      {
        std::lock_guard lock(mutex);
        seen.push_back(id);
      }
      if (id == 2) return make_error(ErrorCode::kRuntime, "keyframe 2 fails");
      return ok_status();
    };
  }
  std::vector<map::KeyFrameId> snapshot() {
    std::lock_guard lock(mutex);
    return seen;
  }
};

KeyFrameWorkerOptions test_options() { return {"sp-test", 0, "test"}; }

TEST(KeyFrameWorker, ProcessPendingRunsTheQueueInOrderAndReturnsTheFirstError) {
  Recorder recorder;
  KeyFrameWorker worker(test_options(), recorder.process());
  for (map::KeyFrameId id : {1, 2, 3}) worker.enqueue(id);
  EXPECT_EQ(worker.queue_size(), 3U);
  const Status status = worker.process_pending();
  ASSERT_FALSE(status);
  EXPECT_EQ(status.error().message, "keyframe 2 fails");
  EXPECT_EQ(recorder.snapshot(), (std::vector<map::KeyFrameId>{1, 2, 3}));
  EXPECT_TRUE(worker.idle());
}

TEST(KeyFrameWorker, ThreadGoesOnAfterAFailureAndStopsWhenAsked) {
  Recorder recorder;
  KeyFrameWorker worker(test_options(), recorder.process());
  worker.start();
  EXPECT_TRUE(worker.running());
  for (map::KeyFrameId id : {1, 2, 3}) worker.enqueue(id);
  worker.wait_until_idle();
  EXPECT_EQ(recorder.snapshot(), (std::vector<map::KeyFrameId>{1, 2, 3}));
  worker.stop();
  EXPECT_FALSE(worker.running());
  worker.enqueue(4);  // stays queued
  worker.wait_until_idle();
  EXPECT_EQ(worker.queue_size(), 1U);
}

TEST(KeyFrameWorker, HeldThreadKeepsKeyframesQueuedUntilReleased) {
  Recorder recorder;
  KeyFrameWorker worker(test_options(), recorder.process());
  worker.start();
  worker.hold();
  worker.enqueue(1);
  EXPECT_FALSE(worker.begin_interruptible_step());  // held, and a keyframe waits
  EXPECT_TRUE(worker.interrupt().load());
  EXPECT_EQ(worker.queue_size(), 1U);
  worker.release();
  worker.wait_until_idle();
  EXPECT_EQ(recorder.snapshot(), (std::vector<map::KeyFrameId>{1}));
  worker.stop();
}

// The loop closer and the tracker (joining a provisional map) may hold the
// mapper at once: one release must not end the other's hold.
TEST(KeyFrameWorker, HoldsNestUntilEachIsReleased) {
  Recorder recorder;
  KeyFrameWorker worker(test_options(), recorder.process());
  worker.start();
  worker.hold();
  worker.hold();
  worker.release();
  EXPECT_FALSE(worker.begin_interruptible_step()) << "still held by the second holder";
  worker.enqueue(1);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(worker.queue_size(), 1U);
  EXPECT_TRUE(recorder.snapshot().empty());
  worker.release();
  worker.wait_until_idle();
  EXPECT_EQ(recorder.snapshot(), (std::vector<map::KeyFrameId>{1}));
  worker.release();  // one release too many is harmless
  EXPECT_TRUE(worker.begin_interruptible_step());
  worker.stop();
}

TEST(KeyFrameWorker, InterruptibleStepClearsTheFlagOnlyWhenNothingWaits) {
  Recorder recorder;
  KeyFrameWorker worker(test_options(), recorder.process());
  worker.enqueue(1);
  EXPECT_TRUE(worker.interrupt().load());
  EXPECT_FALSE(worker.begin_interruptible_step());
  EXPECT_TRUE(worker.interrupt().load());
  ASSERT_TRUE(worker.process_pending());
  EXPECT_TRUE(worker.begin_interruptible_step());
  EXPECT_FALSE(worker.interrupt().load());
  worker.enqueue(3);
  EXPECT_TRUE(worker.interrupt().load());
}

}  // namespace
}  // namespace sitepose::mapping
