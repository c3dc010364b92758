#pragma once
// Two of Aravis's in-process fake cameras serving a stereo image sequence:
// each camera's fill callback writes the sequence image of the slot that the
// buffer's timestamp falls in. The fake cameras wake on wall-clock multiples
// of the frame period, so both cameras of one period show the same slot,
// whichever started first. For the tests and `sitepose bench pipeline
// --source aravis`: no camera needed.
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

  // Installs the fill callbacks on the fake cameras the opener opens.
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

  // Slot of an image: the index of the sequence image it equals, or -1.
  int slot_of(int side, const cv::Mat& image) const;
  int size() const { return static_cast<int>(sides_[0].images.size()); }
  int fills(int side) const { return sides_[side].fills.load(); }

  // One camera's images: the fill callback's data.
  struct Side {
    Side(std::vector<cv::Mat> i, const FakeStereoFeed* f) : images(std::move(i)), feed(f) {}
    std::vector<cv::Mat> images;
    const FakeStereoFeed* feed;
    std::atomic<int> fills{0};
  };
  // The image of `side` that a frame of host time t_ns shows.
  const cv::Mat& image_at(const Side& side, std::int64_t t_ns) const {
    return side.images[static_cast<std::size_t>(slot_of_period(period_of(t_ns)))];
  }

 private:
  static constexpr std::int64_t kNotStarted = std::numeric_limits<std::int64_t>::max();

  // The fake cameras time frames with g_get_real_time (CLOCK_REALTIME).
  std::int64_t period_now() const;
  std::int64_t period_of(std::int64_t t_ns) const { return (t_ns + period_ns_ / 2) / period_ns_; }
  std::int64_t slot_of_period(std::int64_t period) const;

  Side sides_[2];
  std::int64_t period_ns_;
  Playback playback_;
  std::atomic<std::int64_t> first_period_{kNotStarted};
  std::atomic<std::int64_t> frozen_slot_{-1};
};

}  // namespace sitepose::drivers::aravis
