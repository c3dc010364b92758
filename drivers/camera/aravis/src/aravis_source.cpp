#include "sitepose/drivers/aravis/aravis_source.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

namespace sitepose::drivers::aravis {
namespace {

using pipeline::SourceEvent;
using pipeline::SourceEventKind;
using Clock = std::chrono::steady_clock;

using camera::side_name;

// How often the cameras' clocks are latched for the PTP time of an action:
// the host's oscillator drifts from PTP by at most ~100 ppm, 0.1 ms a
// second, far below any useful lead time.
constexpr Clock::duration kLatchInterval = std::chrono::seconds(1);

std::int64_t to_ns(Clock::duration d) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}

// A repeated warning: the first, then every 100th.
bool worth_warning(std::uint64_t count) { return count == 1 || count % 100 == 0; }

// Short polls, alternating between the cameras, keep a frame's wait for its
// partner and the answer to a stop request within milliseconds.
constexpr std::chrono::microseconds kPoll{1000};

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

// Sleeps until `until` or a stop request, whichever comes first.
void wait_until(std::stop_token stop, Clock::time_point until) {
  std::mutex mutex;
  std::condition_variable_any cv;
  std::unique_lock lock(mutex);
  cv.wait_until(lock, std::move(stop), until, [] { return false; });
}

const char* trigger_name(TriggerMode trigger) {
  switch (trigger) {
    case TriggerMode::kFreeRun: return "free-run";
    case TriggerMode::kSoftware: return "software trigger";
    case TriggerMode::kHardware: return "hardware trigger";
    case TriggerMode::kAction: return "scheduled action command";
  }
  return "?";
}

// Opens one camera, retrying absent ones (kNotFound) with back-off until
// `wait_s` has passed.
Expected<std::unique_ptr<CameraDevice>> open_waiting(const CameraOpener& opener, const std::string& id,
                                                     Side side, const AravisSourceOptions& o,
                                                     const std::stop_token& stop) {
  const Clock::time_point give_up = Clock::now() + seconds(o.wait_for_camera_s);
  double backoff_s = o.reconnect_min_s;
  for (;;) {
    auto device = opener(id, o.camera);
    if (device) return device;
    const std::string what = std::string(side_name(side)) + "_id = \"" + id + "\": " + device.error().message;
    if (device.error().code != ErrorCode::kNotFound || Clock::now() >= give_up || stop.stop_requested()) {
      const std::string waited = o.wait_for_camera_s > 0.0 && device.error().code == ErrorCode::kNotFound
                                     ? " (waited " + std::to_string(o.wait_for_camera_s) + " s)"
                                     : "";
      return make_error(device.error().code, what + waited);
    }
    spdlog::info("aravis: {}; retrying in {:.2f} s", what, backoff_s);
    wait_until(stop, std::min(give_up, Clock::now() + seconds(backoff_s)));
    backoff_s = std::min(2.0 * backoff_s, o.reconnect_max_s);
  }
}

}  // namespace

// Sends one camera's software trigger from a thread of its own while the
// capture thread sends the other's: one after the other, the second camera
// would be triggered a full round trip of the first trigger later
// (milliseconds on a loaded host), and expose that much apart.
class AravisSource::TriggerHelper {
 public:
  TriggerHelper() : thread_([this](const std::stop_token& stop) { run(stop); }) {}
  TriggerHelper(const TriggerHelper&) = delete;
  TriggerHelper& operator=(const TriggerHelper&) = delete;
  ~TriggerHelper() = default;  // thread_ is stopped and joined first (declared last)

  void start(CameraDevice& device) {
    {
      std::lock_guard lock(mutex_);
      device_ = &device;
      result_.reset();
    }
    cv_.notify_all();
  }
  Status wait() {
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [this] { return result_.has_value(); });
    return *std::exchange(result_, std::nullopt);
  }

 private:
  void run(const std::stop_token& stop) {
    std::unique_lock lock(mutex_);
    while (cv_.wait(lock, stop, [this] { return device_ != nullptr; })) {
      CameraDevice* device = std::exchange(device_, nullptr);
      lock.unlock();
      Status sent = device->trigger();
      lock.lock();
      result_ = std::move(sent);
      cv_.notify_all();
    }
  }

  std::mutex mutex_;
  std::condition_variable_any cv_;
  CameraDevice* device_ = nullptr;  // to trigger; null when idle
  std::optional<Status> result_;
  std::jthread thread_;
};

Status check_aravis_source_options(const AravisSourceOptions& o) {
  std::string bad;
  auto add = [&bad](const std::string& what) { bad += (bad.empty() ? "" : "; ") + what; };
  if (o.left_id.empty()) add("left_id: must not be empty");
  if (o.right_id.empty()) add("right_id: must not be empty");
  if (!o.left_id.empty() && o.left_id == o.right_id)
    add("right_id: must differ from left_id \"" + o.left_id + "\"");
  if (o.calibration.empty()) add("calibration: must name a calibration file");
  if (!(o.camera.frame_rate_hz > 0.0 && o.camera.frame_rate_hz <= 1000.0))
    add("frame_rate_hz: must be in (0, 1000]");
  const double half_period_ms = 500.0 / std::max(o.camera.frame_rate_hz, 1e-3);
  if (!(o.pair_tolerance_ms > 0.0 && o.pair_tolerance_ms < half_period_ms)) {
    add("pair_tolerance_ms = " + std::to_string(o.pair_tolerance_ms) + ": must be in (0, " +
        std::to_string(half_period_ms) +
        ") (below half a frame period, or frames pair with their neighbours)");
  }
  if (o.max_pending < 1) add("max_pending: must be >= 1");
  if (o.camera.buffer_count < 2) add("buffer_count: must be >= 2");
  if (!(o.lost_timeout_s > 0.0)) add("lost_timeout_s: must be > 0");
  if (!(o.reconnect_min_s > 0.0 && o.reconnect_min_s <= o.reconnect_max_s)) {
    add("reconnect_min_s: must be > 0 and <= reconnect_max_s");
  }
  if (!(o.wait_for_camera_s >= 0.0)) add("wait_for_camera_s: must be >= 0");
  if (o.camera.trigger == TriggerMode::kHardware && o.feature_file.empty()) {
    add("trigger: hardware needs a feature_file that sets up the trigger line");
  }
  if (o.camera.trigger == TriggerMode::kAction) {
    const ActionSettings& a = o.camera.action;
    if (o.pair_clock != PairClock::kCamera) {
      add("pair_clock: trigger action needs camera (both cameras stamp frames on the PTP clock)");
    }
    if (a.group_mask == 0) add("action.group_mask: must not be 0 (no camera would act)");
    const double period_ms = 1000.0 / std::max(o.camera.frame_rate_hz, 1e-3);
    if (!(a.lead_time_ms > 0.0 && a.lead_time_ms < period_ms)) {
      add("action.lead_time_ms = " + std::to_string(a.lead_time_ms) + ": must be in (0, " +
          std::to_string(period_ms) + ") (below a frame period: a camera queues few scheduled actions)");
    }
    if (!a.destination.empty() && !is_dotted_ipv4(a.destination)) {
      add("action.destination = \"" + a.destination + "\": expected a dotted IPv4 address, or \"\"");
    }
  }
  if (bad.empty()) return ok_status();
  return make_error(ErrorCode::kInvalidArgument, bad);
}

namespace {

// Where action commands go: the configured address, or the broadcast
// address of the NIC the left camera is reached through.
Expected<std::string> action_destination(const ActionSettings& action, const CameraDevice& left) {
  if (!action.destination.empty()) return action.destination;
  const std::string host = left.host_address_ipv4();
  if (host.empty()) {
    return make_error(ErrorCode::kInvalidArgument,
                      "action.destination: empty, and the left camera (" + left.describe() +
                          ") is not reached over IPv4, so there is no camera NIC to broadcast on: set it");
  }
  auto broadcast = subnet_broadcast_of(host);
  if (!broadcast)
    return make_error(broadcast.error().code, "action.destination: " + broadcast.error().message);
  return broadcast;
}

}  // namespace

Expected<std::unique_ptr<AravisSource>> AravisSource::open(const AravisSourceOptions& options_in,
                                                           CameraOpener opener, const std::stop_token& stop,
                                                           const DatagramPortOpener& ports) {
  SITEPOSE_TRY_STATUS(check_aravis_source_options(options_in));
  AravisSourceOptions options = options_in;
  if (!options.feature_file.empty()) {
    auto features = read_feature_file(options.feature_file);
    if (!features) return make_error(features.error().code, "feature_file: " + features.error().message);
    options.camera.features = std::make_shared<const FeatureFile>(std::move(*features));
  }
  std::array<std::unique_ptr<CameraDevice>, 2> devices;
  for (const Side side : {Side::kLeft, Side::kRight}) {
    const std::string& id = side == Side::kLeft ? options.left_id : options.right_id;
    SITEPOSE_TRY(devices[static_cast<int>(side)], open_waiting(opener, id, side, options, stop));
  }
  const CameraDevice& left = *devices[0];
  const CameraDevice& right = *devices[1];
  if (left.width() != right.width() || left.height() != right.height()) {
    return make_error(ErrorCode::kInvalidArgument, "right_id: the right camera (" + right.describe() +
                                                       ") delivers another image size than the left one (" +
                                                       left.describe() + ")");
  }
  auto rectifier = calib::load_stereo_rectifier(options.calibration, cv::Size(left.width(), left.height()));
  if (!rectifier) return make_error(rectifier.error().code, "calibration: " + rectifier.error().message);
  std::unique_ptr<ActionSender> actions;
  if (options.camera.trigger == TriggerMode::kAction) {
    SITEPOSE_TRY(const std::string destination, action_destination(options.camera.action, left));
    auto port = (ports ? ports : udp_port_opener())(destination, gvcp::kGvcpPort);
    if (!port) return make_error(port.error().code, "action.destination: " + port.error().message);
    spdlog::info("aravis: action commands to {}:{}", destination, gvcp::kGvcpPort);
    actions = std::make_unique<ActionSender>(std::move(*port));
  }
  return std::unique_ptr<AravisSource>(new AravisSource(options, std::move(opener), std::move(*rectifier),
                                                        std::move(devices), std::move(actions)));
}

AravisSource::AravisSource(const AravisSourceOptions& options, CameraOpener opener,
                           calib::StereoRectifier rectifier,
                           std::array<std::unique_ptr<CameraDevice>, 2> devices,
                           std::unique_ptr<ActionSender> actions)
    : options_(options),
      opener_(std::move(opener)),
      rectifier_(std::move(rectifier)),
      pairer_(static_cast<std::int64_t>(std::llround(options.pair_tolerance_ms * 1e6)),
              static_cast<std::size_t>(options.max_pending)),
      actions_(std::move(actions)) {
  const Clock::time_point now = Clock::now();
  for (int i = 0; i < 2; ++i) {
    Camera& c = cameras_[i];
    c.side = i == 0 ? Side::kLeft : Side::kRight;
    c.id = i == 0 ? options.left_id : options.right_id;
    c.device = std::move(devices[i]);
    c.last_frame = now;
    c.backoff_s = options.reconnect_min_s;
  }
  if (options.camera.trigger == TriggerMode::kSoftware) trigger_helper_ = std::make_unique<TriggerHelper>();
  next_trigger_ = now;
}

AravisSource::~AravisSource() = default;

std::string AravisSource::describe() const {
  auto side = [](const Camera& c) { return c.device ? c.device->describe() : c.id + " (lost)"; };
  return fmt::format("aravis stereo pair: left {}, right {}, {} at {:g} Hz, pairing within {:g} ms, {} {}",
                     side(cameras_[0]), side(cameras_[1]), trigger_name(options_.camera.trigger),
                     options_.camera.frame_rate_hz, options_.pair_tolerance_ms,
                     rectifier_.remaps() ? "rectified from" : "already rectified per", options_.calibration);
}

void AravisSource::lose(Camera& camera, const std::string& why) {
  spdlog::warn("aravis: {} camera {} lost ({}); reconnecting with back-off from {:.2f} s",
               side_name(camera.side), camera.id, why, options_.reconnect_min_s);
  camera.failed_before += camera.device->failed_buffers();
  camera.underruns_before += camera.device->underruns() - camera.underruns_base;
  camera.underruns_base = camera.underruns_seen = 0;
  camera.device.reset();
  camera.clock.reset();
  ptp_latch_.reset();  // latched from both cameras' devices
  camera.backoff_s = options_.reconnect_min_s;
  camera.next_attempt = Clock::now();
  pairer_.reset();
  ++disconnects_;
}

Status AravisSource::try_reconnect(Camera& camera, Clock::time_point now) {
  if (now < camera.next_attempt) return ok_status();
  auto device = opener_(camera.id, options_.camera);
  if (!device) {
    spdlog::debug("aravis: {} camera {}: {}", side_name(camera.side), camera.id, device.error().message);
    camera.next_attempt = Clock::now() + seconds(camera.backoff_s);
    camera.backoff_s = std::min(2.0 * camera.backoff_s, options_.reconnect_max_s);
    return ok_status();
  }
  if ((*device)->width() != rectifier_.camera().width || (*device)->height() != rectifier_.camera().height) {
    return make_error(ErrorCode::kIoError, std::string(side_name(camera.side)) + " camera " + camera.id +
                                               " came back as " + (*device)->describe() +
                                               ", not the calibrated image size");
  }
  spdlog::info("aravis: {} camera {} is back: {}", side_name(camera.side), camera.id, (*device)->describe());
  camera.device = std::move(*device);
  for (Camera& c : cameras_) c.last_frame = Clock::now();  // a triggered partner starts again too
  ++reconnects_;
  return ok_status();
}

Status AravisSource::poll_camera(Camera& camera, std::chrono::microseconds timeout) {
  auto polled = camera.device->poll(timeout);
  if (!polled) {
    lose(camera, polled.error().message);
    return ok_status();
  }
  const Clock::time_point now = Clock::now();
  if (polled->kind == PollKind::kFrame) {
    camera.last_frame = now;
    pair_frame(camera, std::move(polled->frame));
    warn_of_underruns(camera);
  } else if (expecting_frames() && now - camera.last_frame > seconds(options_.lost_timeout_s)) {
    lose(camera, "no frame for " + std::to_string(options_.lost_timeout_s) + " s");
  }
  return ok_status();
}

// Maps the frame to the host clock and queues it for pairing. On the host
// clock, the waiting frames of this camera move with its offset estimate,
// and while the estimate settles they may still move earlier.
void AravisSource::pair_frame(Camera& camera, CameraFrame frame) {
  const bool had_offset = !camera.clock.empty();
  const std::int64_t offset_before_ns = camera.clock.offset_ns();
  frame.host_t_ns = camera.clock.map(frame.camera_t_ns, frame.host_t_ns);
  if (options_.pair_clock == PairClock::kCamera) {
    const std::int64_t camera_t_ns = frame.camera_t_ns;
    pairer_.push(camera.side, camera_t_ns, std::move(frame));
    return;
  }
  if (had_offset) pairer_.shift(camera.side, camera.clock.offset_ns() - offset_before_ns);
  pairer_.set_settling(camera.side, !camera.clock.settled());
  const std::int64_t host_t_ns = frame.host_t_ns;
  pairer_.push(camera.side, host_t_ns, std::move(frame));
}

// A frame lost to an empty pool leaves its partner unpaired (or both lost):
// say why, once per new loss, with the key that sizes the pool.
void AravisSource::warn_of_underruns(Camera& camera) {
  const std::uint64_t n = camera.device->underruns();
  if (n <= camera.underruns_seen) return;
  spdlog::warn(
      "aravis: {} camera {}: {} frame(s) lost, no free stream buffer (source.aravis.buffer_count = {}): the "
      "capture thread fell behind",
      side_name(camera.side), camera.id, n - camera.underruns_seen, options_.camera.buffer_count);
  camera.underruns_seen = n;
}

// Latches both cameras' clocks: the left one's gives PTP time now; the
// difference between the two says whether they follow one grandmaster.
bool AravisSource::latch_clocks() {
  std::array<ClockLatch, 2> latches;
  for (int i = 0; i < 2; ++i) {
    auto latch = cameras_[i].device->latch_clock();
    if (!latch) {
      lose(cameras_[i], latch.error().message);
      return false;
    }
    latches[i] = *latch;
  }
  const std::int64_t skew_ns =
      (latches[1].camera_t_ns - latches[0].camera_t_ns) - to_ns(latches[1].host_t - latches[0].host_t);
  const std::int64_t tolerance_ns = std::llround(options_.pair_tolerance_ms * 1e6);
  if (std::abs(skew_ns) > tolerance_ns && std::abs(ptp_skew_ns_) <= tolerance_ns) {
    spdlog::warn(
        "aravis: the cameras' clocks differ by {:.3f} ms (more than pair_tolerance_ms): not locked to one "
        "PTP "
        "grandmaster; no action commands until they agree",
        static_cast<double>(skew_ns) * 1e-6);
  }
  ptp_skew_ns_ = skew_ns;
  ptp_latch_ = latches[0];
  return true;
}

// One scheduled action command for both cameras, lead_time_ms ahead of
// their PTP time now. None while their clocks disagree: each camera stamps
// a frame with the action time on its own clock, so frames exposed that far
// apart would carry one time and pair.
void AravisSource::send_action() {
  const Clock::time_point now = Clock::now();
  if ((!ptp_latch_ || now - ptp_latch_->host_t >= kLatchInterval) && !latch_clocks()) return;
  if (std::abs(ptp_skew_ns_) > std::llround(options_.pair_tolerance_ms * 1e6)) return;
  const ActionSettings& a = options_.camera.action;
  const auto lead = std::chrono::duration_cast<std::chrono::microseconds>(
      std::chrono::duration<double, std::milli>(a.lead_time_ms));
  const std::int64_t ptp_now_ns = ptp_latch_->camera_t_ns + to_ns(Clock::now() - ptp_latch_->host_t);
  const gvcp::ActionCommand command{a.device_key, a.group_key, a.group_mask,
                                    static_cast<std::uint64_t>(ptp_now_ns + to_ns(lead))};
  ++actions_sent_;
  // Acks after the action time would change nothing: wait up to the lead time.
  const auto result = actions_->send(command, 2, lead);
  if (!result) {
    action_acks_missing_ += 2;
    if (worth_warning(actions_sent_)) spdlog::warn("aravis: action command: {}", result.error().message);
    return;
  }
  for (const std::uint16_t status : result->failures) {
    if (worth_warning(++action_acks_refused_)) {
      spdlog::warn("aravis: a camera refused action command {} ({}; {} refusals)", result->request_id,
                   gvcp::status_name(status), action_acks_refused_);
    }
  }
  const int missing = 2 - result->acks - static_cast<int>(result->failures.size());
  for (int i = 0; i < missing; ++i) {
    if (worth_warning(++action_acks_missing_)) {
      spdlog::warn("aravis: action command {}: {} of 2 cameras acknowledged within {:g} ms ({} missing)",
                   result->request_id, result->acks + result->failures.size(), a.lead_time_ms,
                   action_acks_missing_);
    }
  }
}

void AravisSource::trigger_if_due(Clock::time_point now) {
  if (!triggered() || now < next_trigger_) return;
  if (!cameras_[0].device || !cameras_[1].device) return;
  Clock::time_point sent;
  if (options_.camera.trigger == TriggerMode::kAction) {
    sent = Clock::now();
    send_action();
  } else {
    trigger_helper_->start(*cameras_[1].device);
    sent = Clock::now();  // after waking the helper, which may have taken the CPU
    const Status left = cameras_[0].device->trigger();
    const Status right = trigger_helper_->wait();
    if (!left) lose(cameras_[0], left.error().message);
    if (!right) lose(cameras_[1], right.error().message);
  }
  if (!cameras_[0].device || !cameras_[1].device) return;
  // Never two triggers closer than a period: a camera still busy with the
  // last frame may drop a trigger, and the other camera of the pair may not
  // (unpaired frames). So a late trigger (a loaded host) delays the next one
  // instead of being made up for.
  const Clock::duration period = seconds(1.0 / options_.camera.frame_rate_hz);
  next_trigger_ = std::max(next_trigger_ + period, sent + period);
}

std::chrono::microseconds AravisSource::poll_timeout(Clock::time_point now) const {
  // No triggers while a camera is lost (trigger_if_due): nothing to be back for.
  if (!triggered() || !expecting_frames()) return kPoll;
  // Back in time for the next trigger: a late one shifts all after it.
  const auto until = std::chrono::duration_cast<std::chrono::microseconds>(next_trigger_ - now);
  return std::clamp(until, std::chrono::microseconds{0}, kPoll);
}

Expected<StereoFrame> AravisSource::make_frame(const camera::StereoPair<CameraFrame>& pair) {
  StereoFrame frame;
  SITEPOSE_TRY_STATUS(rectifier_.rectify(pair.left.gray, pair.right.gray, frame.left, frame.right));
  frame.seq = next_seq_++;
  // Strictly increasing, whatever the clock mapping did across a reconnect.
  // On the offset known now, which may have come down since the frames arrived.
  const std::int64_t left_ns = pair.left.camera_t_ns + cameras_[0].clock.offset_ns();
  const std::int64_t right_ns = pair.right.camera_t_ns + cameras_[1].clock.offset_ns();
  frame.t_left_ns = std::max(left_ns, last_t_ns_ + 1);
  frame.t_right_ns = right_ns + (frame.t_left_ns - left_ns);
  last_t_ns_ = frame.t_left_ns;
  frame.source_id = cameras_[0].id + "+" + cameras_[1].id;
  return frame;
}

Expected<SourceEvent> AravisSource::next(std::stop_token stop, pipeline::SteadyTime deadline) {
  if (!started_) {
    // Silence before the first call (the daemon still starting) is not a
    // lost camera, and the first software trigger is due now.
    started_ = true;
    for (Camera& c : cameras_) {
      c.last_frame = Clock::now();
      // The cameras stream from open(); a pool that ran dry before the first
      // call (the daemon still loading its detector) lost nothing of the run.
      if (c.device) c.underruns_base = c.underruns_seen = c.device->underruns();
    }
    next_trigger_ = Clock::now();
  }
  for (;;) {
    if (stop.stop_requested()) return SourceEvent{SourceEventKind::kEnd, {}};
    const Clock::time_point now = Clock::now();
    for (Camera& c : cameras_) {
      if (!c.device) SITEPOSE_TRY_STATUS(try_reconnect(c, now));
    }
    trigger_if_due(now);
    bool any = false;
    for (Camera& c : cameras_) {
      if (!c.device) continue;
      any = true;
      SITEPOSE_TRY_STATUS(poll_camera(c, poll_timeout(Clock::now())));
    }
    if (auto pair = pairer_.pop()) {
      SITEPOSE_TRY(StereoFrame frame, make_frame(*pair));
      return SourceEvent{SourceEventKind::kFrame, std::move(frame)};
    }
    if (Clock::now() >= deadline) return SourceEvent{SourceEventKind::kTimeout, {}};
    if (!any) {
      // Both cameras lost: sleep to the next reconnect attempt.
      const Clock::time_point attempt = std::min(cameras_[0].next_attempt, cameras_[1].next_attempt);
      wait_until(stop, std::min(deadline, std::max(attempt, Clock::now() + kPoll)));
    }
  }
}

AravisSourceStats AravisSource::stats() const {
  AravisSourceStats s;
  s.pairing = pairer_.counts();
  for (const Camera& c : cameras_) {
    s.failed_buffers += c.failed_before + (c.device ? c.device->failed_buffers() : 0);
    s.underruns += c.underruns_before + (c.underruns_seen - c.underruns_base);
  }
  s.disconnects = disconnects_;
  s.reconnects = reconnects_;
  s.clock_offset_left_ns = cameras_[0].clock.offset_ns();
  s.clock_offset_right_ns = cameras_[1].clock.offset_ns();
  s.actions_sent = actions_sent_;
  s.action_acks_missing = action_acks_missing_;
  s.action_acks_refused = action_acks_refused_;
  s.ptp_skew_ns = ptp_skew_ns_;
  return s;
}

}  // namespace sitepose::drivers::aravis
