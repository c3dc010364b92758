#pragma once
// pipeline::FrameSource over V4L2 cameras: two devices (left and right), or
// one side-by-side stereo device (many UVC stereo cameras send both images
// in one frame, left half | right half) split in halves. Frames are
// converted to gray, paired by time stamp (two devices; the halves of one
// frame are a pair by construction) and rectified with maps computed once
// from the calibration file (calib/calibration_file.hpp; its image size is
// one camera's, i.e. half the side-by-side frame's width).
//
// A device that fails while streaming (unplugged: ENODEV; or any other
// error) is closed and reopened with back-off doubling from reconnect_min_s
// to reconnect_max_s; meanwhile next() returns kTimeout at its deadline, so
// the pipeline reports a stall (LOST poses) and the daemon stays up. The
// first open must succeed, unless wait_for_camera_s > 0: then open() retries
// for that long before it fails.
//
// Threads: next() from the capture thread only; stats() from any thread.
// The source owns its cameras.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "sitepose/calib/rectifier.hpp"
#include "sitepose/drivers/camera/stereo_pairer.hpp"
#include "sitepose/drivers/v4l2/v4l2_camera.hpp"
#include "sitepose/drivers/v4l2/v4l2_io.hpp"
#include "sitepose/pipeline/frame_source.hpp"

namespace sitepose::drivers::v4l2 {

using camera::Side;

struct V4l2SourceOptions {
  std::string left_device;   // "/dev/video0", or the side-by-side device
  std::string right_device;  // "" = left_device delivers side-by-side frames
  int width = 0;             // one device's capture size (side-by-side: the whole frame)
  int height = 0;
  double fps = 30.0;
  std::string pixel_format = "auto";  // auto | GREY | YUYV | MJPG
  int buffers = 4;
  std::string
      calibration_file;  // calib::load_stereo_rectifier: sitepose calibrate's YAML or a KITTI calib.txt
  std::int64_t pair_tolerance_ns = 5'000'000;
  double reconnect_min_s = 0.25;
  double reconnect_max_s = 8.0;
  double wait_for_camera_s = 0.0;
};

// Fails naming the option (and, for the calibration, the file and key).
Status check_v4l2_source_options(const V4l2SourceOptions& options);

struct V4l2SourceStats {
  std::uint64_t frames = 0;  // delivered pairs
  std::uint64_t pairs = 0;
  std::uint64_t unpaired_left = 0;
  std::uint64_t unpaired_right = 0;
  std::uint64_t skipped_at_start = 0;  // before the first pair (one device started later)
  std::uint64_t corrupt = 0;           // driver-flagged or undecodable, both devices
  std::uint64_t host_timestamps = 0;
  std::uint64_t sequence_gaps = 0;  // frames the drivers dropped
  std::uint64_t disconnects = 0;
  std::uint64_t reconnects = 0;
  bool connected = false;
  std::string last_error;
};

class V4l2Source final : public pipeline::FrameSource {
 public:
  // Errors start with the option they are about ("left_device: ...",
  // "right_device: ...", "calibration: ..."): kNotFound for an absent device
  // (after wait_for_camera_s), kInvalidArgument or kUnsupported for a size or
  // format the device does not offer.
  static Expected<std::unique_ptr<V4l2Source>> open(const V4l2SourceOptions& options,
                                                    std::shared_ptr<V4l2Io> io = system_v4l2_io());
  ~V4l2Source() override;

  const StereoCamera& camera() const override { return rectifier_.camera(); }
  std::string describe() const override;
  bool live() const override { return true; }
  double frame_rate_hz() const override { return fps_; }
  Expected<pipeline::SourceEvent> next(std::stop_token stop, pipeline::SteadyTime deadline) override;

  V4l2SourceStats stats() const;

 private:
  using Clock = std::chrono::steady_clock;
  V4l2Source(V4l2SourceOptions options, std::shared_ptr<V4l2Io> io, calib::StereoRectifier rectifier);
  bool side_by_side() const { return options_.right_device.empty(); }
  CameraOptions camera_options(Side side) const;
  Status open_cameras();
  void try_reconnect(Clock::time_point now);
  void lose(const std::string& why);
  // Reads what the devices have ready (waits up to `wait_ms`); a pair when
  // one is complete.
  Expected<std::optional<camera::StereoPair<RawFrame>>> poll_cameras(int wait_ms);
  Expected<pipeline::SourceEvent> deliver(const camera::StereoPair<RawFrame>& pair);
  void publish_stats();

  V4l2SourceOptions options_;
  std::shared_ptr<V4l2Io> io_;
  calib::StereoRectifier rectifier_;
  std::vector<PixelFormat> formats_;
  std::unique_ptr<V4l2Camera> cameras_[2];  // [1] unused when side by side
  camera::StereoPairer<RawFrame> pairer_;
  double fps_ = 0.0;
  std::int64_t seq_ = 0;
  CameraCounts retired_;  // counts of cameras closed since
  Clock::time_point next_retry_{};
  double backoff_s_ = 0.0;
  std::uint64_t disconnects_ = 0;
  std::uint64_t reconnects_ = 0;
  mutable std::mutex stats_mutex_;
  V4l2SourceStats stats_;  // guarded by stats_mutex_, a copy for other threads
};

}  // namespace sitepose::drivers::v4l2
