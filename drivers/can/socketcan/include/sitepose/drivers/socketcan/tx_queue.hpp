#pragma once
// Poses waiting for the CAN socket: whole poses (the frames of one
// CanSink::flush()), at most `capacity_frames` frames in all, sent in order.
// A pose is admitted whole or not at all, and dropped whole (counting the
// frames already written), so the counters say exactly which poses did not
// reach the bus. Not thread-safe: the sink guards it with its mutex.

#include <cstddef>
#include <deque>
#include <optional>
#include <vector>

#include "sitepose/output/can_frame.hpp"

namespace sitepose::drivers::socketcan {

class PoseTxQueue {
 public:
  explicit PoseTxQueue(std::size_t capacity_frames) : capacity_frames_(capacity_frames) {}

  bool fits(std::size_t n_frames) const { return n_frames <= capacity_frames_ - frames_; }
  // `frames` must fit and not be empty (checked).
  void push(std::vector<output::CanFrame> frames);

  bool empty() const { return poses_.empty(); }
  std::size_t poses() const { return poses_.size(); }
  std::size_t frames() const { return frames_; }
  std::size_t capacity_frames() const { return capacity_frames_; }

  // The head pose's next unwritten frame (queue not empty: checked).
  const output::CanFrame& next_frame() const;
  // The head frame went out. Returns the head pose's frames when that was
  // its last one (the pose is then removed).
  std::optional<std::vector<output::CanFrame>> frame_written();

  struct Dropped {
    std::size_t poses = 0;
    std::size_t partially_sent = 0;  // of those, poses with some frames already written
    std::size_t frames = 0;          // frames not written
  };
  // Drops every queued pose.
  Dropped clear();

 private:
  struct Pose {
    std::vector<output::CanFrame> frames;
    std::size_t next = 0;
  };
  std::size_t capacity_frames_;
  std::size_t frames_ = 0;  // unwritten frames
  std::deque<Pose> poses_;
};

}  // namespace sitepose::drivers::socketcan
