#pragma once
// Two of Aravis's in-process fake cameras serving a stereo sequence: each
// camera's fill callback writes the sequence image of the slot that the
// buffer's timestamp falls in. The fake cameras wake on wall-clock multiples
// of the frame period, so both cameras of one period show the same slot,
// whichever started first.
// Device ids "Fake_L" and "Fake_R" select the side.
// Ownership: the feed must outlive every source opened with its options
// (the cameras' stream threads call into it until the source is gone).

#include <arv.h>

#include <time.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/core/persistence.hpp>
#include <string>
#include <vector>

#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/drivers/aravis/aravis_camera.hpp"
#include "sitepose/drivers/aravis/pixel_convert.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::testing {

class FakeStereoFeed {
 public:
  // kCycle: slot = period number modulo the sequence length, from the start.
  // kOnce: the first image until start(), then one image per period, then
  // the last image; pause() holds the current image until resume().
  enum class Playback { kCycle, kOnce };

  FakeStereoFeed(std::vector<cv::Mat> left, std::vector<cv::Mat> right, double frame_rate_hz,
                 Playback playback = Playback::kCycle)
      : sides_{Side{std::move(left), this}, Side{std::move(right), this}},
        period_ns_(static_cast<std::int64_t>(1e9 / frame_rate_hz + 0.5)),
        playback_(playback) {}
  FakeStereoFeed(const FakeStereoFeed&) = delete;
  FakeStereoFeed& operator=(const FakeStereoFeed&) = delete;

  drivers::aravis::AravisOpenerOptions opener_options() {
    drivers::aravis::AravisOpenerOptions o;
    o.on_open = [this](ArvCamera* camera, const std::string& device_id) {
      Side& side = sides_[device_id == "Fake_R" ? 1 : 0];
      ArvFakeCamera* fake = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(arv_camera_get_device(camera)));
      arv_fake_camera_set_fill_pattern(fake, &FakeStereoFeed::fill, &side);
    };
    return o;
  }

  // kOnce: image 0 is served in the next period.
  void start() { first_period_.store(period_now() + 1); }
  void pause() { frozen_slot_.store(slot_of_period(period_now())); }
  void resume() {
    const std::int64_t frozen = frozen_slot_.load();
    first_period_.store(period_now() + 1 - frozen);
    frozen_slot_.store(-1);
  }
  // The slot a frame of host time t_ns shows (kOnce, no pause since start).
  int slot_at(std::int64_t t_ns) const { return static_cast<int>(slot_of_period(period_of(t_ns))); }
  // Whether a frame of time t_ns lies in the played range (not before start
  // or after the last image).
  bool playing_at(std::int64_t t_ns) const {
    const std::int64_t k = period_of(t_ns) - first_period_.load();
    return k >= 0 && k < size();
  }
  std::int64_t period_ns() const { return period_ns_; }

  // Slot of an image: the index of the sequence image it equals, or -1.
  int slot_of(int side, const cv::Mat& image) const {
    const auto& images = sides_[side].images;
    for (std::size_t i = 0; i < images.size(); ++i) {
      if (image.size() == images[i].size() && cv::norm(image, images[i], cv::NORM_INF) == 0.0) {
        return static_cast<int>(i);
      }
    }
    return -1;
  }
  int size() const { return static_cast<int>(sides_[0].images.size()); }
  int fills(int side) const { return sides_[side].fills.load(); }

 private:
  static constexpr std::int64_t kNotStarted = std::numeric_limits<std::int64_t>::max();

  struct Side {
    Side(std::vector<cv::Mat> i, const FakeStereoFeed* f) : images(std::move(i)), feed(f) {}
    std::vector<cv::Mat> images;
    const FakeStereoFeed* feed;
    std::atomic<int> fills{0};
  };

  // The fake cameras time frames with g_get_real_time (CLOCK_REALTIME).
  std::int64_t period_now() const {
    timespec ts{};
    clock_gettime(CLOCK_REALTIME, &ts);
    return period_of(static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec);
  }
  std::int64_t period_of(std::int64_t t_ns) const { return (t_ns + period_ns_ / 2) / period_ns_; }
  std::int64_t slot_of_period(std::int64_t period) const {
    const std::int64_t n = size();
    if (playback_ == Playback::kCycle) return period % n;
    if (const std::int64_t frozen = frozen_slot_.load(); frozen >= 0) return frozen;
    const std::int64_t first = first_period_.load();
    if (first == kNotStarted) return 0;
    return std::clamp<std::int64_t>(period - first, 0, n - 1);
  }

  // Called on the fake camera's stream thread for every frame.
  static void fill(ArvBuffer* buffer, void* data, guint32 /*exposure_us*/, guint32 /*gain*/,
                   ArvPixelFormat format) {
    Side& side = *static_cast<Side*>(data);
    const auto t_ns = static_cast<std::int64_t>(arv_buffer_get_timestamp(buffer));
    const cv::Mat& image =
        side.images[static_cast<std::size_t>(side.feed->slot_of_period(side.feed->period_of(t_ns)))];
    size_t size = 0;
    auto* out = static_cast<std::uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, &size)));
    const int w = arv_buffer_get_image_width(buffer);
    const int h = arv_buffer_get_image_height(buffer);
    if (w != image.cols || h != image.rows) return;  // a mis-sized request shows as a wrong image
    if (format == ARV_PIXEL_FORMAT_MONO_16) {
      // The 8-bit value in the high byte: Mono16 -> gray8 gives it back exactly.
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          const std::uint16_t v = static_cast<std::uint16_t>(image.at<std::uint8_t>(y, x) << 8);
          std::memcpy(out + 2 * (static_cast<std::size_t>(y) * w + x), &v, 2);
        }
      }
    } else {
      for (int y = 0; y < h; ++y) std::memcpy(out + static_cast<std::size_t>(y) * w, image.ptr(y), w);
    }
    side.fills.fetch_add(1);
  }

  Side sides_[2];
  std::int64_t period_ns_;
  Playback playback_;
  std::atomic<std::int64_t> first_period_{kNotStarted};
  std::atomic<std::int64_t> frozen_slot_{-1};
};

// The rig's calibration as `sitepose calibrate` writes it (an ideal pair:
// no distortion, no rotation), in `dir`/stereo.yaml.
inline std::string write_calibration(const TempDir& dir, const StereoCamera& c) {
  const std::string path = dir / "stereo.yaml";
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  const cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  fs << "K1" << K << "D1" << cv::Mat::zeros(1, 5, CV_64F) << "K2" << K << "D2"
     << cv::Mat::zeros(1, 5, CV_64F);
  fs << "R" << cv::Mat::eye(3, 3, CV_64F) << "T" << (cv::Mat_<double>(3, 1) << -c.baseline_m, 0, 0);
  fs << "image_width" << c.width << "image_height" << c.height;
  return path;
}

}  // namespace sitepose::testing
