#pragma once
// Maps a camera's timestamps (its own counter, in ns) to the host clock.
// For every frame the host notes when the buffer arrived; arrival minus
// capture is the clock offset plus the transfer latency, which is never
// negative. The smallest such difference over a sliding window of frames is
// the offset plus the shortest latency seen, and host time = camera time +
// that minimum. The window follows slow drift between the two oscillators
// (tens of ppm) and forgets offsets from before a camera reset; a frame
// delayed on the wire does not move the estimate. What remains is the
// pair's minimum transfer latency (exposure end to buffer complete, about a
// millisecond on GigE), common to every frame.
// Until a few frames have been seen (settled()), the estimate may still fall
// by tens of milliseconds: the first frames of a loaded host all arrive late.
// The host clock is CLOCK_REALTIME (system time, disciplined by NTP/PTP), so
// that pose times line up with GNSS fixes and other machines' messages.
// Threads: one owner; no locking.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <deque>

namespace sitepose::drivers::aravis {

class ClockMapper {
 public:
  explicit ClockMapper(std::size_t window = 64, std::size_t settle_frames = 8)
      : window_(window == 0 ? 1 : window), settle_frames_(std::min(settle_frames, window_)) {}

  // Records one frame and returns its capture time on the host clock.
  std::int64_t map(std::int64_t camera_t_ns, std::int64_t host_arrival_ns);
  // After a reconnect the camera's counter starts again.
  void reset() { offsets_.clear(); }
  std::int64_t offset_ns() const;
  bool empty() const { return offsets_.empty(); }
  // Seen settle_frames frames since construction or reset().
  bool settled() const { return offsets_.size() >= settle_frames_; }

 private:
  std::size_t window_;
  std::size_t settle_frames_;
  std::deque<std::int64_t> offsets_;  // host arrival - camera time, newest last
};

}  // namespace sitepose::drivers::aravis
