#include "sitepose/daemon/daemon.hpp"

#include <pthread.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>

#include "sitepose/config/config.hpp"
#include "sitepose/core/build_info.hpp"
#include "sitepose/core/centred_camera.hpp"
#include "sitepose/core/log.hpp"
#include "sitepose/drivers/aravis/aravis_camera.hpp"
#include "sitepose/drivers/aravis/feature_file.hpp"
#include "sitepose/geo/nmea.hpp"
#include "sitepose/io/output_path.hpp"
#include "sitepose/pipeline/detect_stage.hpp"
#include "sitepose/pipeline/frame_source.hpp"
#include "sitepose/pipeline/replay_source.hpp"
#include "sitepose/pipeline/slam_tracker.hpp"
#include "sitepose/pipeline/supervisor.hpp"

namespace sitepose::daemon {

drivers::socketcan::SocketCanSinkOptions socketcan_sink_options(const CanOutputConfig& can) {
  drivers::socketcan::SocketCanSinkOptions o;
  o.interface = can.interface;
  o.queue_frames = static_cast<std::size_t>(can.socketcan.queue_frames);
  o.node.name = can.socketcan.name;
  o.node.preferred_address = can.frames.source_address;
  o.node.heartbeat_interval_ns =
      static_cast<std::int64_t>(std::llround(can.socketcan.heartbeat_interval_s * 1e9));
  o.node.transmitted_pgns = output::transmitted_pgns(can.frames);
  o.node.product.software_version = version_string();
  o.node.product.serial_code = std::to_string(can.socketcan.name.identity_number);
  return o;
}

Expected<std::unique_ptr<pipeline::FrameSource>> open_source(const DaemonConfig& config,
                                                             const CameraAccess& access) {
  if (config.source_type == "aravis") {
    drivers::aravis::AravisSourceOptions options = config.aravis;
    options.wait_for_camera_s = config.wait_for_camera_s;
    auto source = drivers::aravis::AravisSource::open(
        options, access.aravis ? access.aravis : drivers::aravis::aravis_camera_opener());
    if (!source) return make_error(source.error().code, "source.aravis." + source.error().message);
    return std::unique_ptr<pipeline::FrameSource>(std::move(*source));
  }
  if (config.source_type == "v4l2") {
    auto source = drivers::v4l2::V4l2Source::open(
        v4l2_source_options(config), access.v4l2 ? access.v4l2 : drivers::v4l2::system_v4l2_io());
    if (!source) return make_error(source.error().code, "source.v4l2." + source.error().message);
    return std::unique_ptr<pipeline::FrameSource>(std::move(*source));
  }
  SITEPOSE_TRY(auto replay, pipeline::ReplaySource::open(replay_options(config)));
  return std::unique_ptr<pipeline::FrameSource>(std::move(replay));
}

namespace {

// A start finds the camera in the source; a check without a camera source
// (it may be off) loads the detector with a nominal one.
StereoCamera nominal_camera() { return centred_camera(640, 480, 500.0, 0.12); }

// dynamic.detector_isolation. A hung host is killed once a call has taken
// as long again as its deadline (and at least 100 ms more): the detect
// stage abandoned the call at the deadline, and the restarted host is
// ready for the frames after.
detect::IsolationOptions isolation_options(const DaemonConfig& config, double deadline_ms,
                                           std::shared_ptr<detect::HostCounters> counters) {
  detect::IsolationOptions o;
  o.in_child_process = config.detect_deadline.detector_isolation == DetectorIsolation::kProcess;
  o.call_timeout = std::chrono::milliseconds(std::llround(deadline_ms + std::max(deadline_ms, 100.0)));
  o.counters = std::move(counters);
  return o;
}

// dynamic.detector_deadline_ms, or its default: one frame period of a live
// source. A replay at rate max is lossless and has no period to keep up
// with: a generous bound keeps its results independent of this machine's
// load while a hang still ends.
constexpr double kLosslessDeadlineMs = 5000.0;
double detector_deadline_ms(const DaemonConfig& config, const pipeline::FrameSource& source) {
  if (config.detect_deadline.detector_deadline_ms > 0.0) return config.detect_deadline.detector_deadline_ms;
  const double fps = pipeline::known_or_assumed_frame_rate_hz(source.frame_rate_hz());
  return source.live() ? 1000.0 / fps : kLosslessDeadlineMs;
}

// `camera`: the replay sequence's (none for a camera source).
Status check_detector(const DaemonConfig& config, std::optional<StereoCamera> camera) {
  if (config.sitepose.dynamic.mode == config::MaskingMode::kNone) return ok_status();
  detect::DetectorContext context;
  context.camera = config.sitepose.camera.stereo ? config.sitepose.camera.stereo : camera;
  if (!context.camera) context.camera = nominal_camera();
  if (config.source_type == "replay") context.sequence_dir = config.replay.sequence_dir;
  // Loaded as a start loads it: a plugin .so in its host, so that a plugin
  // that crashes at load fails the check instead of ending it.
  const double deadline_ms = config.detect_deadline.detector_deadline_ms > 0.0
                                 ? config.detect_deadline.detector_deadline_ms
                                 : kLosslessDeadlineMs;
  auto hook =
      pipeline::make_detect_hook(config.sitepose, context, isolation_options(config, deadline_ms, {}));
  if (!hook) return make_error(ErrorCode::kInvalidArgument, "detector: " + hook.error().message);
  return ok_status();
}

// The site map kept in mapping.map_file: loaded into the tracker now,
// saved by the returned store.
std::unique_ptr<MapStore> open_map_store(const DaemonConfig& config, pipeline::SlamPoseTracker& tracker) {
  pipeline::SlamPoseTracker* t = &tracker;
  const auto anchor = site_anchor_record(config.geo);
  const MapLoadOutcome loaded = load_site_map(config.map.map_file, anchor,
                                              [t](map::MapData map) { return t->load_map(std::move(map)); });
  auto store = std::make_unique<MapStore>(config.map, anchor, [t] { return t->copy_map(); });
  if (!loaded.refused_why.empty() && loaded.moved_to.empty()) {
    store->disable("not saving over the refused map file " + config.map.map_file);
  }
  return store;
}

// camera.stereo (or what source.orbslam2_settings put there) must have the
// size of the source's images: found at start, not at the first frame.
Expected<StereoCamera> tracking_camera(const DaemonConfig& config, const StereoCamera& source) {
  if (!config.sitepose.camera.stereo) return source;
  const StereoCamera& camera = *config.sitepose.camera.stereo;
  if (camera.width == source.width && camera.height == source.height) return camera;
  const std::string from = config.orbslam2_settings.empty()
                               ? ""
                               : " (from source.orbslam2_settings " + config.orbslam2_settings + ")";
  return make_error(ErrorCode::kInvalidArgument,
                    "camera.stereo" + from + " is " + std::to_string(camera.width) + "x" +
                        std::to_string(camera.height) + " but the source's images are " +
                        std::to_string(source.width) + "x" + std::to_string(source.height));
}

Status check_output(bool enabled, const std::string& key, const std::string& path) {
  if (!enabled) return ok_status();
  auto st = io::check_output_path(path);
  if (!st) return make_error(ErrorCode::kInvalidArgument, key + ": " + st.error().message);
  return ok_status();
}

}  // namespace

Status check_startable(const DaemonConfig& config) {
  std::optional<StereoCamera> camera;
  if (config.source_type == "replay") {
    auto source = pipeline::ReplaySource::open(replay_options(config));
    if (!source) {
      return make_error(ErrorCode::kInvalidArgument, "source.replay.sequence: " + source.error().message);
    }
    camera = (*source)->camera();
    SITEPOSE_TRY_STATUS(tracking_camera(config, *camera));
  }
  if (config.source_type == "aravis" && !config.aravis.feature_file.empty()) {
    if (auto features = drivers::aravis::read_feature_file(config.aravis.feature_file); !features) {
      return make_error(ErrorCode::kInvalidArgument,
                        "source.aravis.feature_file: " + features.error().message);
    }
  }
  SITEPOSE_TRY_STATUS(check_detector(config, camera));
  if (auto anchoring = Anchoring::create(config.geo, publish_options(config)); !anchoring) {
    return Unexpected{anchoring.error()};
  }
  if (config.geo.mode == GeoMode::kOnline && config.geo.gnss_input == GnssInput::kNmeaFile) {
    if (auto fixes = geo::read_nmea_file(config.geo.nmea_file, {}); !fixes) return Unexpected{fixes.error()};
  }
  if (config.lcm.enabled) SITEPOSE_TRY_STATUS(output::check_lcm_url(config.lcm.lcm.url, "outputs.lcm.url"));
  if (config.geo.mode == GeoMode::kOnline && config.geo.gnss_input == GnssInput::kLcm &&
      !config.lcm.enabled) {
    return make_error(ErrorCode::kInvalidArgument,
                      "geo.online.gnss_input = lcm: needs outputs.lcm.enabled = true");
  }
  SITEPOSE_TRY_STATUS(check_output(config.can.enabled && config.can.sink == CanSinkKind::kCandumpFile,
                                   "outputs.can.path", config.can.path));
  SITEPOSE_TRY_STATUS(
      check_output(config.trajectory.enabled, "outputs.trajectory.path", config.trajectory.path));
  SITEPOSE_TRY_STATUS(check_output(!config.map.map_file.empty(), "mapping.map_file", config.map.map_file));
  return ok_status();
}

// The detect stage's hook: the detector (a plugin .so in its host unless
// dynamic.detector_isolation is in-process) behind its deadline.
Expected<std::unique_ptr<pipeline::DetectHook>> Daemon::open_detect_stage(const pipeline::FrameSource& source,
                                                                          const StereoCamera& camera) {
  detect::DetectorContext context;
  if (config_.source_type == "replay") context.sequence_dir = config_.replay.sequence_dir;
  context.camera = camera;
  const double deadline_ms = detector_deadline_ms(config_, source);
  SITEPOSE_TRY(auto detect_hook,
               pipeline::make_detect_hook(config_.sitepose, context,
                                          isolation_options(config_, deadline_ms, detector_host_)));
  std::string deadline_text;
  if (config_.sitepose.dynamic.mode != config::MaskingMode::kNone) {
    auto bounded = std::make_unique<pipeline::DeadlineDetect>(
        std::move(detect_hook), std::chrono::nanoseconds(std::llround(deadline_ms * 1e6)));
    deadline_detect_ = bounded.get();
    detect_hook = std::move(bounded);
    deadline_text = fmt::format(", deadline {:.1f} ms", deadline_ms);
  }
  spdlog::info("detect stage: {}, dynamic.mode {}{}", detect_hook->name(),
               config::to_string(config_.sitepose.dynamic.mode), deadline_text);
  return detect_hook;
}

Expected<std::unique_ptr<Daemon>> Daemon::create(const DaemonConfig& config,
                                                 std::unique_ptr<pipeline::FrameSource> source) {
  std::unique_ptr<Daemon> d(new Daemon(config));
  if (!source) {
    SITEPOSE_TRY(source, open_source(config));
  }
  spdlog::info("source: {}", source->describe());
  SITEPOSE_TRY(const StereoCamera camera, tracking_camera(config, source->camera()));
  SITEPOSE_TRY(auto tracker,
               pipeline::SlamPoseTracker::create(camera, config.sitepose, source->frame_rate_hz()));
  d->tracker_ = tracker.get();
  if (!config.map.map_file.empty()) d->map_store_ = open_map_store(config, *tracker);
  SITEPOSE_TRY(auto detect_hook, d->open_detect_stage(*source, camera));
  SITEPOSE_TRY(d->anchoring_, Anchoring::create(config.geo, publish_options(config)));
  if (config.geo.mode == GeoMode::kOnline && config.geo.gnss_input == GnssInput::kNmeaFile) {
    SITEPOSE_TRY(geo::NmeaReadResult fixes, geo::read_nmea_file(config.geo.nmea_file, {}));
    spdlog::info("geo: {} GNSS fixes from {}", fixes.fixes.size(), config.geo.nmea_file);
    d->anchoring_->set_scheduled_fixes(std::move(fixes.fixes));
  }

  std::vector<std::unique_ptr<pipeline::PoseOutput>> outputs;
  if (config.lcm.enabled) {
    SITEPOSE_TRY(d->lcm_, output::open_lcm(config.lcm.lcm.url));
    SITEPOSE_TRY(auto publisher, output::LcmPublisher::create(config.lcm.lcm, d->lcm_));
    outputs.push_back(std::make_unique<LcmOutput>(std::move(publisher), *d->anchoring_));
  }
  if (config.geo.mode == GeoMode::kOnline && config.geo.gnss_input == GnssInput::kLcm) {
    if (!d->lcm_) {
      return make_error(ErrorCode::kInvalidArgument,
                        "geo.online.gnss_input = lcm: needs outputs.lcm.enabled = true");
    }
    Anchoring* anchoring = d->anchoring_.get();
    SITEPOSE_TRY(d->gnss_, output::LcmGnssSubscriber::create(
                               config.lcm.lcm, d->lcm_,
                               [anchoring](const geo::GnssFix& fix) { anchoring->push_fix(fix); }));
  }
  if (config.can.enabled) {
    std::unique_ptr<output::CanSink> sink;
    if (config.can.sink == CanSinkKind::kStdout) {
      sink = output::CandumpSink::make_stdout(config.can.interface);
    } else if (config.can.sink == CanSinkKind::kSocketCan) {
      drivers::socketcan::RawSocketOptions raw;
      raw.interface = config.can.interface;
      raw.error_frames = config.can.socketcan.error_frames;
      SITEPOSE_TRY(auto socketcan,
                   drivers::socketcan::SocketCanSink::open(socketcan_sink_options(config.can),
                                                           drivers::socketcan::raw_can_socket_ops(raw)));
      spdlog::info("CAN: SocketCAN {}, claiming J1939 address {} with NAME {:#018x}", config.can.interface,
                   config.can.frames.source_address, output::pack_j1939_name(config.can.socketcan.name));
      d->socketcan_ = socketcan.get();
      sink = std::move(socketcan);
    } else {
      SITEPOSE_TRY(sink, output::CandumpSink::open_file(config.can.path, config.can.interface));
    }
    outputs.push_back(std::make_unique<CanOutput>(config.can.frames, std::move(sink), *d->anchoring_));
  }
  if (config.trajectory.enabled) {
    SITEPOSE_TRY(auto trajectory, TrajectoryOutput::open(config.trajectory.path, config.trajectory.append));
    outputs.push_back(std::move(trajectory));
  }
  SITEPOSE_TRY(d->pipeline_,
               pipeline::Pipeline::create(config.pipeline, std::move(source), std::move(detect_hook),
                                          std::move(tracker), std::move(outputs)));
  return d;
}

Daemon::~Daemon() {
  gnss_thread_ = {};                   // stop and join before the anchoring goes
  if (map_store_) map_store_->stop();  // before the tracker it copies from
  pipeline_.reset();
}

void Daemon::log_health(const pipeline::PipelineHealth& h) const {
  std::string stages;
  for (const auto& s : h.stages) {
    stages += fmt::format(" {}[n={} depth={} drops={} p50={:.1f}ms p99={:.1f}ms]", s.name, s.items,
                          s.queue_depth, s.drops, s.p50_ms, s.p99_ms);
  }
  std::string outputs;
  for (const auto& o : h.outputs) {
    outputs += fmt::format(" {}[ok={} errors={} retries={} failed={}]", o.name, o.published, o.errors,
                           o.retries, o.failed);
  }
  std::string anchor;
  if (auto st = anchoring_->anchor_status()) {
    anchor = fmt::format(" anchor[{} fixes={} pairs={} inliers={}]", geo::to_string(st->state),
                         st->fixes_received, st->pairs, st->inliers);
  }
  std::string fallbacks;
  if (tracker_ != nullptr && config_.sitepose.dynamic.mode != config::MaskingMode::kNone) {
    const pipeline::TrackerFallbackCounters f = tracker_->fallback_counters();
    const pipeline::DetectDeadlineCounters d =
        deadline_detect_ != nullptr ? deadline_detect_->counters() : pipeline::DetectDeadlineCounters{};
    fallbacks = fmt::format(
        " dynamic[detect_errors={} reused_boxes={} unmasked={} box_for_pixel_mask={} detect_timeouts={} "
        "detect_skipped={} detect_late={} detector_crashes={} detector_hangs={} detector_restarts={}]",
        h.detect_errors, f.reused_detections, f.tracked_unmasked, f.box_mask_for_pixel_mask, d.timeouts,
        d.skipped_busy, d.late_returns, detector_host_->crashes.load(), detector_host_->hangs.load(),
        detector_host_->restarts.load());
  }
  std::string can_bus;
  if (socketcan_ != nullptr) {
    can_bus =
        " can_bus[" + drivers::socketcan::format_stats(config_.can.interface, socketcan_->stats()) + "]";
  }
  const std::string map =
      map_store_ ? " " + format_map_stats(map_store_->stats(), pipeline::SteadyClock::now()) : std::string();
  spdlog::info("health: {} captured={} stalls={} track_errors={} |{} |{}{}{}{}{}", pipeline::format_status(h),
               h.frames_captured, h.stalls, h.track_errors, stages, outputs, anchor, fallbacks, can_bus, map);
}

// After the pipeline has stopped (the mapper finished): the last word of the
// map, whatever stopped the run.
void Daemon::save_map_at_stop() {
  if (!map_store_) return;
  map_store_->stop();
  if (auto st = map_store_->save_now(); !st) {
    spdlog::error("map: save at stop failed: {}", st.error().message);
    return;
  }
  const MapStoreStats s = map_store_->stats();
  spdlog::info("map: saved {} at stop: {} keyframes, {} points, copy {:.1f} ms, write {:.1f} ms ({} saves)",
               config_.map.map_file, s.keyframes, s.points, s.last_copy_ms, s.last_write_ms, s.saves);
}

int Daemon::run(const sigset_t& stop_signals) {
  if (gnss_) {
    gnss_thread_ = std::jthread([this](const std::stop_token& stop) {
      pthread_setname_np(pthread_self(), "sp-gnss");
      // handle() waits at most 100 ms, so a stop is seen within that.
      while (!stop.stop_requested()) {
        if (auto r = gnss_->handle(100); !r) {
          spdlog::warn("gnss: LCM receive failed: {}", r.error().message);
        }
      }
    });
  }
  pipeline::Supervisor supervisor(config_.supervisor, notifier_.watchdog_interval_ns());
  if (notifier_.enabled()) {
    spdlog::info("systemd: notify socket set, watchdog {}",
                 notifier_.watchdog_interval_ns()
                     ? fmt::format("every {:.1f} s", *notifier_.watchdog_interval_ns() * 1e-9)
                     : std::string("off"));
  }
  auto notify = [this](const Status& st) {
    if (!st && (notifier_.failures() <= 3 || notifier_.failures() % 100 == 0)) {
      spdlog::warn("systemd: {}", st.error().message);
    }
  };
  pipeline_->start();
  if (map_store_) map_store_->start();
  const auto tick = supervisor.tick_interval();
  bool stopped_by_signal = false;
  for (;;) {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(tick.count() / 1'000'000'000);
    ts.tv_nsec = static_cast<long>(tick.count() % 1'000'000'000);
    const int sig = sigtimedwait(&stop_signals, nullptr, &ts);
    if (sig > 0) {
      spdlog::info("received {}, stopping", sigabbrev_np(sig) ? sigabbrev_np(sig) : "signal");
      notify(notifier_.stopping("stopping on signal"));
      pipeline_->stop();
      stopped_by_signal = true;
      break;
    }
    if (sig < 0 && errno != EAGAIN && errno != EINTR) {
      spdlog::error("sigtimedwait: {}", std::strerror(errno));
    }
    const pipeline::PipelineHealth h = pipeline_->health();
    const pipeline::SupervisorActions a = supervisor.tick(h, pipeline::SteadyClock::now());
    if (a.ready) {
      spdlog::info("first frame captured: ready");
      notify(notifier_.ready(a.status.value_or("ready")));
    } else if (a.status) {
      notify(notifier_.status(*a.status));
    }
    if (a.watchdog) notify(notifier_.watchdog());
    if (a.log) log_health(h);
    if (pipeline_->finished()) break;
  }
  const Status st = pipeline_->wait();
  save_map_at_stop();
  const pipeline::PipelineHealth h = pipeline_->health();
  log_health(h);
  if (!stopped_by_signal) notify(notifier_.stopping(st ? "source ended" : "source failed"));
  gnss_thread_ = {};
  if (!st) {
    spdlog::error("source failed: {}", st.error().message);
    return 1;
  }
  spdlog::info("stopped: {} frames tracked, {} poses published", h.frames_tracked, h.poses_published);
  return 0;
}

}  // namespace sitepose::daemon
