#pragma once
// One V4L2 capture device streaming through mmap buffers: opened, format
// negotiated (the first of the preferred pixel formats the device offers, at
// exactly the requested size), buffers requested, mapped and queued, stream
// on. dequeue() hands out one gray frame per call, converted and copied out
// of the driver's buffer, which goes straight back to the driver.
//
// Time stamps: the kernel's, when the buffer says they are on
// CLOCK_MONOTONIC (V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC, uvcvideo and most
// drivers: the time the first or last byte arrived, see the flag's
// TSTAMP_SRC bits); otherwise the host's CLOCK_MONOTONIC when the buffer is
// dequeued, counted in host_timestamps. std::chrono::steady_clock is
// CLOCK_MONOTONIC on Linux, so both are on the pipeline's clock.
//
// Threads: one owner (the capture thread). Ownership: the camera owns its
// descriptor and mappings; close() (and the destructor) stops the stream,
// unmaps and closes.

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/drivers/v4l2/pixel_format.hpp"
#include "sitepose/drivers/v4l2/v4l2_io.hpp"

namespace sitepose::drivers::v4l2 {

struct CameraOptions {
  std::string device;  // "/dev/video0" or a /dev/v4l/by-id/... link
  int width = 0;       // the exact capture size; the device must offer it
  int height = 0;
  double fps = 30.0;  // requested with VIDIOC_S_PARM; 0 = leave the device's
  std::vector<PixelFormat> formats = auto_preference();  // in order of preference
  int buffers = 4;                                       // mmap buffers requested (the driver may grant more)
};

// Fails naming the field: device set, size positive, fps >= 0, buffers 2..32,
// at least one format.
Status check_camera_options(const CameraOptions& options);

struct RawFrame {
  cv::Mat gray;                // CV_8UC1 width x height, owned
  std::int64_t t_ns = 0;       // CLOCK_MONOTONIC
  std::uint32_t sequence = 0;  // the driver's frame counter
  bool kernel_time = false;
};

struct CameraCounts {
  std::uint64_t frames = 0;
  std::uint64_t host_timestamps = 0;  // buffers without a monotonic kernel time stamp
  std::uint64_t corrupt = 0;          // V4L2_BUF_FLAG_ERROR or a frame that does not convert
  std::uint64_t sequence_gaps = 0;    // frames the driver dropped (sequence jumps)
};

class V4l2Camera {
 public:
  // Errors: kNotFound when the device does not exist, kUnsupported when it
  // cannot stream video capture or offers none of the formats at the size
  // (the message lists what it offers), kIoError for a failing call (named).
  static Expected<std::unique_ptr<V4l2Camera>> open(std::shared_ptr<V4l2Io> io, const CameraOptions& options);
  ~V4l2Camera();
  V4l2Camera(const V4l2Camera&) = delete;
  V4l2Camera& operator=(const V4l2Camera&) = delete;

  int fd() const { return fd_; }
  PixelFormat format() const { return format_; }
  double fps() const { return fps_; }  // as the device reports it, 0 when unknown
  const std::string& device() const { return options_.device; }
  std::string describe() const;  // "/dev/video0 YUYV 1280x480 @ 30 fps"

  // The next filled buffer as a frame, or nullopt when none is ready
  // (EAGAIN) or it was corrupt (counted; the buffer is requeued). An error
  // means the device failed (ENODEV: unplugged); close and reopen it.
  Expected<std::optional<RawFrame>> dequeue();

  const CameraCounts& counts() const { return counts_; }

 private:
  struct Buffer {
    void* start = nullptr;
    std::size_t length = 0;
  };
  V4l2Camera(std::shared_ptr<V4l2Io> io, CameraOptions options);
  Status negotiate_format();
  void set_frame_rate();
  Status map_buffers();
  Status start_streaming();
  void close();
  std::string fail_text(const std::string& call, int err) const;

  std::shared_ptr<V4l2Io> io_;
  CameraOptions options_;
  int fd_ = -1;
  PixelFormat format_ = PixelFormat::kGrey;
  std::size_t bytes_per_line_ = 0;
  double fps_ = 0.0;
  std::vector<Buffer> buffers_;
  bool streaming_ = false;
  std::optional<std::uint32_t> last_sequence_;
  CameraCounts counts_;
};

}  // namespace sitepose::drivers::v4l2
