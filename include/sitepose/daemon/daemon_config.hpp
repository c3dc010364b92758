#pragma once
// siteposed's settings: one YAML file (config/siteposed.yaml documents every
// key) holding the daemon's own sections (source, pipeline, supervisor,
// outputs, geo) next to the sitepose sections (camera, orb, stereo,
// tracking, mapping, dynamic, detector, logging; config/sitepose.yaml).
// daemon_sections() is the table of the whole file, built on the config
// module's Section machinery, so the daemon's keys are read, validated and
// written like the sitepose ones. load_daemon_config() validates everything
// before anything starts: unknown keys, wrong types, broken rules and
// cross-field problems are reported all at once, each naming file:line, the
// key path, the value and the rule (kInvalidArgument; kNotFound for a
// missing file). Relative paths in the file are resolved against the file's
// directory.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sitepose/config/section.hpp"
#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/drivers/aravis/aravis_source.hpp"
#include "sitepose/drivers/v4l2/v4l2_source.hpp"
#include "sitepose/geo/geoid.hpp"
#include "sitepose/geo/site_anchor.hpp"
#include "sitepose/output/can_pose_encoder.hpp"
#include "sitepose/output/j1939_network.hpp"
#include "sitepose/output/lcm_bus.hpp"
#include "sitepose/output/published_pose.hpp"
#include "sitepose/pipeline/pipeline.hpp"
#include "sitepose/pipeline/replay_source.hpp"
#include "sitepose/pipeline/supervisor.hpp"

namespace sitepose::daemon {

struct TrajectoryOutputConfig {
  bool enabled = true;
  std::string path;    // TUM lines, T_world_cam in the SLAM frame
  bool append = true;  // keep lines of earlier runs (a restart loses nothing)
};

enum class CanSinkKind { kCandumpFile, kStdout, kSocketCan };

// The J1939 / NMEA 2000 node on a SocketCAN interface (sink socketcan).
struct SocketCanConfig {
  int queue_frames = 64;               // poses wait here while the bus is busy
  bool error_frames = true;            // read bus-off / restarted / error-passive
  double heartbeat_interval_s = 60.0;  // NMEA 2000 126993; 0 = none
  output::J1939Name name = default_name();

  // Industry group 3 (construction equipment), arbitrary address capable;
  // identity_number must be unique per unit (its serial number).
  static output::J1939Name default_name() {
    output::J1939Name n;
    n.industry_group = 3;
    n.arbitrary_address_capable = true;
    return n;
  }
};

struct CanOutputConfig {
  bool enabled = true;
  CanSinkKind sink = CanSinkKind::kCandumpFile;
  std::string path;                 // candump log (sink candump)
  std::string interface = "can0";   // socketcan: the interface; otherwise the name in log lines
  output::CanOutputOptions frames;  // frames.source_address: the preferred J1939 address
  SocketCanConfig socketcan;
};

struct LcmOutputConfig {
  bool enabled = true;
  output::LcmOptions lcm;
};

enum class GeoMode { kNone, kFixed, kOnline };
enum class GnssInput { kLcm, kNmeaFile };

// The site anchor's own uncertainty (isotropic position / attitude std):
// mode fixed, that of the commissioned T_site_slam; mode online, the least
// added to the fit's.
struct AnchorStd {
  double position_m = 0.02;
  double attitude_deg = 0.05;
};

struct GeoConfig {
  GeoMode mode = GeoMode::kNone;
  AnchorStd anchor_std;
  // GTX geoid grid (geo::GeoidGrid) for heights above mean sea level; ""
  // = none (J1939 SPN 580 and 129029's geoidal separation not available).
  std::string geoid = geo::kDefaultGeoidPath;
  geo::Geodetic origin;
  geo::ForwardAxis forward_axis_cam = geo::ForwardAxis::kMinusX;
  SE3 T_site_slam;  // mode fixed
  // mode online (SiteAnchor): origin, forward axis and the options below.
  GnssInput gnss_input = GnssInput::kLcm;
  std::string nmea_file;  // gnss_input nmea_file
  geo::SiteAnchorOptions anchor;
};

// source.v4l2: the V4L2 source's options, and the two keys whose form
// differs from V4l2SourceOptions (v4l2_source_options() applies them).
struct V4l2SourceConfig {
  // One device sending left | right in one frame (right_device stays empty).
  bool side_by_side = false;
  drivers::v4l2::V4l2SourceOptions options;  // pair_tolerance_ns, wait_for_camera_s: set from elsewhere
  double pair_tolerance_ms = 5.0;
};

// mapping.map_file, mapping.checkpoint_interval_s: siteposed's own keys in
// the sitepose `mapping` section (MapStore, map_store.hpp).
struct MapPersistenceConfig {
  // The site map kept between runs; empty: none (each start a new map).
  // The shipped file sets /var/lib/siteposed/site.map (StateDirectory=).
  std::string map_file;
  double checkpoint_interval_s = 300.0;  // periodic save while running; 0 = only at stop
};

// Where a detector plugin .so runs (detect::IsolationOptions): in a child
// process, sitepose-detector-host (its crash or hang is counted and it is
// restarted), or in siteposed itself (a crash ends the daemon).
enum class DetectorIsolation { kProcess, kInProcess };

// dynamic.detector_deadline_ms, dynamic.detector_isolation: siteposed's own
// keys in the sitepose `dynamic` section (pipeline::DeadlineDetect,
// detect::load_isolated_plugin). The built-in detectors run in-process
// whatever detector_isolation says.
struct DetectDeadlineConfig {
  double detector_deadline_ms = 0.0;  // 0: one frame period of a live source, 5 s for a lossless replay
  DetectorIsolation detector_isolation = DetectorIsolation::kProcess;
};

struct DaemonConfig {
  std::string source_type = "replay";  // replay | aravis | v4l2
  // source.orbslam2_settings: an ORB-SLAM2 stereo settings file whose camera
  // and ORB values load_daemon_config applies over the sitepose sections
  // (config::apply_orbslam2_settings, as `sitepose run --orbslam2-settings`);
  // empty: none. Its keys sitepose does not use, for the start-up log:
  std::string orbslam2_settings;
  std::vector<std::string> orbslam2_ignored_keys;
  // A camera source: how long to wait at start for an absent camera (0:
  // fail at once). Lost cameras later are reconnected whatever this says.
  double wait_for_camera_s = 0.0;
  pipeline::ReplayOptions replay;
  drivers::aravis::AravisSourceOptions aravis;
  V4l2SourceConfig v4l2;
  pipeline::PipelineOptions pipeline;
  pipeline::SupervisorOptions supervisor;
  TrajectoryOutputConfig trajectory;
  CanOutputConfig can;
  LcmOutputConfig lcm;
  output::ReferencePointOptions reference_point;                          // outputs.reference_point
  output::CovarianceOptions covariance{1.0, 0.001, 0.005, 0.003, 0.008};  // outputs.covariance
  output::IntegrityOptions integrity{0.10, 4.5};                          // outputs.integrity
  GeoConfig geo;
  config::SiteposeConfig sitepose;
  MapPersistenceConfig map;
  DetectDeadlineConfig detect_deadline;
};

// The V4L2 source's options from source.v4l2 and source.wait_for_camera_s.
drivers::v4l2::V4l2SourceOptions v4l2_source_options(const DaemonConfig& config);
// The replay's options from source.replay and camera.channel_order.
pipeline::ReplayOptions replay_options(const DaemonConfig& config);

// The table of the settings file; defaults are DaemonConfig's initialisers.
const config::Section<DaemonConfig>& daemon_sections();

Expected<DaemonConfig> load_daemon_config(const std::string& path);
Expected<DaemonConfig> load_daemon_config_from_string(const std::string& text, const std::string& source_name,
                                                      const std::string& base_dir);

// The resolved settings as YAML that load_daemon_config reads back to the
// same values (logged once at startup, printed by --check-config).
std::string to_yaml(const DaemonConfig& config);

}  // namespace sitepose::daemon
