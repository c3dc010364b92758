#include "sitepose/drivers/v4l2/v4l2_source.hpp"

#include <algorithm>
#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <thread>

#include "sitepose/core/log.hpp"

namespace sitepose::drivers::v4l2 {

namespace {

// next() polls in slices this long so a stop request is seen promptly.
constexpr int kPollSliceMs = 20;
// Frames kept per side while waiting for the other side's.
constexpr std::size_t kMaxPending = 8;

// Sleeps until `until` or a stop request, whichever is first.
void wait_interruptibly(const std::stop_token& stop, std::chrono::steady_clock::time_point until) {
  std::mutex mutex;
  std::condition_variable_any cv;
  std::unique_lock lock(mutex);
  cv.wait_until(lock, stop, until, [] { return false; });
}

std::chrono::steady_clock::duration seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
}

}  // namespace

Status check_v4l2_source_options(const V4l2SourceOptions& o) {
  if (o.left_device.empty()) return make_error(ErrorCode::kInvalidArgument, "left_device: must be set");
  if (o.right_device == o.left_device) {
    return make_error(ErrorCode::kInvalidArgument,
                      "right_device: the same as left_device (leave it empty for a side-by-side device)");
  }
  if (o.width <= 0 || o.height <= 0 || (o.right_device.empty() && o.width % 2 != 0)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "width/height: " + std::to_string(o.width) + "x" + std::to_string(o.height) +
                          " must be positive (and the width even for a side-by-side device)");
  }
  SITEPOSE_TRY_STATUS(parse_pixel_preference(o.pixel_format));
  if (o.pair_tolerance_ns < 0) return make_error(ErrorCode::kInvalidArgument, "pair_tolerance: must be >= 0");
  if (!(o.reconnect_min_s > 0.0) || !(o.reconnect_max_s >= o.reconnect_min_s)) {
    return make_error(ErrorCode::kInvalidArgument, "reconnect_min_s/reconnect_max_s: need 0 < min <= max");
  }
  if (!(o.wait_for_camera_s >= 0.0))
    return make_error(ErrorCode::kInvalidArgument, "wait_for_camera_s: must be >= 0");
  if (o.calibration_file.empty()) return make_error(ErrorCode::kInvalidArgument, "calibration: must be set");
  CameraOptions camera;
  camera.device = o.left_device;
  camera.width = o.width;
  camera.height = o.height;
  camera.fps = o.fps;
  camera.buffers = o.buffers;
  return check_camera_options(camera);
}

V4l2Source::V4l2Source(V4l2SourceOptions options, std::shared_ptr<V4l2Io> io,
                       calib::StereoRectifier rectifier)
    : options_(std::move(options)),
      io_(std::move(io)),
      rectifier_(std::move(rectifier)),
      pairer_(options_.pair_tolerance_ns, kMaxPending) {
  formats_ = *parse_pixel_preference(options_.pixel_format);
}

V4l2Source::~V4l2Source() = default;

Expected<std::unique_ptr<V4l2Source>> V4l2Source::open(const V4l2SourceOptions& options,
                                                       std::shared_ptr<V4l2Io> io) {
  SITEPOSE_TRY_STATUS(check_v4l2_source_options(options));
  const int camera_width = options.right_device.empty() ? options.width / 2 : options.width;
  auto rectifier = calib::load_stereo_rectifier(options.calibration_file, {camera_width, options.height});
  if (!rectifier) {
    const bool size_hint =
        options.right_device.empty() && rectifier.error().code == ErrorCode::kInvalidArgument;
    return make_error(rectifier.error().code, "calibration: " + rectifier.error().message +
                                                  (size_hint ? " (half of the side-by-side frame)" : ""));
  }
  std::unique_ptr<V4l2Source> source(new V4l2Source(options, std::move(io), std::move(*rectifier)));
  const auto give_up = Clock::now() + seconds(options.wait_for_camera_s);
  double backoff_s = options.reconnect_min_s;
  for (;;) {
    Status st = source->open_cameras();
    if (st) break;
    // Only an absent device is worth waiting for; a wrong format stays wrong.
    if (st.error().code != ErrorCode::kNotFound || Clock::now() >= give_up) {
      const bool waited = options.wait_for_camera_s > 0.0 && st.error().code == ErrorCode::kNotFound;
      return make_error(st.error().code,
                        st.error().message +
                            (waited ? " (waited " + std::to_string(options.wait_for_camera_s) + " s)" : ""));
    }
    std::this_thread::sleep_until(std::min(give_up, Clock::now() + seconds(backoff_s)));
    backoff_s = std::min(2.0 * backoff_s, options.reconnect_max_s);
  }
  source->publish_stats();
  return source;
}

CameraOptions V4l2Source::camera_options(Side side) const {
  CameraOptions o;
  o.device = side == Side::kLeft ? options_.left_device : options_.right_device;
  o.width = options_.width;
  o.height = options_.height;
  o.fps = options_.fps;
  o.formats = formats_;
  o.buffers = options_.buffers;
  return o;
}

Status V4l2Source::open_cameras() {
  const int n = side_by_side() ? 1 : 2;
  for (int i = 0; i < n; ++i) {
    auto camera = V4l2Camera::open(io_, camera_options(static_cast<Side>(i)));
    if (!camera) {
      cameras_[0].reset();
      cameras_[1].reset();
      return make_error(camera.error().code,
                        std::string(i == 0 ? "left_device: " : "right_device: ") + camera.error().message);
    }
    cameras_[i] = std::move(*camera);
  }
  fps_ = cameras_[0]->fps() > 0.0 ? cameras_[0]->fps() : options_.fps;
  return ok_status();
}

std::string V4l2Source::describe() const {
  std::string text = "v4l2 ";
  if (side_by_side()) {
    text += "side-by-side " + (cameras_[0] ? cameras_[0]->describe() : options_.left_device);
  } else {
    text += "left " + (cameras_[0] ? cameras_[0]->describe() : options_.left_device) + ", right " +
            (cameras_[1] ? cameras_[1]->describe() : options_.right_device);
  }
  return text + ", rectified to " + std::to_string(camera().width) + "x" + std::to_string(camera().height) +
         " (" + options_.calibration_file + ")";
}

void V4l2Source::lose(const std::string& why) {
  for (auto& camera : cameras_) {
    if (!camera) continue;
    const CameraCounts& c = camera->counts();
    retired_.frames += c.frames;
    retired_.corrupt += c.corrupt;
    retired_.host_timestamps += c.host_timestamps;
    retired_.sequence_gaps += c.sequence_gaps;
    camera.reset();
  }
  pairer_.reset();
  ++disconnects_;
  backoff_s_ = options_.reconnect_min_s;
  next_retry_ = Clock::now() + seconds(backoff_s_);
  spdlog::warn("{}; reopening in {:.2f} s", why, backoff_s_);
  std::lock_guard lock(stats_mutex_);
  stats_.last_error = why;
}

void V4l2Source::try_reconnect(Clock::time_point now) {
  Status st = open_cameras();
  if (st) {
    ++reconnects_;
    spdlog::info("V4L2 cameras back: {}", describe());
    return;
  }
  backoff_s_ = std::min(2.0 * backoff_s_, options_.reconnect_max_s);
  next_retry_ = now + seconds(backoff_s_);
  std::lock_guard lock(stats_mutex_);
  stats_.last_error = st.error().message;
}

Expected<std::optional<camera::StereoPair<RawFrame>>> V4l2Source::poll_cameras(int wait_ms) {
  const int n = side_by_side() ? 1 : 2;
  pollfd fds[2] = {};
  for (int i = 0; i < n; ++i) fds[i] = {cameras_[i]->fd(), POLLIN, 0};
  if (io_->poll(fds, static_cast<nfds_t>(n), wait_ms) < 0) {
    lose("V4L2 poll: " + std::string(std::strerror(errno)));
    return std::optional<camera::StereoPair<RawFrame>>{};
  }
  for (int i = 0; i < n; ++i) {
    if (fds[i].revents == 0) continue;
    // Drain what is ready; POLLERR/POLLHUP show up as a failing DQBUF.
    for (;;) {
      auto frame = cameras_[i]->dequeue();
      if (!frame) {
        lose(frame.error().message);
        return std::optional<camera::StereoPair<RawFrame>>{};
      }
      if (!*frame) break;
      RawFrame raw = std::move(**frame);
      if (side_by_side()) {
        const int half = raw.gray.cols / 2;
        RawFrame right = raw;
        right.gray = raw.gray(cv::Rect(half, 0, half, raw.gray.rows));
        raw.gray = raw.gray(cv::Rect(0, 0, half, raw.gray.rows));
        const std::int64_t right_t_ns = right.t_ns;
        pairer_.push(Side::kRight, right_t_ns, std::move(right));
      }
      const std::int64_t t_ns = raw.t_ns;
      pairer_.push(static_cast<Side>(i), t_ns, std::move(raw));
    }
  }
  return pairer_.pop();
}

Expected<pipeline::SourceEvent> V4l2Source::deliver(const camera::StereoPair<RawFrame>& pair) {
  StereoFrame frame;
  SITEPOSE_TRY_STATUS(rectifier_.rectify(pair.left.gray, pair.right.gray, frame.left, frame.right));
  frame.seq = seq_++;
  frame.t_left_ns = pair.left.t_ns;
  frame.t_right_ns = pair.right.t_ns;
  frame.source_id = "v4l2:" + options_.left_device;
  publish_stats();
  return pipeline::SourceEvent{pipeline::SourceEventKind::kFrame, std::move(frame)};
}

Expected<pipeline::SourceEvent> V4l2Source::next(std::stop_token stop, pipeline::SteadyTime deadline) {
  using pipeline::SourceEvent;
  using pipeline::SourceEventKind;
  for (;;) {
    if (stop.stop_requested()) return SourceEvent{SourceEventKind::kEnd, {}};
    if (auto pair = pairer_.pop()) return deliver(*pair);
    const auto now = Clock::now();
    if (!cameras_[0]) {
      if (now >= next_retry_) try_reconnect(now);
      if (!cameras_[0]) {
        publish_stats();
        if (now >= deadline) return SourceEvent{SourceEventKind::kTimeout, {}};
        wait_interruptibly(stop, std::min(next_retry_, deadline));
        continue;
      }
    }
    if (now >= deadline) {
      publish_stats();
      return SourceEvent{SourceEventKind::kTimeout, {}};
    }
    const auto left_ms = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now).count();
    const int wait_ms = static_cast<int>(std::clamp<std::int64_t>(left_ms, 0, kPollSliceMs));
    SITEPOSE_TRY(auto pair, poll_cameras(wait_ms));
    if (pair) return deliver(*pair);
  }
}

void V4l2Source::publish_stats() {
  CameraCounts c = retired_;
  for (const auto& camera : cameras_) {
    if (!camera) continue;
    c.corrupt += camera->counts().corrupt;
    c.host_timestamps += camera->counts().host_timestamps;
    c.sequence_gaps += camera->counts().sequence_gaps;
  }
  std::lock_guard lock(stats_mutex_);
  stats_.frames = static_cast<std::uint64_t>(seq_);
  stats_.pairs = pairer_.counts().pairs;
  stats_.unpaired_left = pairer_.counts().unpaired_left;
  stats_.unpaired_right = pairer_.counts().unpaired_right;
  stats_.skipped_at_start = pairer_.counts().skipped_at_start;
  stats_.corrupt = c.corrupt;
  stats_.host_timestamps = c.host_timestamps;
  stats_.sequence_gaps = c.sequence_gaps;
  stats_.disconnects = disconnects_;
  stats_.reconnects = reconnects_;
  stats_.connected = cameras_[0] != nullptr;
}

V4l2SourceStats V4l2Source::stats() const {
  std::lock_guard lock(stats_mutex_);
  return stats_;
}

}  // namespace sitepose::drivers::v4l2
