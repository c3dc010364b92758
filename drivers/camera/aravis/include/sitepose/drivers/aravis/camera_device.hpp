#pragma once
// The seam between the stereo source and a camera library: one opened,
// configured, streaming camera (CameraDevice) and a way to open one
// (CameraOpener). aravis_camera.hpp implements it on Aravis; tests wrap or
// replace it to unplug a camera or to feed frames without one.
// Threads: a device is used by one thread (the capture thread).

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/drivers/aravis/feature_file.hpp"
#include "sitepose/drivers/aravis/pixel_convert.hpp"

namespace sitepose::drivers::aravis {

struct CameraFrame {
  cv::Mat gray;                  // CV_8UC1, not yet rectified
  std::int64_t camera_t_ns = 0;  // the camera's own clock
  std::int64_t host_t_ns = 0;    // mapped to the host clock (clock_mapper.hpp)
  std::uint64_t frame_id = 0;    // the camera's block id
};

enum class TriggerMode {
  kFreeRun,   // each camera runs at frame_rate_hz on its own clock
  kSoftware,  // the source triggers both cameras at frame_rate_hz
  kHardware,  // a trigger line the feature file sets up (TriggerSelector, TriggerMode,
              // TriggerSource, TriggerActivation) starts each exposure; left as set there
  kAction,    // both cameras PTP-locked; the source sends one scheduled GigE Vision action
              // command per frame that both act on at the same PTP time (TriggerSource Action1)
};

// TriggerMode::kAction. The cameras take the keys (ActionDeviceKey,
// ActionGroupKey, ActionGroupMask); the source sends each command to
// `destination` and schedules it lead_time_ms ahead of the cameras' PTP time.
struct ActionSettings {
  std::uint32_t device_key = 0;
  std::uint32_t group_key = 1;
  std::uint32_t group_mask = 1;
  std::string destination;  // dotted IPv4; "" = the broadcast address of the left camera's host NIC
  double lead_time_ms = 10.0;
};

// A camera's clock latched at a known host time (TriggerMode::kAction).
struct ClockLatch {
  std::int64_t camera_t_ns = 0;                  // the camera's timestamp clock: PTP time when locked
  std::chrono::steady_clock::time_point host_t;  // when it was latched (mid-point of the latch command)
};

// Region of interest; width/height 0 = the sensor's full size.
struct Roi {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
};

// What the source asks of each camera of the pair.
struct CameraSettings {
  // Applied first, in order; the settings below then win. Null: none.
  // Shared and never changed after the source read it.
  std::shared_ptr<const FeatureFile> features;
  PixelFormat pixel_format = PixelFormat::kMono8;
  bool exposure_auto = true;
  double exposure_us = 10000.0;  // when not auto
  bool gain_auto = true;
  double gain_db = 0.0;  // when not auto
  Roi roi;
  TriggerMode trigger = TriggerMode::kFreeRun;
  ActionSettings action;  // trigger kAction
  double frame_rate_hz = 20.0;
  int packet_size_bytes = 0;  // GigE: 0 = negotiate the largest that passes
  int packet_delay_ns = 0;    // GigE inter-packet delay (two cameras on one link)
  int buffer_count = 8;       // stream buffer pool: frames the capture thread may fall behind by
};

enum class PollKind { kFrame, kNothing };

struct Poll {
  PollKind kind = PollKind::kNothing;
  CameraFrame frame;  // kFrame: gray8, camera_t_ns and host arrival (host_t_ns, unmapped)
};

class CameraDevice {
 public:
  virtual ~CameraDevice() = default;
  // Image size after the region of interest.
  virtual int width() const = 0;
  virtual int height() const = 0;
  virtual std::string describe() const = 0;
  // Waits up to `timeout` for a completed buffer. kNothing on timeout or on
  // an incomplete buffer (counted by the device); an error when the camera
  // is gone (control lost, stream failed).
  virtual Expected<Poll> poll(std::chrono::microseconds timeout) = 0;
  // One software trigger (TriggerMode::kSoftware).
  virtual Status trigger() = 0;
  // Buffers that arrived incomplete or failed.
  virtual std::uint64_t failed_buffers() const = 0;
  // Frames the camera sent while every stream buffer was taken (the
  // capture thread fell behind by more than the pool): lost on the host.
  virtual std::uint64_t underruns() const = 0;
  // TriggerMode::kAction: latches the camera's clock now and reads it (two
  // control round trips). kUnsupported where the camera has no latch.
  virtual Expected<ClockLatch> latch_clock() {
    return make_error(ErrorCode::kUnsupported, describe() + ": no timestamp latch");
  }
  // The host's IPv4 address the camera's control channel runs through; ""
  // when the camera is not reached over IP (USB3 Vision, in-process fakes).
  virtual std::string host_address_ipv4() const { return ""; }
};

// Opens, configures and starts streaming one camera (device_id: Aravis's
// "Vendor-Model-Serial", an IP address, ...). kNotFound when no device has
// the id, or (trigger kAction) its PTP clock is not locked yet: both are
// waited for (wait_for_camera_s, reconnects). kInvalidArgument when the
// camera refuses a setting, kUnsupported when it lacks a feature the
// settings need (the message names it).
using CameraOpener = std::function<Expected<std::unique_ptr<CameraDevice>>(const std::string& device_id,
                                                                           const CameraSettings&)>;

}  // namespace sitepose::drivers::aravis
