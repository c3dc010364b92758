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
// The host clock is CLOCK_REALTIME (system time, disciplined by NTP/PTP), so
// that pose times line up with GNSS fixes and other machines' messages.
// Threads: one owner; no locking.

#include <cstddef>
#include <cstdint>
#include <deque>

namespace sitepose::drivers::aravis {

class ClockMapper {
 public:
  explicit ClockMapper(std::size_t window = 64) : window_(window == 0 ? 1 : window) {}

  // Records one frame and returns its capture time on the host clock.
  std::int64_t map(std::int64_t camera_t_ns, std::int64_t host_arrival_ns);
  // After a reconnect the camera's counter starts again.
  void reset() { offsets_.clear(); }
  std::int64_t offset_ns() const;

 private:
  std::size_t window_;
  std::deque<std::int64_t> offsets_;  // host arrival - camera time, newest last
};

}  // namespace sitepose::drivers::aravis
