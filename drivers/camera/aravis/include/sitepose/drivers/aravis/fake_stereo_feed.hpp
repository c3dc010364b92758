#pragma once
// Two of Aravis's in-process fake cameras serving a stereo image sequence:
// each camera's fill callback writes the sequence image of the exposure
// period the frame belongs to. For the tests and `sitepose bench pipeline
// --source aravis`: no camera needed.
// Time: a real camera exposes on its own clock whatever the host's load and
// stamps the frame with that clock; only the transfer to the host is late
// when the host is busy. The fake camera is a host thread that sleeps to the
// next multiple of its frame period and stamps the frame when it wakes, so
// on a loaded host its stamp is late by the scheduler's delay (tens of ms at
// load 25 on 2 cores) and two cameras' stamps of one period differ. The
// feed makes it behave like a real one: both cameras run on the feed's
// period grid (the fake's AcquisitionFramePeriod is set to it), a fill
// belongs to the period the thread slept until, its camera stamp is that
// period's start (the same on both cameras), and the image is that
// period's; the buffer's system timestamp stays the host's arrival time,
// which the source's clock mapping has to see through. A thread that wakes
// a whole period late loses that period's frame, as a camera would with no
// free buffer: counted in missed(side).
// Device ids "Fake_L" and "Fake_R" select the side (aravis_camera_opener
// opens Aravis's fake interface for ids starting with "Fake_").
// Ownership: the feed must outlive every source opened with its options
// (the cameras' stream threads call into it until the source is gone).
// Threads: start(), pause() and resume() from any thread; the fill
// callbacks run on the cameras' stream threads.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <vector>

#include "sitepose/drivers/aravis/aravis_camera.hpp"

namespace sitepose::drivers::aravis {

class FakeStereoFeed {
 public:
  // kCycle: slot = period number modulo the sequence length, from the start.
  // kOnce: the first image until start(), then one image per period, then
  // the last image; pause() holds the current image until resume().
  enum class Playback { kCycle, kOnce };

  FakeStereoFeed(std::vector<cv::Mat> left, std::vector<cv::Mat> right, double frame_rate_hz,
                 Playback playback = Playback::kCycle);
  FakeStereoFeed(const FakeStereoFeed&) = delete;
  FakeStereoFeed& operator=(const FakeStereoFeed&) = delete;

  // Installs the fill callbacks on the fake cameras the opener opens and
  // puts them on the feed's period grid.
  AravisOpenerOptions opener_options();

  // kOnce: image 0 is served in the next period.
  void start();
  void pause();
  void resume();
  // The slot a frame of host time t_ns shows (kOnce, no pause since start).
  int slot_at(std::int64_t t_ns) const { return static_cast<int>(slot_of_period(period_of(t_ns))); }
  // Whether a frame of time t_ns lies in the played range (not before start
  // or after the last image).
  bool playing_at(std::int64_t t_ns) const;
  std::int64_t period_ns() const { return period_ns_; }

  // Whether `image` is the sequence image of `side` for the frame stamped
  // camera_t_ns (a check that a frame's stamp and picture belong together).
  bool shows(int side, std::int64_t camera_t_ns, const cv::Mat& image) const;
  // Slot of an image: the index of the sequence image it equals, or -1.
  int slot_of(int side, const cv::Mat& image) const;
  int size() const { return static_cast<int>(sides_[0].images.size()); }
  int fills(int side) const { return sides_[side].fills.load(); }
  // Exposure periods a camera's thread slept through (woke a period or
  // more late): frames that camera never made.
  int missed(int side) const { return sides_[side].missed.load(); }
  // The longest delay from a frame's exposure (its camera stamp) to its
  // fill on the host, ns.
  std::int64_t max_fill_delay_ns(int side) const { return sides_[side].max_delay_ns.load(); }

  // One camera's images: the fill callback's data.
  struct Side {
    Side(std::vector<cv::Mat> i, const FakeStereoFeed* f) : images(std::move(i)), feed(f) {}
    std::vector<cv::Mat> images;
    const FakeStereoFeed* feed;
    std::atomic<int> fills{0};
    std::atomic<int> missed{0};
    std::atomic<std::int64_t> max_delay_ns{0};
    std::atomic<std::int64_t> last_period{-1};  // of the last fill; -1 after an open
  };
  // A fill at host time fill_ns: the exposure period it belongs to, after
  // counting periods the thread slept through. Stream threads only.
  std::int64_t record_fill(Side& side, std::int64_t fill_ns) const;
  const cv::Mat& image_of_period(const Side& side, std::int64_t period) const {
    return side.images[static_cast<std::size_t>(slot_of_period(period))];
  }

 private:
  static constexpr std::int64_t kNotStarted = std::numeric_limits<std::int64_t>::max();

  // The fake cameras time frames with g_get_real_time (CLOCK_REALTIME).
  // The period whose exposure was made last.
  std::int64_t period_now() const;
  // A stamped time (a period's start, plus the source's clock mapping of a
  // few ms at most): its period.
  std::int64_t period_of(std::int64_t t_ns) const { return (t_ns + period_ns_ / 2) / period_ns_; }
  std::int64_t slot_of_period(std::int64_t period) const;

  Side sides_[2];
  std::int64_t period_us_;  // the fake camera's AcquisitionFramePeriod is in us
  std::int64_t period_ns_;
  Playback playback_;
  std::atomic<std::int64_t> first_period_{kNotStarted};
  std::atomic<std::int64_t> frozen_slot_{-1};
};

}  // namespace sitepose::drivers::aravis
