#pragma once
// Pairs the left and right frames of two cameras by time stamp. Two cameras
// never deliver in lock step: a free-running pair is offset by a fraction of
// a period or by whole periods, a frame can be lost on the wire or dropped
// by the driver, and each stream has its own latency. A left and a right
// frame pair when their times differ by at most the tolerance; a frame that
// can no longer find a partner (the other side's oldest frame is later than
// the tolerance allows, or more than max_pending wait on its side) is
// dropped and counted as unpaired.
// Frames dropped before the first pair (after construction or reset()) are
// start-up skew, one camera streaming before the other, not a
// synchronisation fault: they are counted apart (skipped_at_start).
// The caller chooses the clock the times are on (the cameras' own when they
// share one, e.g. PTP; else the host's), the same for both sides.
// A side whose times come from an estimate still settling (a camera clock
// mapped to the host's from its first few frames) may see them move: shift()
// moves its waiting frames with the estimate. While set_settling() says they
// may still move earlier, a frame of the other side that looks older than
// the settling side's waits for the settling side's next frames (which may
// bring the estimate down), until max_pending of them wait; only then is it
// dropped. Pairs behind it wait with it.
// Threads: one owner (the capture thread); no locking.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>

namespace sitepose::drivers::camera {

enum class Side { kLeft = 0, kRight = 1 };

inline const char* side_name(Side side) { return side == Side::kLeft ? "left" : "right"; }

struct PairerCounts {
  std::uint64_t pairs = 0;
  std::uint64_t unpaired_left = 0;
  std::uint64_t unpaired_right = 0;
  std::uint64_t skipped_at_start = 0;
};

template <class Frame>
struct StereoPair {
  Frame left;
  Frame right;
};

template <class Frame>
class StereoPairer {
 public:
  StereoPairer(std::int64_t tolerance_ns, std::size_t max_pending)
      : tolerance_ns_(tolerance_ns), max_pending_(max_pending) {}

  // `t_ns`: the time the frame pairs on.
  void push(Side side, std::int64_t t_ns, Frame frame) {
    auto& q = queue(side);
    q.push_back(Waiting{t_ns, std::move(frame)});
    while (q.size() > max_pending_) drop_front(side);
  }

  // The side's time estimate changed by delta_ns: its waiting frames move with it.
  void shift(Side side, std::int64_t delta_ns) {
    for (Waiting& w : queue(side)) w.t_ns += delta_ns;
  }

  // Whether the side's times may still move earlier (see the top).
  void set_settling(Side side, bool settling) { settling_[static_cast<int>(side)] = settling; }

  // The oldest pair that can be formed now, dropping frames that never will.
  std::optional<StereoPair<Frame>> pop() {
    auto& left = queue(Side::kLeft);
    auto& right = queue(Side::kRight);
    while (!left.empty() && !right.empty()) {
      const std::int64_t dt = left.front().t_ns - right.front().t_ns;
      if (dt > tolerance_ns_) {
        if (may_move_earlier(Side::kLeft)) break;
        drop_front(Side::kRight);  // older than any left frame still to come
      } else if (dt < -tolerance_ns_) {
        if (may_move_earlier(Side::kRight)) break;
        drop_front(Side::kLeft);
      } else {
        StereoPair<Frame> pair{std::move(left.front().frame), std::move(right.front().frame)};
        left.pop_front();
        right.pop_front();
        ++counts_.pairs;
        paired_once_ = true;
        return pair;
      }
    }
    return std::nullopt;
  }

  // Forgets waiting frames (counted unpaired) and the start-up state: after
  // a camera was lost, pairing starts afresh.
  void reset() {
    while (!queue(Side::kLeft).empty()) drop_front(Side::kLeft);
    while (!queue(Side::kRight).empty()) drop_front(Side::kRight);
    paired_once_ = false;
  }

  const PairerCounts& counts() const { return counts_; }
  std::size_t pending(Side side) const { return queues_[static_cast<int>(side)].size(); }

 private:
  struct Waiting {
    std::int64_t t_ns;
    Frame frame;
  };

  std::deque<Waiting>& queue(Side side) { return queues_[static_cast<int>(side)]; }
  // Settling, with room for the frames that may refine its waiting frames' times.
  bool may_move_earlier(Side side) const {
    return settling_[static_cast<int>(side)] && queues_[static_cast<int>(side)].size() < max_pending_;
  }

  void drop_front(Side side) {
    queue(side).pop_front();
    if (!paired_once_) {
      ++counts_.skipped_at_start;  // the other camera has not started yet
    } else {
      ++(side == Side::kLeft ? counts_.unpaired_left : counts_.unpaired_right);
    }
  }

  std::int64_t tolerance_ns_;
  std::size_t max_pending_;
  std::deque<Waiting> queues_[2];
  bool paired_once_ = false;  // since construction or reset()
  bool settling_[2] = {false, false};
  PairerCounts counts_;
};

}  // namespace sitepose::drivers::camera
