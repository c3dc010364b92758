#pragma once
// Pairs left and right camera frames by timestamp. Two cameras never deliver
// in lock step: a free-running pair is offset by a fraction of a period or
// by whole periods, a frame can be lost on the wire, and each stream has its
// own latency. A left and a right frame form a pair when their pairing
// times differ by at most the tolerance; a frame that can no longer find a
// partner (its counterpart is later than the tolerance allows, or too many
// frames wait) is dropped and counted as unpaired.
// Frames dropped before the first pair (after start or reset()) are
// start-up skew, one camera streaming before the other, not a
// synchronisation fault: they are counted apart (skipped_at_start).
// Threads: one owner (the capture thread); no locking.

#include <cstdint>
#include <deque>
#include <opencv2/core.hpp>
#include <optional>
#include <utility>

namespace sitepose::drivers::aravis {

enum class Side { kLeft = 0, kRight = 1 };

struct CameraFrame {
  cv::Mat gray;                  // CV_8UC1, not yet rectified
  std::int64_t camera_t_ns = 0;  // the camera's own clock
  std::int64_t host_t_ns = 0;    // mapped to the host clock (clock_mapper.hpp)
  std::uint64_t frame_id = 0;    // the camera's block id
};

enum class PairClock { kCamera, kHost };

struct PairerOptions {
  std::int64_t tolerance_ns = 2'000'000;
  // Frames of one side kept waiting for the other side's; beyond this the
  // oldest is dropped (the other camera is late or silent).
  std::size_t max_pending = 4;
  // Which time stamp pairs: the cameras' clocks when they share one (PTP,
  // a common trigger clock), else the host-mapped times.
  PairClock clock = PairClock::kHost;
};

struct PairerCounts {
  std::uint64_t pairs = 0;
  std::uint64_t unpaired_left = 0;
  std::uint64_t unpaired_right = 0;
  std::uint64_t skipped_at_start = 0;
};

struct FramePair {
  CameraFrame left;
  CameraFrame right;
};

class StereoPairer {
 public:
  explicit StereoPairer(const PairerOptions& options) : options_(options) {}

  void push(Side side, CameraFrame frame);
  // The oldest pair available, dropping frames that cannot pair any more.
  std::optional<FramePair> pop();
  // Forgets waiting frames (counted unpaired) and the start-up state: after
  // a camera was lost, pairing starts afresh.
  void reset();

  const PairerCounts& counts() const { return counts_; }
  std::size_t pending(Side side) const { return queue(side).size(); }

 private:
  std::int64_t key(const CameraFrame& f) const {
    return options_.clock == PairClock::kCamera ? f.camera_t_ns : f.host_t_ns;
  }
  std::deque<CameraFrame>& queue(Side side) { return queues_[static_cast<int>(side)]; }
  const std::deque<CameraFrame>& queue(Side side) const { return queues_[static_cast<int>(side)]; }
  void drop_front(Side side);

  PairerOptions options_;
  std::deque<CameraFrame> queues_[2];
  bool paired_once_ = false;  // since start or reset()
  PairerCounts counts_;
};

}  // namespace sitepose::drivers::aravis
