#include "sitepose/drivers/v4l2/v4l2_camera.hpp"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace sitepose::drivers::v4l2 {

namespace {

std::string errno_text(int err) {
  return std::string(std::strerror(err)) + " (errno " + std::to_string(err) + ")";
}

std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

std::int64_t monotonic_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// A capture buffer of the mmap streaming I/O, by index (DQBUF fills the index in).
v4l2_buffer mmap_capture_buffer(std::uint32_t index) {
  v4l2_buffer buf{};
  buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buf.memory = V4L2_MEMORY_MMAP;
  buf.index = index;
  return buf;
}

}  // namespace

Status check_camera_options(const CameraOptions& o) {
  if (o.device.empty()) return make_error(ErrorCode::kInvalidArgument, "device: must be set");
  if (o.width <= 0 || o.height <= 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      o.device + ": size " + size_text(o.width, o.height) + " must be positive");
  }
  if (!(o.fps >= 0.0) || !std::isfinite(o.fps)) {
    return make_error(ErrorCode::kInvalidArgument, o.device + ": fps must be >= 0");
  }
  if (o.buffers < 2 || o.buffers > 32) {
    return make_error(ErrorCode::kInvalidArgument,
                      o.device + ": buffers = " + std::to_string(o.buffers) + ", must be 2..32");
  }
  if (o.formats.empty()) return make_error(ErrorCode::kInvalidArgument, o.device + ": no pixel format");
  return ok_status();
}

V4l2Camera::V4l2Camera(std::shared_ptr<V4l2Io> io, CameraOptions options)
    : io_(std::move(io)), options_(std::move(options)) {}

V4l2Camera::~V4l2Camera() { close(); }

std::string V4l2Camera::fail_text(const std::string& call, int err) const {
  return "V4L2 " + options_.device + ": " + call + ": " + errno_text(err);
}

Expected<std::unique_ptr<V4l2Camera>> V4l2Camera::open(std::shared_ptr<V4l2Io> io,
                                                       const CameraOptions& options) {
  SITEPOSE_TRY_STATUS(check_camera_options(options));
  std::unique_ptr<V4l2Camera> camera(new V4l2Camera(std::move(io), options));
  camera->fd_ = camera->io_->open(options.device.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (camera->fd_ < 0) {
    const int err = errno;
    const bool absent = err == ENOENT || err == ENODEV || err == ENXIO;
    return make_error(absent ? ErrorCode::kNotFound : ErrorCode::kIoError,
                      camera->fail_text("open", err) + (absent ? "; is the camera plugged in?" : ""));
  }
  v4l2_capability cap{};
  if (camera->io_->ioctl(camera->fd_, VIDIOC_QUERYCAP, &cap) != 0) {
    return make_error(ErrorCode::kUnsupported,
                      camera->fail_text("VIDIOC_QUERYCAP (not a V4L2 device?)", errno));
  }
  const std::uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) != 0 ? cap.device_caps : cap.capabilities;
  if ((caps & V4L2_CAP_VIDEO_CAPTURE) == 0 || (caps & V4L2_CAP_STREAMING) == 0) {
    return make_error(ErrorCode::kUnsupported, "V4L2 " + options.device +
                                                   ": not a streaming video capture device (a UVC camera has "
                                                   "a second /dev/video node for metadata; use the first)");
  }
  SITEPOSE_TRY_STATUS(camera->negotiate_format());
  camera->set_frame_rate();
  SITEPOSE_TRY_STATUS(camera->map_buffers());
  SITEPOSE_TRY_STATUS(camera->start_streaming());
  return camera;
}

Status V4l2Camera::negotiate_format() {
  std::vector<std::uint32_t> offered;
  for (std::uint32_t i = 0;; ++i) {
    v4l2_fmtdesc desc{};
    desc.index = i;
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (io_->ioctl(fd_, VIDIOC_ENUM_FMT, &desc) != 0) break;  // EINVAL ends the list
    offered.push_back(desc.pixelformat);
  }
  std::string offered_text;
  for (std::uint32_t code : offered) offered_text += (offered_text.empty() ? "" : ", ") + fourcc_text(code);
  std::string tried;
  for (PixelFormat want : options_.formats) {
    if (std::find(offered.begin(), offered.end(), fourcc(want)) == offered.end()) continue;
    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    fmt.fmt.pix.width = static_cast<std::uint32_t>(options_.width);
    fmt.fmt.pix.height = static_cast<std::uint32_t>(options_.height);
    fmt.fmt.pix.pixelformat = fourcc(want);
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    if (io_->ioctl(fd_, VIDIOC_S_FMT, &fmt) != 0) {
      if (errno == EBUSY)
        return make_error(ErrorCode::kIoError, fail_text("VIDIOC_S_FMT (in use by another program?)", EBUSY));
      tried += std::string(tried.empty() ? "" : "; ") + to_string(want) + ": " + errno_text(errno);
      continue;
    }
    const int w = static_cast<int>(fmt.fmt.pix.width), h = static_cast<int>(fmt.fmt.pix.height);
    if (fmt.fmt.pix.pixelformat != fourcc(want) || w != options_.width || h != options_.height) {
      tried += std::string(tried.empty() ? "" : "; ") + to_string(want) + " at " +
               size_text(options_.width, options_.height) + " became " +
               fourcc_text(fmt.fmt.pix.pixelformat) + " " + size_text(w, h);
      continue;
    }
    format_ = want;
    bytes_per_line_ = fmt.fmt.pix.bytesperline;
    return ok_status();
  }
  std::string wanted;
  for (PixelFormat f : options_.formats) wanted += (wanted.empty() ? "" : ", ") + std::string(to_string(f));
  return make_error(ErrorCode::kUnsupported,
                    "V4L2 " + options_.device + ": no usable format: wanted " + wanted + " at " +
                        size_text(options_.width, options_.height) + ", the device offers " +
                        (offered_text.empty() ? "none" : offered_text) +
                        (tried.empty() ? "" : " (" + tried + ")"));
}

void V4l2Camera::set_frame_rate() {
  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (options_.fps > 0.0) {
    parm.parm.capture.timeperframe.numerator = 1000;
    parm.parm.capture.timeperframe.denominator =
        static_cast<std::uint32_t>(std::lround(options_.fps * 1000.0));
    // Not every driver sets the rate (some only have one): keep what it has.
    (void)io_->ioctl(fd_, VIDIOC_S_PARM, &parm);
  }
  parm = {};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (io_->ioctl(fd_, VIDIOC_G_PARM, &parm) == 0 && parm.parm.capture.timeperframe.numerator > 0) {
    fps_ = static_cast<double>(parm.parm.capture.timeperframe.denominator) /
           parm.parm.capture.timeperframe.numerator;
  }
}

Status V4l2Camera::map_buffers() {
  v4l2_requestbuffers req{};
  req.count = static_cast<std::uint32_t>(options_.buffers);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (io_->ioctl(fd_, VIDIOC_REQBUFS, &req) != 0) {
    return make_error(ErrorCode::kUnsupported, fail_text("VIDIOC_REQBUFS (mmap streaming)", errno));
  }
  if (req.count < 2) {
    return make_error(ErrorCode::kIoError, "V4L2 " + options_.device + ": the driver granted " +
                                               std::to_string(req.count) + " buffers, need 2");
  }
  for (std::uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer buf = mmap_capture_buffer(i);
    if (io_->ioctl(fd_, VIDIOC_QUERYBUF, &buf) != 0)
      return make_error(ErrorCode::kIoError, fail_text("VIDIOC_QUERYBUF", errno));
    void* start = io_->mmap(buf.length, fd_, static_cast<off_t>(buf.m.offset));
    if (start == MAP_FAILED) return make_error(ErrorCode::kIoError, fail_text("mmap", errno));
    buffers_.push_back({start, buf.length});
  }
  return ok_status();
}

Status V4l2Camera::start_streaming() {
  for (std::uint32_t i = 0; i < buffers_.size(); ++i) {
    v4l2_buffer buf = mmap_capture_buffer(i);
    if (io_->ioctl(fd_, VIDIOC_QBUF, &buf) != 0)
      return make_error(ErrorCode::kIoError, fail_text("VIDIOC_QBUF", errno));
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (io_->ioctl(fd_, VIDIOC_STREAMON, &type) != 0) {
    return make_error(ErrorCode::kIoError, fail_text("VIDIOC_STREAMON (USB bandwidth?)", errno));
  }
  streaming_ = true;
  return ok_status();
}

void V4l2Camera::close() {
  if (fd_ < 0) return;
  if (streaming_) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    (void)io_->ioctl(fd_, VIDIOC_STREAMOFF, &type);  // fails harmlessly on an unplugged device
    streaming_ = false;
  }
  for (const Buffer& b : buffers_) io_->munmap(b.start, b.length);
  buffers_.clear();
  io_->close(fd_);
  fd_ = -1;
}

std::string V4l2Camera::describe() const {
  char fps[32];
  std::snprintf(fps, sizeof(fps), "%.4g", fps_);
  return options_.device + " " + to_string(format_) + " " + size_text(options_.width, options_.height) +
         " @ " + (fps_ > 0.0 ? std::string(fps) + " fps" : std::string("unknown rate"));
}

Expected<std::optional<RawFrame>> V4l2Camera::dequeue() {
  if (fd_ < 0) return make_error(ErrorCode::kIoError, "V4L2 " + options_.device + ": closed");
  v4l2_buffer buf = mmap_capture_buffer(0);
  if (io_->ioctl(fd_, VIDIOC_DQBUF, &buf) != 0) {
    if (errno == EAGAIN) return std::optional<RawFrame>{};
    return make_error(ErrorCode::kIoError, fail_text("VIDIOC_DQBUF", errno));
  }
  if (buf.index >= buffers_.size()) {
    return make_error(ErrorCode::kIoError, "V4L2 " + options_.device + ": driver returned buffer " +
                                               std::to_string(buf.index) + " of " +
                                               std::to_string(buffers_.size()));
  }
  RawFrame frame;
  frame.sequence = buf.sequence;
  if ((buf.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC) {
    frame.t_ns = static_cast<std::int64_t>(buf.timestamp.tv_sec) * 1'000'000'000 +
                 static_cast<std::int64_t>(buf.timestamp.tv_usec) * 1'000;
    frame.kernel_time = true;
  } else {
    frame.t_ns = monotonic_now_ns();
    ++counts_.host_timestamps;
  }
  const Buffer& b = buffers_[buf.index];
  Expected<cv::Mat> gray =
      (buf.flags & V4L2_BUF_FLAG_ERROR) != 0
          ? Expected<cv::Mat>(make_error(ErrorCode::kIoError, "flagged corrupt by the driver"))
          : to_gray(format_, static_cast<const std::uint8_t*>(b.start),
                    std::min<std::size_t>(buf.bytesused, b.length), options_.width, options_.height,
                    bytes_per_line_);
  // The copy is made: the buffer goes back to the driver at once.
  if (io_->ioctl(fd_, VIDIOC_QBUF, &buf) != 0)
    return make_error(ErrorCode::kIoError, fail_text("VIDIOC_QBUF", errno));
  if (last_sequence_ && buf.sequence > *last_sequence_ + 1)
    counts_.sequence_gaps += buf.sequence - *last_sequence_ - 1;
  last_sequence_ = buf.sequence;
  if (!gray) {
    ++counts_.corrupt;
    return std::optional<RawFrame>{};
  }
  frame.gray = std::move(*gray);
  ++counts_.frames;
  return std::optional<RawFrame>{std::move(frame)};
}

}  // namespace sitepose::drivers::v4l2
