#pragma once
// Pairs left and right frames of two free-running (or commonly triggered)
// cameras by capture time: a left and a right frame pair when their times
// differ by at most the tolerance. A frame that can no longer pair (the
// other side already has a later frame beyond the tolerance, or more than
// max_pending wait on its side) is dropped and counted as unpaired.
// Threads: one owner (the capture thread); no locking.

#include <cstdint>
#include <deque>
#include <optional>
#include <utility>

#include "sitepose/drivers/v4l2/v4l2_camera.hpp"

namespace sitepose::drivers::v4l2 {

enum class Side { kLeft = 0, kRight = 1 };

struct PairCounts {
  std::uint64_t pairs = 0;
  std::uint64_t unpaired_left = 0;
  std::uint64_t unpaired_right = 0;
};

class TimestampPairer {
 public:
  TimestampPairer(std::int64_t tolerance_ns, std::size_t max_pending)
      : tolerance_ns_(tolerance_ns), max_pending_(max_pending) {}

  void push(Side side, RawFrame frame);
  // The oldest pair that can be formed now, dropping frames that never will.
  std::optional<std::pair<RawFrame, RawFrame>> pop();
  // Drops what waits (counted unpaired): after a device was lost.
  void reset();

  const PairCounts& counts() const { return counts_; }
  std::size_t pending(Side side) const { return queues_[static_cast<int>(side)].size(); }

 private:
  void drop_front(int side);

  std::int64_t tolerance_ns_;
  std::size_t max_pending_;
  std::deque<RawFrame> queues_[2];
  PairCounts counts_;
};

}  // namespace sitepose::drivers::v4l2
