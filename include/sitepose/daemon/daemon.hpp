#pragma once
// siteposed's supervisor: builds the source, the tracker, the anchoring and
// the outputs from a validated DaemonConfig, runs the pipeline and talks to
// systemd (READY after the first source frame, STATUS lines, WATCHDOG only
// while frames flow and the track stage progresses, STOPPING on a stop
// signal), logging health periodically. With mapping.map_file it starts in
// the saved site map and keeps it saved (MapStore: checkpoints, and one
// save after the pipeline stopped, on SIGTERM or at the source's end).
// Threads: create() and run() on the main thread, which must have blocked
// the stop signals (SIGTERM, SIGINT) before any thread was started, so that
// only run()'s sigtimedwait() receives them. A GNSS receiving thread runs
// when geo.mode is online with gnss_input lcm.

#include <signal.h>

#include <memory>
#include <thread>

#include "sitepose/daemon/daemon_config.hpp"
#include "sitepose/daemon/map_store.hpp"
#include "sitepose/daemon/outputs.hpp"
#include "sitepose/detect/isolated_detector.hpp"
#include "sitepose/drivers/socketcan/socketcan_sink.hpp"
#include "sitepose/output/lcm_gnss_subscriber.hpp"
#include "sitepose/pipeline/detect_deadline.hpp"
#include "sitepose/pipeline/pipeline.hpp"
#include "sitepose/pipeline/slam_tracker.hpp"
#include "sitepose/pipeline/systemd_notify.hpp"

namespace sitepose::daemon {

// The SocketCAN sink's options from the daemon's CAN settings (sink socketcan).
drivers::socketcan::SocketCanSinkOptions socketcan_sink_options(const CanOutputConfig& can);

// How the camera sources reach their cameras; an empty member means the
// real ones (Aravis; the kernel's V4L2 ioctls). Tests put fakes here.
struct CameraAccess {
  drivers::aravis::CameraOpener aravis;
  std::shared_ptr<drivers::v4l2::V4l2Io> v4l2;
};

// The source the config names (source.type replay, aravis or v4l2); errors
// name the key ("source.aravis.right_id = ...", "source.v4l2.left_device:
// ...").
Expected<std::unique_ptr<pipeline::FrameSource>> open_source(const DaemonConfig& config,
                                                             const CameraAccess& access = {});

// What --check-config checks: everything a start checks but the camera and
// the LCM network (they may not be up yet while the unit is being set up):
// the replay sequence opens, the detector (plugin .so) loads with the mode's
// inputs (labels of the sequence), the site anchoring and NMEA file, the
// LCM URL parses, the output files can be written (folders exist and are
// writable). Opens nothing that stays open and writes nothing.
// kInvalidArgument (exit 2) naming the key.
Status check_startable(const DaemonConfig& config);

class Daemon {
 public:
  // Opens everything the config names; errors name the key or file
  // (Error::exit_status(): 2 for bad input such as a missing sequence, 1
  // for a run-time failure such as an LCM URL that cannot be opened).
  // `source`: a test seam replacing the configured source (nullptr: open
  // the one the config names).
  static Expected<std::unique_ptr<Daemon>> create(const DaemonConfig& config,
                                                  std::unique_ptr<pipeline::FrameSource> source = nullptr);
  ~Daemon();

  // Runs until the source ends or a signal of `stop_signals` arrives; 0 on
  // a clean end or stop, 1 when the source failed.
  int run(const sigset_t& stop_signals);

 private:
  explicit Daemon(const DaemonConfig& config) : config_(config) {}
  Expected<std::unique_ptr<pipeline::DetectHook>> open_detect_stage(const pipeline::FrameSource& source,
                                                                    const StereoCamera& camera);
  void log_health(const pipeline::PipelineHealth& health) const;
  void save_map_at_stop();

  DaemonConfig config_;
  pipeline::SystemdNotifier notifier_;
  std::unique_ptr<Anchoring> anchoring_;  // outlives the outputs
  std::shared_ptr<lcm::LCM> lcm_;
  std::unique_ptr<output::LcmGnssSubscriber> gnss_;               // used by gnss_thread_ only
  std::unique_ptr<pipeline::Pipeline> pipeline_;                  // owns source, tracker, outputs
  const pipeline::SlamPoseTracker* tracker_ = nullptr;            // owned by pipeline_ (counters only)
  const drivers::socketcan::SocketCanSink* socketcan_ = nullptr;  // owned by pipeline_ (stats only)
  const pipeline::DeadlineDetect* deadline_detect_ = nullptr;     // owned by pipeline_ (counters only)
  // dynamic.detector_isolation: process (counted by the plugin's host, read by log_health)
  std::shared_ptr<detect::HostCounters> detector_host_ = std::make_shared<detect::HostCounters>();
  std::unique_ptr<MapStore> map_store_;  // copies from tracker_: stopped first
  std::jthread gnss_thread_;             // joined first (declared last)
};

}  // namespace sitepose::daemon
