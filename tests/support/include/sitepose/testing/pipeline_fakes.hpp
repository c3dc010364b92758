#pragma once
// Test doubles for the pipeline's seams: a scripted frame source, a tracker
// that answers with a pose per frame (optionally slow), and an output that
// records what it got and fails on demand. Needs sitepose::pipeline.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <stop_token>
#include <string>
#include <thread>
#include <vector>

#include "sitepose/pipeline/frame_source.hpp"
#include "sitepose/pipeline/hooks.hpp"
#include "sitepose/testing/cameras.hpp"

namespace sitepose::testing {

inline StereoFrame tiny_frame(std::int64_t seq, std::int64_t t_ns) {
  StereoFrame f;
  f.seq = seq;
  f.t_left_ns = f.t_right_ns = t_ns;
  f.left = cv::Mat(4, 4, CV_8UC1, cv::Scalar(static_cast<int>(seq % 256)));
  f.right = f.left.clone();
  f.source_id = "fake";
  return f;
}

// Steps: kFrame delivers the next frame at once; kSilence waits until the
// deadline (or stop) and reports kTimeout; after the script: kEnd, or with
// `endless` frames forever (every `period`).
class ScriptedSource final : public pipeline::FrameSource {
 public:
  enum class Step { kFrame, kSilence };
  ScriptedSource(std::vector<Step> steps, bool live, bool endless = false,
                 std::chrono::nanoseconds period = std::chrono::nanoseconds(0))
      : camera_(centred_camera(4, 4, 100.0, 0.1)),
        steps_(steps.begin(), steps.end()),
        live_(live),
        endless_(endless),
        period_(period) {}
  static std::vector<Step> frames(int n) { return std::vector<Step>(n, Step::kFrame); }

  const StereoCamera& camera() const override { return camera_; }
  std::string describe() const override { return "scripted"; }
  bool live() const override { return live_; }
  Expected<pipeline::SourceEvent> next(std::stop_token stop, pipeline::SteadyTime deadline) override {
    std::unique_lock lock(mutex_);
    if (stop.stop_requested()) return pipeline::SourceEvent{pipeline::SourceEventKind::kEnd, {}};
    if (steps_.empty() && !endless_) return pipeline::SourceEvent{pipeline::SourceEventKind::kEnd, {}};
    const Step step = steps_.empty() ? Step::kFrame : steps_.front();
    if (!steps_.empty()) steps_.pop_front();
    if (step == Step::kSilence) {
      cv_.wait_until(lock, stop, deadline, [] { return false; });
      if (stop.stop_requested()) return pipeline::SourceEvent{pipeline::SourceEventKind::kEnd, {}};
      return pipeline::SourceEvent{pipeline::SourceEventKind::kTimeout, {}};
    }
    if (period_.count() > 0) {
      cv_.wait_for(lock, stop, period_, [] { return false; });
      if (stop.stop_requested()) return pipeline::SourceEvent{pipeline::SourceEventKind::kEnd, {}};
    }
    const std::int64_t seq = next_seq_++;
    return pipeline::SourceEvent{pipeline::SourceEventKind::kFrame, tiny_frame(seq, 1'000'000'000 + seq * 100'000'000)};
  }

 private:
  StereoCamera camera_;
  std::deque<Step> steps_;
  bool live_;
  bool endless_;
  std::chrono::nanoseconds period_;
  std::int64_t next_seq_ = 0;
  std::mutex mutex_;
  std::condition_variable_any cv_;
};

// Pose = translation (seq, 0, 0), state OK; rejects frames whose seq is in
// `reject`. Optionally busy for `work` per frame.
class FakeTracker final : public pipeline::PoseTracker {
 public:
  explicit FakeTracker(std::chrono::nanoseconds work = {}, std::vector<std::int64_t> reject = {},
                       std::shared_ptr<std::atomic<int>> finished = nullptr)
      : work_(work), reject_(std::move(reject)), finished_(std::move(finished)) {}
  Expected<PoseEstimate> track(const pipeline::FramePacket& packet) override {
    if (work_.count() > 0) std::this_thread::sleep_for(work_);
    for (auto r : reject_) {
      if (r == packet.frame.seq) return make_error(ErrorCode::kInvalidArgument, "bad frame");
    }
    PoseEstimate p;
    p.seq = packet.frame.seq;
    p.t_ns = packet.frame.t_ns();
    p.T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(double(p.seq), 0, 0));
    p.state = TrackingState::kOk;
    p.counters.features_used = 100;
    return p;
  }
  void finish() override {
    if (finished_) finished_->fetch_add(1);
  }

 private:
  std::chrono::nanoseconds work_;
  std::vector<std::int64_t> reject_;
  std::shared_ptr<std::atomic<int>> finished_;
};

// What an output saw; shared with the test (the pipeline owns the output).
struct Recording {
  std::mutex mutex;
  std::vector<pipeline::PosePacket> poses;  // confirmed (publish or retry ok)
  std::vector<pipeline::PipelineHealth> health;
  int publish_calls = 0;
  int retry_calls = 0;
};

// Fails `fail_first` attempts (publish or retry calls) per pose whose seq
// satisfies `fails_on`, or every attempt when `always_fail`.
class RecordingOutput final : public pipeline::PoseOutput {
 public:
  RecordingOutput(std::string name, std::shared_ptr<Recording> rec, int fail_first = 0,
                  std::function<bool(const pipeline::PosePacket&)> fails_on = nullptr, bool always_fail = false)
      : name_(std::move(name)), rec_(std::move(rec)), fail_first_(fail_first),
        fails_on_(std::move(fails_on)), always_fail_(always_fail) {}
  std::string name() const override { return name_; }
  Status publish(const pipeline::PosePacket& packet) override {
    pending_ = packet;
    attempts_ = 0;
    std::lock_guard lock(rec_->mutex);
    ++rec_->publish_calls;
    return attempt_locked();
  }
  Status retry() override {
    std::lock_guard lock(rec_->mutex);
    ++rec_->retry_calls;
    return attempt_locked();
  }
  Status publish_health(const pipeline::PipelineHealth& h) override {
    std::lock_guard lock(rec_->mutex);
    rec_->health.push_back(h);
    return ok_status();
  }

 private:
  Status attempt_locked() {
    ++attempts_;
    const bool targeted = !fails_on_ || fails_on_(pending_);
    if (always_fail_ || (targeted && attempts_ <= fail_first_)) {
      return make_error(ErrorCode::kIoError, name_ + ": injected failure");
    }
    rec_->poses.push_back(pending_);
    return ok_status();
  }
  std::string name_;
  std::shared_ptr<Recording> rec_;
  int fail_first_;
  std::function<bool(const pipeline::PosePacket&)> fails_on_;
  bool always_fail_;
  pipeline::PosePacket pending_;
  int attempts_ = 0;
};

}  // namespace sitepose::testing
