#include "sitepose/drivers/aravis/aravis_camera.hpp"

#include <arv.h>
#include <time.h>

#include <atomic>
#include <mutex>
#include <utility>

#include "sitepose/drivers/aravis/gvcp_action.hpp"

namespace sitepose::drivers::aravis {
namespace {

// Takes and frees a GError: an Error naming the camera and the step.
Error take_error(GError* error, ErrorCode code, const std::string& what) {
  std::string message = what;
  if (error != nullptr) {
    message += ": ";
    message += error->message;
    g_error_free(error);
  }
  return Error{code, message};
}

std::int64_t realtime_now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::optional<PixelFormat> from_arv_format(ArvPixelFormat format) {
  switch (format) {
    case ARV_PIXEL_FORMAT_MONO_8: return PixelFormat::kMono8;
    case ARV_PIXEL_FORMAT_MONO_16: return PixelFormat::kMono16;
    case ARV_PIXEL_FORMAT_BAYER_RG_8: return PixelFormat::kBayerRG8;
    case ARV_PIXEL_FORMAT_BAYER_GR_8: return PixelFormat::kBayerGR8;
    case ARV_PIXEL_FORMAT_BAYER_GB_8: return PixelFormat::kBayerGB8;
    case ARV_PIXEL_FORMAT_BAYER_BG_8: return PixelFormat::kBayerBG8;
    default: return std::nullopt;
  }
}

class AravisCamera final : public CameraDevice {
 public:
  AravisCamera(ArvCamera* camera, std::string id) : camera_(camera), id_(std::move(id)) {
    lost_handler_ = g_signal_connect(arv_camera_get_device(camera_), "control-lost",
                                     G_CALLBACK(&AravisCamera::on_control_lost), this);
  }
  ~AravisCamera() override;
  AravisCamera(const AravisCamera&) = delete;
  AravisCamera& operator=(const AravisCamera&) = delete;

  Status configure(const CameraSettings& s);
  Status start(int buffer_count);

  int width() const override { return width_; }
  int height() const override { return height_; }
  std::string describe() const override { return description_; }
  Expected<Poll> poll(std::chrono::microseconds timeout) override;
  Status trigger() override;
  std::uint64_t failed_buffers() const override { return failed_; }
  std::uint64_t underruns() const override {
    guint64 n = 0;
    arv_stream_get_statistics(stream_, nullptr, nullptr, &n);
    return n;
  }
  Expected<ClockLatch> latch_clock() override;
  std::string host_address_ipv4() const override;

 private:
  static void on_control_lost(ArvDevice* /*device*/, gpointer self) {
    static_cast<AravisCamera*>(self)->control_lost_.store(true);
  }
  Status check(GError* error, const std::string& what, ErrorCode code = ErrorCode::kInvalidArgument) const {
    if (error == nullptr) return ok_status();
    return Unexpected{take_error(error, code, id_ + ": " + what)};
  }
  Status apply_features(const FeatureFile& file);
  Status configure_exposure_gain(const CameraSettings& s);
  Status configure_timing(const CameraSettings& s);
  Status configure_action(const ActionSettings& a);
  Status check_ptp_locked();
  // The first of `names` the camera has; "" when none.
  std::string first_available(std::initializer_list<const char*> names) const;

  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  gulong lost_handler_ = 0;
  std::string id_;
  std::string description_;
  int width_ = 0;
  int height_ = 0;
  std::uint64_t failed_ = 0;
  std::string latch_command_;  // kAction: the timestamp latch command and its value feature
  std::string latch_value_;
  std::atomic<bool> control_lost_{false};  // set by Aravis's heartbeat thread
};

AravisCamera::~AravisCamera() {
  GError* error = nullptr;
  if (stream_ != nullptr) {
    arv_camera_stop_acquisition(camera_, &error);
    if (error != nullptr) g_error_free(error);  // a lost camera cannot be stopped
    g_object_unref(stream_);
  }
  g_signal_handler_disconnect(arv_camera_get_device(camera_), lost_handler_);
  g_object_unref(camera_);
}

// Each step of the feature file in order; the first one the camera refuses
// ends the configuration, named by its file and line.
Status AravisCamera::apply_features(const FeatureFile& file) {
  ArvDevice* device = arv_camera_get_device(camera_);
  for (const FeatureStep& step : file.steps) {
    GError* error = nullptr;
    if (step.value) {
      arv_device_set_features_from_string(device, step.text().c_str(), &error);
    } else {
      arv_device_execute_command(device, step.name.c_str(), &error);
    }
    SITEPOSE_TRY_STATUS(
        check(error, "feature_file " + file.path + ":" + std::to_string(step.line) + ": " + step.text()));
  }
  return ok_status();
}

Status AravisCamera::configure(const CameraSettings& s) {
  if (s.features) {
    SITEPOSE_TRY_STATUS(apply_features(*s.features));
  }
  GError* error = nullptr;
  arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
  SITEPOSE_TRY_STATUS(check(error, "AcquisitionMode Continuous"));
  arv_camera_set_pixel_format_from_string(camera_, to_string(s.pixel_format), &error);
  SITEPOSE_TRY_STATUS(check(error, std::string("pixel format ") + to_string(s.pixel_format)));
  Roi roi = s.roi;
  if (roi.width == 0 || roi.height == 0) {
    arv_camera_get_sensor_size(camera_, &roi.width, &roi.height, &error);
    SITEPOSE_TRY_STATUS(check(error, "sensor size"));
    roi.width -= roi.x;
    roi.height -= roi.y;
  }
  arv_camera_set_region(camera_, roi.x, roi.y, roi.width, roi.height, &error);
  SITEPOSE_TRY_STATUS(check(error, "region"));
  arv_camera_get_region(camera_, nullptr, nullptr, &width_, &height_, &error);
  SITEPOSE_TRY_STATUS(check(error, "region"));
  if (width_ != roi.width || height_ != roi.height) {
    return make_error(ErrorCode::kInvalidArgument,
                      id_ + ": region " + std::to_string(roi.width) + "x" + std::to_string(roi.height) +
                          " not accepted (the camera set " + std::to_string(width_) + "x" +
                          std::to_string(height_) + "; check the sensor size and the width increment)");
  }
  SITEPOSE_TRY_STATUS(configure_exposure_gain(s));
  SITEPOSE_TRY_STATUS(configure_timing(s));
  if (arv_camera_is_gv_device(camera_)) {
    if (s.packet_size_bytes > 0) {
      arv_camera_gv_set_packet_size(camera_, s.packet_size_bytes, &error);
    } else {
      arv_camera_gv_auto_packet_size(camera_, &error);
    }
    SITEPOSE_TRY_STATUS(check(error, "GevSCPSPacketSize"));
    if (s.packet_delay_ns > 0) arv_camera_gv_set_packet_delay(camera_, s.packet_delay_ns, &error);
    SITEPOSE_TRY_STATUS(check(error, "GevSCPD packet delay"));
  }
  description_ =
      id_ + " " + std::to_string(width_) + "x" + std::to_string(height_) + " " + to_string(s.pixel_format);
  return ok_status();
}

// Auto where asked and available; a camera without auto keeps its own value.
Status AravisCamera::configure_exposure_gain(const CameraSettings& s) {
  GError* error = nullptr;
  if (s.exposure_auto) {
    const bool available = arv_camera_is_exposure_auto_available(camera_, &error);
    SITEPOSE_TRY_STATUS(check(error, "ExposureAuto"));
    if (available) arv_camera_set_exposure_time_auto(camera_, ARV_AUTO_CONTINUOUS, &error);
    SITEPOSE_TRY_STATUS(check(error, "ExposureAuto Continuous"));
  } else {
    arv_camera_set_exposure_time(camera_, s.exposure_us, &error);
    SITEPOSE_TRY_STATUS(check(error, "exposure " + std::to_string(s.exposure_us) + " us"));
  }
  if (s.gain_auto) {
    const bool available = arv_camera_is_gain_auto_available(camera_, &error);
    SITEPOSE_TRY_STATUS(check(error, "GainAuto"));
    if (available) arv_camera_set_gain_auto(camera_, ARV_AUTO_CONTINUOUS, &error);
    SITEPOSE_TRY_STATUS(check(error, "GainAuto Continuous"));
  } else {
    arv_camera_set_gain(camera_, s.gain_db, &error);
    SITEPOSE_TRY_STATUS(check(error, "gain " + std::to_string(s.gain_db) + " dB"));
  }
  return ok_status();
}

Status AravisCamera::configure_timing(const CameraSettings& s) {
  GError* error = nullptr;
  if (s.trigger == TriggerMode::kSoftware) {
    const bool supported = arv_camera_is_software_trigger_supported(camera_, &error);
    SITEPOSE_TRY_STATUS(check(error, "TriggerSource Software"));
    if (!supported) return make_error(ErrorCode::kInvalidArgument, id_ + ": no software trigger");
    arv_camera_set_trigger(camera_, "Software", &error);
    return check(error, "TriggerSource Software");
  }
  if (s.trigger == TriggerMode::kHardware) return ok_status();  // the feature file set the line up
  if (s.trigger == TriggerMode::kAction) return configure_action(s.action);
  arv_camera_clear_triggers(camera_, &error);
  SITEPOSE_TRY_STATUS(check(error, "TriggerMode Off"));
  const bool rate_available = arv_camera_is_frame_rate_available(camera_, &error);
  SITEPOSE_TRY_STATUS(check(error, "AcquisitionFrameRate"));
  if (rate_available) arv_camera_set_frame_rate(camera_, s.frame_rate_hz, &error);
  return check(error, "frame rate " + std::to_string(s.frame_rate_hz) + " Hz");
}

std::string AravisCamera::first_available(std::initializer_list<const char*> names) const {
  ArvDevice* device = arv_camera_get_device(camera_);
  for (const char* name : names) {
    GError* error = nullptr;
    const bool available = arv_device_is_feature_available(device, name, &error);
    if (error != nullptr) g_error_free(error);  // a feature the camera cannot read is not available
    if (available) return name;
  }
  return "";
}

// Scheduled actions act on the PTP clock: the camera must have PTP on and
// follow the grandmaster. Not locked yet is kNotFound, which the source
// waits for (a camera locks within seconds of ptp4l starting); PTP off or
// missing is the feature file's or the camera's, named.
Status AravisCamera::check_ptp_locked() {
  ArvDevice* device = arv_camera_get_device(camera_);
  const std::string enable = first_available({"PtpEnable", "GevIEEE1588"});
  if (enable.empty()) {
    return make_error(
        ErrorCode::kUnsupported,
        id_ + ": trigger action needs PTP, and the camera has neither PtpEnable nor GevIEEE1588");
  }
  GError* error = nullptr;
  const bool on = arv_device_get_boolean_feature_value(device, enable.c_str(), &error);
  SITEPOSE_TRY_STATUS(check(error, enable));
  if (!on) {
    return make_error(ErrorCode::kInvalidArgument, id_ + ": " + enable +
                                                       " is false: trigger action needs PTP on (" + enable +
                                                       "=true in the feature file, firmware-config/genicam)");
  }
  // The status is of a latched data set where the camera has a latch.
  const std::string latch = first_available({"PtpDataSetLatch", "GevIEEE1588DataSetLatch"});
  if (!latch.empty()) {
    arv_device_execute_command(device, latch.c_str(), &error);
    SITEPOSE_TRY_STATUS(check(error, latch, ErrorCode::kIoError));
  }
  const std::string status = first_available({"PtpStatus", "GevIEEE1588StatusLatched", "GevIEEE1588Status"});
  if (status.empty()) {
    return make_error(ErrorCode::kUnsupported,
                      id_ + ": trigger action: no PTP status feature (PtpStatus, GevIEEE1588Status)");
  }
  const char* value = arv_device_get_string_feature_value(device, status.c_str(), &error);
  SITEPOSE_TRY_STATUS(check(error, status, ErrorCode::kIoError));
  const std::string state = value != nullptr ? value : "";
  if (state != "Slave") {
    return make_error(ErrorCode::kNotFound,
                      id_ + ": " + status + " is " + state +
                          ", not Slave: not locked to the PTP grandmaster (ptp4l on the "
                          "camera NIC, firmware-config/README.md)");
  }
  return ok_status();
}

Status AravisCamera::configure_action(const ActionSettings& a) {
  SITEPOSE_TRY_STATUS(check_ptp_locked());
  latch_command_ = first_available({"TimestampLatch", "GevTimestampControlLatch"});
  latch_value_ = latch_command_ == "TimestampLatch" ? "TimestampLatchValue" : "GevTimestampValue";
  if (latch_command_.empty() || first_available({latch_value_.c_str()}).empty()) {
    return make_error(ErrorCode::kUnsupported, id_ +
                                                   ": trigger action: no timestamp latch "
                                                   "(TimestampLatch + TimestampLatchValue, or "
                                                   "GevTimestampControlLatch + GevTimestampValue)");
  }
  ArvDevice* device = arv_camera_get_device(camera_);
  GError* error = nullptr;
  if (!first_available({"ActionSelector"}).empty()) {
    arv_device_set_integer_feature_value(device, "ActionSelector", 1, &error);
    SITEPOSE_TRY_STATUS(check(error, "ActionSelector 1"));
  }
  const std::pair<const char*, std::uint32_t> keys[] = {
      {"ActionDeviceKey", a.device_key}, {"ActionGroupKey", a.group_key}, {"ActionGroupMask", a.group_mask}};
  for (const auto& [name, value] : keys) {
    if (first_available({name}).empty()) {
      return make_error(ErrorCode::kUnsupported, id_ + ": trigger action: no " + std::string(name) +
                                                     " (the camera takes no action commands)");
    }
    arv_device_set_integer_feature_value(device, name, value, &error);
    SITEPOSE_TRY_STATUS(check(error, std::string(name) + " " + gvcp::format_key(value)));
  }
  if (!first_available({"TriggerSelector"}).empty()) {
    arv_device_set_string_feature_value(device, "TriggerSelector", "FrameStart", &error);
    SITEPOSE_TRY_STATUS(check(error, "TriggerSelector FrameStart"));
  }
  const bool action1 = arv_device_is_enumeration_entry_available(device, "TriggerSource", "Action1", &error);
  SITEPOSE_TRY_STATUS(check(error, "TriggerSource"));
  if (!action1) {
    return make_error(ErrorCode::kUnsupported, id_ + ": trigger action: TriggerSource has no Action1");
  }
  arv_device_set_string_feature_value(device, "TriggerSource", "Action1", &error);
  SITEPOSE_TRY_STATUS(check(error, "TriggerSource Action1"));
  arv_device_set_string_feature_value(device, "TriggerMode", "On", &error);
  return check(error, "TriggerMode On");
}

Expected<ClockLatch> AravisCamera::latch_clock() {
  if (latch_command_.empty()) return CameraDevice::latch_clock();
  ArvDevice* device = arv_camera_get_device(camera_);
  GError* error = nullptr;
  const auto before = std::chrono::steady_clock::now();
  arv_device_execute_command(device, latch_command_.c_str(), &error);
  const auto after = std::chrono::steady_clock::now();
  SITEPOSE_TRY_STATUS(check(error, latch_command_, ErrorCode::kIoError));
  const gint64 value = arv_device_get_integer_feature_value(device, latch_value_.c_str(), &error);
  SITEPOSE_TRY_STATUS(check(error, latch_value_, ErrorCode::kIoError));
  return ClockLatch{value, before + (after - before) / 2};
}

std::string AravisCamera::host_address_ipv4() const {
  if (!arv_camera_is_gv_device(camera_)) return "";
  GSocketAddress* address =
      arv_gv_device_get_interface_address(ARV_GV_DEVICE(arv_camera_get_device(camera_)));
  if (address == nullptr) return "";
  gchar* text = g_inet_address_to_string(g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(address)));
  std::string out = text != nullptr ? text : "";
  g_free(text);
  return out;
}

Status AravisCamera::start(int buffer_count) {
  GError* error = nullptr;
  stream_ = arv_camera_create_stream(camera_, nullptr, nullptr, &error);
  if (stream_ == nullptr) return check(error, "stream", ErrorCode::kIoError);
  const guint payload = arv_camera_get_payload(camera_, &error);
  SITEPOSE_TRY_STATUS(check(error, "payload size", ErrorCode::kIoError));
  for (int i = 0; i < buffer_count; ++i) arv_stream_push_buffer(stream_, arv_buffer_new(payload, nullptr));
  arv_camera_start_acquisition(camera_, &error);
  return check(error, "AcquisitionStart", ErrorCode::kIoError);
}

Expected<Poll> AravisCamera::poll(std::chrono::microseconds timeout) {
  if (control_lost_.load()) return make_error(ErrorCode::kIoError, id_ + ": control channel lost");
  ArvBuffer* buffer = arv_stream_timeout_pop_buffer(stream_, static_cast<guint64>(timeout.count()));
  if (buffer == nullptr) return Poll{};
  Poll out;
  const auto format = from_arv_format(arv_buffer_get_image_pixel_format(buffer));
  if (arv_buffer_get_status(buffer) != ARV_BUFFER_STATUS_SUCCESS || !format) {
    ++failed_;
  } else {
    size_t size = 0;
    const void* data = arv_buffer_get_data(buffer, &size);
    RawImage raw{static_cast<const std::uint8_t*>(data), size, arv_buffer_get_image_width(buffer),
                 arv_buffer_get_image_height(buffer), *format};
    // The fake camera with a custom fill leaves the size at 0 (PLATFORM.md).
    if (raw.size_bytes == 0) {
      raw.size_bytes = static_cast<std::size_t>(raw.width) * static_cast<std::size_t>(raw.height) *
                       static_cast<std::size_t>(bytes_per_pixel(*format));
    }
    auto gray = to_gray8(raw);
    if (gray) {
      out.kind = PollKind::kFrame;
      out.frame.gray = std::move(*gray);
      out.frame.camera_t_ns = static_cast<std::int64_t>(arv_buffer_get_timestamp(buffer));
      const auto system_ns = static_cast<std::int64_t>(arv_buffer_get_system_timestamp(buffer));
      out.frame.host_t_ns = system_ns > 0 ? system_ns : realtime_now_ns();
      out.frame.frame_id = arv_buffer_get_frame_id(buffer);
    } else {
      ++failed_;
    }
  }
  arv_stream_push_buffer(stream_, buffer);
  return out;
}

Status AravisCamera::trigger() {
  GError* error = nullptr;
  arv_camera_software_trigger(camera_, &error);
  return check(error, "TriggerSoftware", ErrorCode::kIoError);
}

Expected<std::unique_ptr<CameraDevice>> open_aravis_camera(const std::string& id,
                                                           const CameraSettings& settings,
                                                           const AravisOpenerOptions& options) {
  std::string arv_id = id;
  if (arv_id.rfind("Fake_", 0) == 0) {
    static std::once_flag fake_enabled;
    std::call_once(fake_enabled, [] { arv_enable_interface("Fake"); });
    arv_id = "Fake_1";  // the fake interface's only id; each open is a new camera
  }
  GError* error = nullptr;
  ArvCamera* camera = arv_camera_new(arv_id.c_str(), &error);
  if (camera == nullptr) {
    return Unexpected{take_error(error, ErrorCode::kNotFound, "camera " + id + ": not found")};
  }
  auto device = std::make_unique<AravisCamera>(camera, id);
  SITEPOSE_TRY_STATUS(device->configure(settings));
  if (options.on_open) options.on_open(camera, id);
  SITEPOSE_TRY_STATUS(device->start(settings.buffer_count));
  return std::unique_ptr<CameraDevice>(std::move(device));
}

}  // namespace

CameraOpener aravis_camera_opener(AravisOpenerOptions options) {
  return [options = std::move(options)](const std::string& id, const CameraSettings& settings) {
    return open_aravis_camera(id, settings, options);
  };
}

}  // namespace sitepose::drivers::aravis
