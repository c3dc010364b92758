#include "sitepose/drivers/socketcan/tx_queue.hpp"

#include <utility>

#include "sitepose/core/expected.hpp"

namespace sitepose::drivers::socketcan {

void PoseTxQueue::push(std::vector<output::CanFrame> frames) {
  SITEPOSE_CHECK(!frames.empty() && fits(frames.size()));
  frames_ += frames.size();
  poses_.push_back(Pose{std::move(frames), 0});
}

const output::CanFrame& PoseTxQueue::next_frame() const {
  SITEPOSE_CHECK(!poses_.empty());
  return poses_.front().frames[poses_.front().next];
}

std::optional<std::vector<output::CanFrame>> PoseTxQueue::frame_written() {
  SITEPOSE_CHECK(!poses_.empty());
  Pose& head = poses_.front();
  ++head.next;
  --frames_;
  if (head.next < head.frames.size()) return std::nullopt;
  std::vector<output::CanFrame> done = std::move(head.frames);
  poses_.pop_front();
  return done;
}

PoseTxQueue::Dropped PoseTxQueue::clear() {
  Dropped d;
  d.poses = poses_.size();
  d.frames = frames_;
  for (const Pose& p : poses_) {
    if (p.next > 0) ++d.partially_sent;
  }
  poses_.clear();
  frames_ = 0;
  return d;
}

}  // namespace sitepose::drivers::socketcan
