#pragma once
// FrameSource over a stereo pair of cameras (GigE Vision / USB3 Vision via
// Aravis, or any CameraOpener): both cameras configured alike, frames
// converted to 8-bit gray, paired by timestamp (drivers/camera/common's
// stereo_pairer.hpp), mapped to the host clock (clock_mapper.hpp) and
// rectified with maps computed once (calib/rectifier.hpp).
// Timing: free-run (each camera at frame_rate_hz; pair_tolerance must cover
// the phase between the two), or software trigger (the source triggers both
// cameras every 1 / frame_rate_hz, never faster: a late trigger delays the
// rest; both triggers go out together, the right camera's from a helper
// thread, so the cameras expose within the trigger latency, not one trigger
// round trip apart).
// Action trigger (both cameras PTP-locked, pair_clock camera): every
// 1 / frame_rate_hz, paced like the software trigger, one scheduled GigE
// Vision action command goes to camera.action.destination (one datagram that
// both cameras receive) with an action time of the cameras' PTP time now
// plus camera.action.lead_time_ms; both expose at that PTP time. PTP time
// "now" is extrapolated on the host's steady clock from a latch of each
// camera's clock, renewed once a second (two control round trips each).
// While the two latched clocks disagree by more than pair_tolerance_ms no
// command goes out: each camera stamps a frame with the action time on its
// own clock, so frames exposed that far apart would still pair.
// Hardware trigger lines are set up in the cameras' feature files
// (firmware-config/), not here.
// A lost camera (Aravis reports it, or it sends nothing for lost_timeout_s)
// is closed and reopened with exponential back-off from reconnect_min_s to
// reconnect_max_s; meanwhile next() returns kTimeout at its deadline, so the
// pipeline reports a stall (LOST poses) and the daemon stays up. Waiting
// frames are dropped (counted) and pairing starts afresh when it is back.
// Threads: next() and the accessors from the capture thread only; the
// helper thread uses the right camera only while the capture thread waits
// for its trigger.

#include <array>
#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "sitepose/calib/rectifier.hpp"
#include "sitepose/drivers/aravis/action_sender.hpp"
#include "sitepose/drivers/aravis/camera_device.hpp"
#include "sitepose/drivers/aravis/clock_mapper.hpp"
#include "sitepose/drivers/camera/stereo_pairer.hpp"
#include "sitepose/pipeline/frame_source.hpp"

namespace sitepose::drivers::aravis {

using camera::PairerCounts;
using camera::Side;

// The clock frames pair on: the cameras' own when they share one (PTP, a
// common trigger clock), else the host-mapped times.
enum class PairClock { kCamera, kHost };

struct AravisSourceOptions {
  std::string left_id;
  std::string right_id;
  CameraSettings camera;    // both cameras
  std::string calibration;  // calib::load_stereo_rectifier: OpenCV stereo calibration YAML or KITTI calib.txt
  // A GenICam feature file (feature_file.hpp) applied to both cameras at
  // every open, before `camera`; "" = none. open() reads it into
  // camera.features.
  std::string feature_file;
  double pair_tolerance_ms = 5.0;
  PairClock pair_clock = PairClock::kHost;
  int max_pending = 4;  // frames of one side waiting for the other side's
  double lost_timeout_s = 1.0;
  double reconnect_min_s = 0.25;
  double reconnect_max_s = 8.0;
  // At start: how long to wait for an absent camera (0: fail at once).
  double wait_for_camera_s = 0.0;
};

// Checks values and their relations; messages name the field.
Status check_aravis_source_options(const AravisSourceOptions& options);

struct AravisSourceStats {
  PairerCounts pairing;
  std::uint64_t failed_buffers = 0;  // both cameras, all connections
  std::uint64_t underruns = 0;       // frames lost for want of a free stream buffer, both cameras,
                                     // as of each camera's last frame (not after capture stopped)
  std::uint64_t disconnects = 0;
  std::uint64_t reconnects = 0;
  std::int64_t clock_offset_left_ns = 0;  // host - camera (clock_mapper.hpp)
  std::int64_t clock_offset_right_ns = 0;
  // Trigger action: commands sent, and acknowledgements missing or refused
  // (each expects one SUCCESS ack per camera).
  std::uint64_t actions_sent = 0;
  std::uint64_t action_acks_missing = 0;
  std::uint64_t action_acks_refused = 0;
  // The latest latch: right camera's clock minus the left one's, minus the
  // host time between the two latches. Near 0 when both follow one PTP
  // grandmaster; its size is the latch's own uncertainty (round trips).
  std::int64_t ptp_skew_ns = 0;
};

class AravisSource final : public pipeline::FrameSource {
 public:
  // Opens both cameras (waiting up to wait_for_camera_s for absent ones) and
  // loads the calibration. Errors start with the option they are about
  // ("right_id = \"X\": ...", "calibration: ...", "feature_file: ..."):
  // kNotFound for an absent camera or feature file, kInvalidArgument for a
  // setting the camera refuses (a feature file's step: its file and line) or
  // cameras of different image sizes, the calibration's errors.
  // Trigger action: `ports` opens the socket the commands go out on (null:
  // UDP); "action.destination: ..." when there is no address to send to.
  static Expected<std::unique_ptr<AravisSource>> open(const AravisSourceOptions& options, CameraOpener opener,
                                                      const std::stop_token& stop = {},
                                                      const DatagramPortOpener& ports = {});
  ~AravisSource() override;

  const StereoCamera& camera() const override { return rectifier_.camera(); }
  std::string describe() const override;
  bool live() const override { return true; }
  double frame_rate_hz() const override { return options_.camera.frame_rate_hz; }
  Expected<pipeline::SourceEvent> next(std::stop_token stop, pipeline::SteadyTime deadline) override;

  AravisSourceStats stats() const;

 private:
  using Clock = std::chrono::steady_clock;
  class TriggerHelper;
  struct Camera {
    Side side = Side::kLeft;
    std::string id;
    std::unique_ptr<CameraDevice> device;  // null while lost
    ClockMapper clock;
    Clock::time_point last_frame{};
    Clock::time_point next_attempt{};
    double backoff_s = 0.0;
    std::uint64_t failed_before = 0;     // failed buffers of earlier connections
    std::uint64_t underruns_before = 0;  // underruns of earlier connections
    std::uint64_t underruns_base = 0;    // of this connection, before capture began (not losses)
    std::uint64_t underruns_seen = 0;    // of this connection, at its last frame (logged)
  };

  AravisSource(const AravisSourceOptions& options, CameraOpener opener, calib::StereoRectifier rectifier,
               std::array<std::unique_ptr<CameraDevice>, 2> devices, std::unique_ptr<ActionSender> actions);
  void lose(Camera& camera, const std::string& why);
  Status try_reconnect(Camera& camera, Clock::time_point now);
  Status poll_camera(Camera& camera, std::chrono::microseconds timeout);
  void pair_frame(Camera& camera, CameraFrame frame);
  void trigger_if_due(Clock::time_point now);
  bool latch_clocks();
  void send_action();
  bool triggered() const {
    return options_.camera.trigger == TriggerMode::kSoftware ||
           options_.camera.trigger == TriggerMode::kAction;
  }
  std::chrono::microseconds poll_timeout(Clock::time_point now) const;
  void warn_of_underruns(Camera& camera);
  // A triggered camera whose partner is lost gets no triggers: no frames
  // are due then, and silence is not a fault.
  bool expecting_frames() const { return !triggered() || (cameras_[0].device && cameras_[1].device); }
  Expected<StereoFrame> make_frame(const camera::StereoPair<CameraFrame>& pair);

  AravisSourceOptions options_;
  CameraOpener opener_;
  calib::StereoRectifier rectifier_;
  std::array<Camera, 2> cameras_;
  camera::StereoPairer<CameraFrame> pairer_;
  std::unique_ptr<TriggerHelper> trigger_helper_;  // software trigger only
  std::unique_ptr<ActionSender> actions_;          // action trigger only
  std::optional<ClockLatch> ptp_latch_;            // the left camera's, for PTP time now
  std::uint64_t actions_sent_ = 0;
  std::uint64_t action_acks_missing_ = 0;
  std::uint64_t action_acks_refused_ = 0;
  std::int64_t ptp_skew_ns_ = 0;
  Clock::time_point next_trigger_{};
  bool started_ = false;  // next() called once
  std::int64_t next_seq_ = 0;
  std::int64_t last_t_ns_ = 0;
  std::uint64_t disconnects_ = 0;
  std::uint64_t reconnects_ = 0;
};

}  // namespace sitepose::drivers::aravis
