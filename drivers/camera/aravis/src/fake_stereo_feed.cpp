#include "sitepose/drivers/aravis/fake_stereo_feed.hpp"

#include <arv.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace sitepose::drivers::aravis {
namespace {

// Called on a fake camera's stream thread for every frame, after Aravis
// stamped it (camera and system timestamp) with the host's time of the fill.
void fill(ArvBuffer* buffer, void* data, guint32 /*exposure_us*/, guint32 /*gain*/, ArvPixelFormat format) {
  auto& side = *static_cast<FakeStereoFeed::Side*>(data);
  const auto fill_ns = static_cast<std::int64_t>(arv_buffer_get_system_timestamp(buffer));
  const std::int64_t period = side.feed->record_fill(side, fill_ns);
  // The camera stamp is the exposure's time; the system timestamp keeps the
  // host's arrival time.
  arv_buffer_set_timestamp(buffer, static_cast<guint64>(period * side.feed->period_ns()));
  const cv::Mat& image = side.feed->image_of_period(side, period);
  size_t size = 0;
  auto* out = static_cast<std::uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, &size)));
  const int w = arv_buffer_get_image_width(buffer);
  const int h = arv_buffer_get_image_height(buffer);
  if (w != image.cols || h != image.rows) return;  // a mis-sized request shows as a wrong image
  if (format == ARV_PIXEL_FORMAT_MONO_16) {
    // The 8-bit value in the high byte: Mono16 -> gray8 gives it back exactly.
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const auto v = static_cast<std::uint16_t>(image.at<std::uint8_t>(y, x) << 8);
        std::memcpy(out + 2 * (static_cast<std::size_t>(y) * w + x), &v, 2);
      }
    }
  } else {
    for (int y = 0; y < h; ++y) std::memcpy(out + static_cast<std::size_t>(y) * w, image.ptr(y), w);
  }
  side.fills.fetch_add(1);
}

}  // namespace

FakeStereoFeed::FakeStereoFeed(std::vector<cv::Mat> left, std::vector<cv::Mat> right, double frame_rate_hz,
                               Playback playback)
    : sides_{Side{std::move(left), this}, Side{std::move(right), this}},
      period_us_(std::llround(1e6 / frame_rate_hz)),
      period_ns_(period_us_ * 1000),
      playback_(playback) {}

AravisOpenerOptions FakeStereoFeed::opener_options() {
  AravisOpenerOptions o;
  o.on_open = [this](ArvCamera* camera, const std::string& device_id) {
    Side& side = sides_[device_id == "Fake_R" ? 1 : 0];
    // The fake's rate feature is a converter onto this integer register;
    // set the register itself so that its grid is exactly the feed's.
    GError* error = nullptr;
    arv_camera_set_integer(camera, "AcquisitionFramePeriod", period_us_, &error);
    if (error != nullptr) g_error_free(error);  // then the images run off the grid: the tests show it
    side.last_period.store(-1);
    ArvFakeCamera* fake = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(arv_camera_get_device(camera)));
    arv_fake_camera_set_fill_pattern(fake, &fill, &side);
  };
  return o;
}

void FakeStereoFeed::start() { first_period_.store(period_now() + 1); }

void FakeStereoFeed::pause() { frozen_slot_.store(slot_of_period(period_now())); }

void FakeStereoFeed::resume() {
  const std::int64_t frozen = frozen_slot_.load();
  first_period_.store(period_now() + 1 - frozen);
  frozen_slot_.store(-1);
}

std::int64_t FakeStereoFeed::record_fill(Side& side, std::int64_t fill_ns) const {
  // The thread slept until a multiple of the period and woke at or after it.
  const std::int64_t period = fill_ns / period_ns_;
  const std::int64_t last = side.last_period.exchange(period);
  if (last >= 0 && period > last + 1) side.missed.fetch_add(static_cast<int>(period - last - 1));
  const std::int64_t delay_ns = fill_ns - period * period_ns_;
  std::int64_t seen = side.max_delay_ns.load();
  while (delay_ns > seen && !side.max_delay_ns.compare_exchange_weak(seen, delay_ns)) {
  }
  return period;
}

bool FakeStereoFeed::playing_at(std::int64_t t_ns) const {
  const std::int64_t k = period_of(t_ns) - first_period_.load();
  return k >= 0 && k < size();
}

bool FakeStereoFeed::shows(int side, std::int64_t camera_t_ns, const cv::Mat& image) const {
  const cv::Mat& want = image_of_period(sides_[side], period_of(camera_t_ns));
  return image.size() == want.size() && image.type() == want.type() &&
         cv::norm(image, want, cv::NORM_INF) == 0.0;
}

int FakeStereoFeed::slot_of(int side, const cv::Mat& image) const {
  const auto& images = sides_[side].images;
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (image.size() == images[i].size() && cv::norm(image, images[i], cv::NORM_INF) == 0.0) {
      return static_cast<int>(i);
    }
  }
  return -1;
}

std::int64_t FakeStereoFeed::period_now() const {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return (static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec) / period_ns_;
}

std::int64_t FakeStereoFeed::slot_of_period(std::int64_t period) const {
  const std::int64_t n = size();
  if (playback_ == Playback::kCycle) return period % n;
  if (const std::int64_t frozen = frozen_slot_.load(); frozen >= 0) return frozen;
  const std::int64_t first = first_period_.load();
  if (first == kNotStarted) return 0;
  return std::clamp<std::int64_t>(period - first, 0, n - 1);
}

}  // namespace sitepose::drivers::aravis
