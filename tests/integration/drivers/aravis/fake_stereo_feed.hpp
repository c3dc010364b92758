#pragma once
// Two of Aravis's in-process fake cameras serving a stereo sequence: each
// camera's fill callback writes the sequence image whose slot matches the
// buffer's timestamp. The fake cameras wake on wall-clock multiples of the
// frame period, so both cameras of one period get the same slot
// (timestamp / period modulo the sequence length), whichever started first.
// Device ids "Fake_L" and "Fake_R" select the side.
// Ownership: the feed must outlive every source opened with its options
// (the cameras' stream threads call into it until the source is gone).

#include <arv.h>

#include <atomic>
#include <cstring>
#include <opencv2/core.hpp>
#include <vector>

#include "sitepose/drivers/aravis/aravis_camera.hpp"
#include "sitepose/drivers/aravis/pixel_convert.hpp"

namespace sitepose::testing {

class FakeStereoFeed {
 public:
  FakeStereoFeed(std::vector<cv::Mat> left, std::vector<cv::Mat> right, double frame_rate_hz)
      : sides_{Side{std::move(left)}, Side{std::move(right)}},
        period_ns_(static_cast<std::int64_t>(1e9 / frame_rate_hz + 0.5)) {
    for (Side& s : sides_) s.period_ns = period_ns_;
  }
  FakeStereoFeed(const FakeStereoFeed&) = delete;
  FakeStereoFeed& operator=(const FakeStereoFeed&) = delete;

  drivers::aravis::AravisOpenerOptions opener_options() {
    drivers::aravis::AravisOpenerOptions o;
    o.on_open = [this](ArvCamera* camera, const drivers::aravis::CameraSettings& settings) {
      Side& side = sides_[settings.device_id == "Fake_R" ? 1 : 0];
      ArvFakeCamera* fake = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(arv_camera_get_device(camera)));
      arv_fake_camera_set_fill_pattern(fake, &FakeStereoFeed::fill, &side);
    };
    return o;
  }

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
  struct Side {
    explicit Side(std::vector<cv::Mat> i) : images(std::move(i)) {}
    std::vector<cv::Mat> images;
    std::int64_t period_ns = 0;
    std::atomic<int> fills{0};
  };

  // Called on the fake camera's stream thread for every frame.
  static void fill(ArvBuffer* buffer, void* data, guint32 /*exposure_us*/, guint32 /*gain*/,
                   ArvPixelFormat format) {
    Side& side = *static_cast<Side*>(data);
    const auto t_ns = static_cast<std::int64_t>(arv_buffer_get_timestamp(buffer));
    const auto n = static_cast<std::int64_t>(side.images.size());
    const std::int64_t slot = ((t_ns + side.period_ns / 2) / side.period_ns) % n;
    const cv::Mat& image = side.images[static_cast<std::size_t>(slot)];
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
};

}  // namespace sitepose::testing
