#pragma once
// FrameSource over a recorded sequence (io::open_sequence: sitepose/KITTI or
// EuRoC layout).
//   rate kRecorded - frame i is delivered at start + (t_i - t_0) on the
//                    steady clock (live(): the pipeline drops the oldest
//                    frame when it falls behind, as with a camera);
//   rate kMax      - as fast as the pipeline takes them (not live: lossless).
//   loop           - after the last frame start again; pass k shifts t_ns by
//                    k * (duration + one mean frame interval) and seq by k * n,
//                    so both stay monotonic (the tracker sees a jump in
//                    position, as after a relocalisation).
// Threads: next() from one thread (the capture stage); the rest is const.

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "sitepose/core/channel_order.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/pipeline/frame_source.hpp"

namespace sitepose::pipeline {

enum class ReplayRate { kRecorded, kMax };

// "recorded" | "max"; errors list the accepted names.
Expected<ReplayRate> parse_replay_rate(const std::string& name);
const char* to_string(ReplayRate rate);

struct ReplayOptions {
  std::string sequence_dir;
  ReplayRate rate = ReplayRate::kRecorded;
  bool loop = false;
  std::int64_t max_frames = 0;  // frames per pass, 0 = the whole sequence
  // How colour images become gray (siteposed: camera.channel_order).
  ChannelOrder channel_order = ChannelOrder::kBgr;
};

class ReplaySource final : public FrameSource {
 public:
  // Opens and checks the sequence (io::open_sequence's checks: calibration,
  // frame counts, every image present). Errors name the directory/file.
  static Expected<std::unique_ptr<ReplaySource>> open(const ReplayOptions& options);

  const StereoCamera& camera() const override { return sequence_->camera(); }
  std::string describe() const override;
  bool live() const override { return options_.rate == ReplayRate::kRecorded; }
  // From the recorded time stamps (mean interval), whatever the replay rate.
  double frame_rate_hz() const override { return frame_rate_hz_; }
  Expected<SourceEvent> next(std::stop_token stop, SteadyTime deadline) override;

  std::size_t frames_per_pass() const { return frames_per_pass_; }

 private:
  ReplaySource(const ReplayOptions& options, std::unique_ptr<io::Sequence> sequence);

  ReplayOptions options_;
  std::unique_ptr<io::Sequence> sequence_;
  std::size_t frames_per_pass_ = 0;
  std::int64_t pass_period_ns_ = 0;  // t shift between passes
  double frame_rate_hz_ = 0.0;
  std::size_t next_index_ = 0;  // over all passes
  bool started_ = false;
  SteadyTime start_{};
  // Interruptible timed waits (pacing); nothing else is guarded.
  std::mutex wait_mutex_;
  std::condition_variable_any wait_cv_;
};

}  // namespace sitepose::pipeline
