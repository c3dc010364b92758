// The table of siteposed's settings file: every key once, with its rule.
// The option structs of pipeline, output and geo hold the defaults; the
// sections here bind the file's layout to them.

#include "sitepose/daemon/daemon_config.hpp"

#include <cmath>
#include <filesystem>

#include "sitepose/config/config.hpp"
#include "sitepose/config/orbslam2_settings.hpp"
#include "sitepose/config/yaml_reader.hpp"
#include "sitepose/detect/create_detector.hpp"
#include "sitepose/drivers/aravis/aravis_source.hpp"
#include "sitepose/drivers/aravis/gvcp_action.hpp"
#include "sitepose/drivers/v4l2/pixel_format.hpp"

namespace sitepose::daemon {
namespace {

namespace fs = std::filesystem;
using config::Choice;
using config::in_range;
using config::make_rule;
using config::non_empty;
using config::non_negative;
using config::ReadKeys;
using config::Section;

std::string resolve(const std::string& base_dir, const std::string& path) {
  if (path.empty() || fs::path(path).is_absolute() || base_dir.empty()) return path;
  return (fs::path(base_dir) / path).lexically_normal().string();
}

std::vector<double> as_list(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
Eigen::Vector3d as_vector3(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

auto three_numbers() {
  return make_rule([](const std::vector<double>& x) { return x.size() == 3; },
                   "expected a list of 3 numbers");
}

// ---- source, pipeline, supervisor -----------------------------------------

Section<pipeline::ReplayOptions> replay_section() {
  using R = pipeline::ReplayOptions;
  Section<R> s;
  // Required, and not empty, with source.type replay (source_group's check):
  // the written settings of another source type hold it empty.
  s.key("sequence", &R::sequence_dir)
      .parsed(
          "rate", &R::rate, [](const std::string& t) { return pipeline::parse_replay_rate(t); },
          [](pipeline::ReplayRate r) { return pipeline::to_string(r); })
      .key("loop", &R::loop)
      .key("max_frames", &R::max_frames, non_negative());
  return s;
}

Section<drivers::aravis::Roi> roi_section() {
  using R = drivers::aravis::Roi;
  Section<R> s;
  s.key("x", &R::x, in_range(0, 65535))
      .key("y", &R::y, in_range(0, 65535))
      .key("width", &R::width, in_range(0, 65535))
      .key("height", &R::height, in_range(0, 65535));
  return s;
}

Section<drivers::aravis::ActionSettings> action_section() {
  namespace a = drivers::aravis;
  using A = a::ActionSettings;
  const auto key = [](const std::string& t) { return a::gvcp::parse_key(t); };
  Section<A> s;
  s.parsed("device_key", &A::device_key, key, a::gvcp::format_key)
      .parsed("group_key", &A::group_key, key, a::gvcp::format_key)
      .parsed("group_mask", &A::group_mask, key, a::gvcp::format_key)
      .key("destination", &A::destination)
      .key("lead_time_ms", &A::lead_time_ms, in_range(0.1, 1000.0));
  return s;
}

Section<drivers::aravis::CameraSettings> camera_settings_section() {
  namespace a = drivers::aravis;
  using C = a::CameraSettings;
  Section<C> s;
  s.parsed(
       "pixel_format", &C::pixel_format, [](const std::string& t) { return a::parse_pixel_format(t); },
       [](a::PixelFormat f) { return a::to_string(f); })
      .key("exposure_auto", &C::exposure_auto)
      .key("exposure_us", &C::exposure_us, in_range(1.0, 1e7))
      .key("gain_auto", &C::gain_auto)
      .key("gain_db", &C::gain_db, in_range(-20.0, 60.0))
      .section("roi", &C::roi, roi_section())
      .choice("trigger", &C::trigger,
              {Choice<a::TriggerMode>{a::TriggerMode::kFreeRun, "free_run"},
               Choice<a::TriggerMode>{a::TriggerMode::kSoftware, "software"},
               Choice<a::TriggerMode>{a::TriggerMode::kHardware, "hardware"},
               Choice<a::TriggerMode>{a::TriggerMode::kAction, "action"}})
      .section("action", &C::action, action_section())
      .key("frame_rate_hz", &C::frame_rate_hz, in_range(0.1, 1000.0))
      .key("packet_size_bytes", &C::packet_size_bytes, in_range(0, 16384))
      .key("packet_delay_ns", &C::packet_delay_ns, in_range(0, 100'000'000))
      .key("buffer_count", &C::buffer_count, in_range(2, 256));
  return s;
}

Section<drivers::aravis::AravisSourceOptions> aravis_section() {
  namespace a = drivers::aravis;
  using A = a::AravisSourceOptions;
  Section<A> s;
  s.key("left_id", &A::left_id)
      .key("right_id", &A::right_id)
      .key("calibration", &A::calibration)
      .key("feature_file", &A::feature_file)
      .embed(&A::camera, camera_settings_section())
      .key("pair_tolerance_ms", &A::pair_tolerance_ms, in_range(0.001, 1000.0))
      .choice("pair_clock", &A::pair_clock,
              {Choice<a::PairClock>{a::PairClock::kHost, "host"},
               Choice<a::PairClock>{a::PairClock::kCamera, "camera"}})
      .key("max_pending", &A::max_pending, in_range(1, 64))
      .key("lost_timeout_s", &A::lost_timeout_s, in_range(0.01, 60.0))
      .key("reconnect_min_s", &A::reconnect_min_s, in_range(0.01, 60.0))
      .key("reconnect_max_s", &A::reconnect_max_s, in_range(0.01, 3600.0));
  return s;
}

Section<drivers::v4l2::V4l2SourceOptions> v4l2_options_section() {
  using V = drivers::v4l2::V4l2SourceOptions;
  const auto pixel_format =
      make_rule([](const std::string& t) { return drivers::v4l2::parse_pixel_preference(t).has_value(); },
                "expected one of: auto, GREY, YUYV, MJPG");
  Section<V> s;
  s.key("left_device", &V::left_device)
      .key("right_device", &V::right_device)
      .key("width", &V::width, in_range(0, 16384))
      .key("height", &V::height, in_range(0, 16384))
      .key("fps", &V::fps, in_range(0.0, 1000.0))
      .key("pixel_format", &V::pixel_format, pixel_format)
      .key("buffers", &V::buffers, in_range(2, 32))
      .key("calibration", &V::calibration_file)
      .key("reconnect_min_s", &V::reconnect_min_s, in_range(0.01, 60.0))
      .key("reconnect_max_s", &V::reconnect_max_s, in_range(0.01, 3600.0));
  return s;
}

Section<V4l2SourceConfig> v4l2_section() {
  using V = V4l2SourceConfig;
  Section<V> s;
  s.key("side_by_side", &V::side_by_side)
      .embed(&V::options, v4l2_options_section())
      .key("pair_tolerance_ms", &V::pair_tolerance_ms, in_range(0.0, 1000.0));
  return s;
}

// source.v4l2 with type v4l2: the devices, the size and the calibration are
// required; right_device exactly when the frames are not side by side.
void check_v4l2(const ReadKeys& keys, const DaemonConfig& c) {
  const config::YamlMap v4l2 = keys.map().map("v4l2");
  bool complete = true;
  for (const char* key : {"left_device", "width", "height", "calibration"}) complete &= v4l2.require(key);
  const bool has_right = !c.v4l2.options.right_device.empty();
  if (c.v4l2.side_by_side && has_right) {
    v4l2.report("right_device", "must be empty with side_by_side: true (one device sends both images)");
    complete = false;
  } else if (!c.v4l2.side_by_side && !v4l2.require("right_device")) {
    complete = false;
  }
  if (!complete) return;
  if (auto st = drivers::v4l2::check_v4l2_source_options(v4l2_source_options(c)); !st) {
    v4l2.report_here(st.error().message);
  }
}

Section<DaemonConfig> source_group() {
  Section<DaemonConfig> s;
  s.key("type", &DaemonConfig::source_type, config::one_of({"replay", "aravis", "v4l2"}))
      .key("wait_for_camera_s", &DaemonConfig::wait_for_camera_s, in_range(0.0, 86400.0))
      .key("orbslam2_settings", &DaemonConfig::orbslam2_settings)
      .section("replay", &DaemonConfig::replay, replay_section())
      .section("aravis", &DaemonConfig::aravis, aravis_section())
      .section("v4l2", &DaemonConfig::v4l2, v4l2_section())
      .check([](const ReadKeys& keys, const DaemonConfig& c) {
        if (c.source_type == "replay") {
          const config::YamlMap replay = keys.map().map("replay");
          if (replay.require("sequence")) replay.check("sequence", c.replay.sequence_dir, non_empty());
        }
        if (c.source_type == "v4l2") check_v4l2(keys, c);
        if (c.source_type != "aravis") return;
        const config::YamlMap aravis = keys.map().map("aravis");
        for (const char* key : {"left_id", "right_id", "calibration"}) aravis.require(key);
        if (!aravis.has("left_id") || !aravis.has("right_id") || !aravis.has("calibration")) return;
        if (auto st = drivers::aravis::check_aravis_source_options(c.aravis); !st) {
          aravis.report_here(st.error().message);
        }
      });
  return s;
}

Section<pipeline::PipelineOptions> pipeline_section() {
  using P = pipeline::PipelineOptions;
  const auto power_of_two = make_rule([](int v) { return v >= 2 && v <= (1 << 20) && (v & (v - 1)) == 0; },
                                      "must be a power of two in [2, 1048576]");
  Section<P> s;
  s.key_as<int>("capture_ring_capacity", &P::capture_ring_capacity, power_of_two)
      .key_as<int>("detect_ring_capacity", &P::detect_ring_capacity, power_of_two)
      .key_as<int>("publish_ring_capacity", &P::publish_ring_capacity, power_of_two)
      .key("stall_timeout_s", &P::stall_timeout_s, in_range(0.05, 3600.0))
      .key("publish_max_attempts", &P::publish_max_attempts, in_range(1, 100))
      .key("publish_retry_delay_s", &P::publish_retry_delay_s, in_range(0.0, 1.0))
      .key("health_interval_s", &P::health_interval_s, in_range(0.05, 3600.0));
  return s;
}

Section<pipeline::SupervisorOptions> supervisor_section() {
  using S = pipeline::SupervisorOptions;
  Section<S> s;
  s.key("status_interval_s", &S::status_interval_s, in_range(0.05, 3600.0))
      .key("log_interval_s", &S::log_interval_s, in_range(0.1, 86400.0));
  return s;
}

// ---- outputs --------------------------------------------------------------

Section<TrajectoryOutputConfig> trajectory_section() {
  using T = TrajectoryOutputConfig;
  Section<T> s;
  s.key("enabled", &T::enabled)
      .key("path", &T::path)
      .key("append", &T::append)
      .check([](const ReadKeys& keys, const T& t) {
        if (t.enabled) keys.require("path", t.path, non_empty());
      });
  return s;
}

Section<output::CanOutputOptions> can_frames_section() {
  using O = output::CanOutputOptions;
  Section<O> frames;
  frames.key("j1939_vehicle_position", &O::j1939_vehicle_position)
      .key("j1939_vehicle_direction_speed", &O::j1939_vehicle_direction_speed)
      .key("n2k_position_rapid_update", &O::n2k_position_rapid_update)
      .key("n2k_cog_sog_rapid_update", &O::n2k_cog_sog_rapid_update)
      .key("n2k_gnss_position_data", &O::n2k_gnss_position_data)
      .key("n2k_vessel_heading", &O::n2k_vessel_heading)
      .key("sitepose_pose_quality", &O::sitepose_pose_quality);
  Section<O> s;
  s.key_as<int>("source_address", &O::source_address, in_range(0, 253)).group("frames", std::move(frames));
  return s;
}

Section<output::J1939Name> j1939_name_section() {
  using N = output::J1939Name;
  Section<N> s;
  s.key_as<int>("identity_number", &N::identity_number, in_range(0, (1 << 21) - 1))
      .key_as<int>("manufacturer_code", &N::manufacturer_code, in_range(0, (1 << 11) - 1))
      .key_as<int>("ecu_instance", &N::ecu_instance, in_range(0, 7))
      .key_as<int>("function_instance", &N::function_instance, in_range(0, 31))
      .key_as<int>("function", &N::function, in_range(0, 255))
      .key_as<int>("vehicle_system", &N::vehicle_system, in_range(0, 127))
      .key_as<int>("vehicle_system_instance", &N::vehicle_system_instance, in_range(0, 15))
      .key_as<int>("industry_group", &N::industry_group, in_range(0, 7))
      .key("arbitrary_address_capable", &N::arbitrary_address_capable);
  return s;
}

Section<SocketCanConfig> socketcan_section() {
  using K = SocketCanConfig;
  Section<K> s;
  s.key("queue_frames", &K::queue_frames, in_range(13, 65536))
      .key("error_frames", &K::error_frames)
      .key("heartbeat_interval_s", &K::heartbeat_interval_s,
           make_rule([](double v) { return v == 0.0 || (v >= 0.01 && v <= 655.32); },
                     "must be 0 (off) or 0.01..655.32"))
      .section("name", &K::name, j1939_name_section());
  return s;
}

Section<CanOutputConfig> can_section() {
  using C = CanOutputConfig;
  Section<C> s;
  s.key("enabled", &C::enabled)
      .choice("sink", &C::sink,
              {Choice<CanSinkKind>{CanSinkKind::kCandumpFile, "candump"},
               Choice<CanSinkKind>{CanSinkKind::kStdout, "stdout"},
               Choice<CanSinkKind>{CanSinkKind::kSocketCan, "socketcan"}})
      .key("path", &C::path)
      .key("interface", &C::interface,
           make_rule(
               [](const std::string& v) { return !v.empty() && v.find_first_of(" \t") == std::string::npos; },
               "must be a non-empty name without blanks"))
      .embed(&C::frames, can_frames_section())
      .section("socketcan", &C::socketcan, socketcan_section())
      .check([](const ReadKeys& keys, const C& can) {
        if (!can.enabled) return;
        if (can.sink == CanSinkKind::kCandumpFile) keys.require("path", can.path, non_empty());
        if (auto st = output::check_can_output_options(can.frames); !st) {
          keys.report("frames", st.error().message);
        }
      });
  return s;
}

Section<output::LcmOptions> lcm_options_section() {
  using L = output::LcmOptions;
  Section<L> s;
  s.key("url", &L::url)
      .key("pose_channel", &L::pose_channel)
      .key("health_channel", &L::health_channel)
      .key("gnss_channel", &L::gnss_channel)
      .key("max_send_attempts", &L::max_send_attempts)
      .check([](const ReadKeys& keys, const L& lcm) {
        if (auto st = lcm.validate(keys.map().path()); !st) {
          keys.map().report_here(st.error().message);
        }
      });
  return s;
}

Section<LcmOutputConfig> lcm_section() {
  Section<LcmOutputConfig> s;
  s.key("enabled", &LcmOutputConfig::enabled).embed(&LcmOutputConfig::lcm, lcm_options_section());
  return s;
}

Section<output::ReferencePointOptions> reference_point_section() {
  using R = output::ReferencePointOptions;
  Section<R> s;
  s.computed(
      "lever_arm_m", [](const R& r) { return as_list(r.lever_arm_m); },
      [](R& r, const std::vector<double>& v) { r.lever_arm_m = as_vector3(v); }, three_numbers());
  return s;
}

Section<output::CovarianceOptions> covariance_section() {
  using C = output::CovarianceOptions;
  Section<C> s;
  s.key("scale", &C::scale, in_range(1e-6, 1e6))
      // Above 0: the first pose (no tracker covariance yet, geo.mode none)
      // is never published with a zero covariance.
      .key("floor_position_m", &C::floor_position_m, in_range(0.0001, 100.0))
      .key("floor_attitude_deg", &C::floor_attitude_deg, in_range(0.0001, 90.0))
      .key("drift_m_per_sqrt_m", &C::drift_m_per_sqrt_m, in_range(0.0, 1.0))
      .key("drift_deg_per_sqrt_m", &C::drift_deg_per_sqrt_m, in_range(0.0, 10.0));
  return s;
}

Section<output::IntegrityOptions> integrity_section() {
  using I = output::IntegrityOptions;
  Section<I> s;
  s.key("alert_limit_m", &I::alert_limit_m, in_range(0.0, 1000.0))
      .key("protection_level_sigmas", &I::protection_level_sigmas, in_range(1.0, 100.0));
  return s;
}

Section<DaemonConfig> outputs_group() {
  Section<DaemonConfig> s;
  s.section("trajectory", &DaemonConfig::trajectory, trajectory_section())
      .section("can", &DaemonConfig::can, can_section())
      .section("lcm", &DaemonConfig::lcm, lcm_section())
      .section("reference_point", &DaemonConfig::reference_point, reference_point_section())
      .section("covariance", &DaemonConfig::covariance, covariance_section())
      .section("integrity", &DaemonConfig::integrity, integrity_section());
  return s;
}

// ---- geo --------------------------------------------------------------------

// The online anchor's options with the site origin and forward axis, which
// the file gives once for every mode.
geo::SiteAnchorOptions anchor_options(const GeoConfig& g) {
  geo::SiteAnchorOptions anchor = g.anchor;
  anchor.origin = g.origin;
  anchor.forward_axis_cam = g.forward_axis_cam;
  return anchor;
}

Section<geo::Geodetic> origin_section() {
  using G = geo::Geodetic;
  Section<G> s;
  s.key("latitude_deg", &G::latitude_deg, in_range(-90.0, 90.0))
      .key("longitude_deg", &G::longitude_deg, in_range(-180.0, 180.0))
      .key("height_m", &G::height_m, in_range(-1000.0, 10000.0));
  return s;
}

Section<SE3> site_slam_section() {
  const auto unit_quaternion = make_rule(
      [](const std::vector<double>& x) {
        if (x.size() != 4) return false;
        const double n = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]);
        return std::abs(n - 1.0) < 1e-3;
      },
      "expected a unit quaternion [w, x, y, z] (norm within 1e-3 of 1)");
  Section<SE3> s;
  s.computed(
       "translation_m", [](const SE3& T) { return as_list(T.translation()); },
       [](SE3& T, const std::vector<double>& t) { T = SE3(T.rotation(), as_vector3(t)); }, three_numbers())
      .computed(
          "rotation_wxyz",
          [](const SE3& T) {
            const Eigen::Quaterniond& q = T.rotation();
            return std::vector<double>{q.w(), q.x(), q.y(), q.z()};
          },
          [](SE3& T, const std::vector<double>& q) {
            T = SE3(Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized(), T.translation());
          },
          unit_quaternion);
  return s;
}

Section<geo::SiteAnchorOptions> anchor_section() {
  using A = geo::SiteAnchorOptions;
  Section<A> s;
  s.computed(
       "p_cam_antenna_m", [](const A& a) { return as_list(a.p_cam_antenna_m); },
       [](A& a, const std::vector<double>& p) { a.p_cam_antenna_m = as_vector3(p); }, three_numbers())
      .computed(
          "gnss_clock_offset_s",
          [](const A& a) { return static_cast<double>(a.gnss_clock_offset_ns) * 1e-9; },
          [](A& a, double offset_s) {
            a.gnss_clock_offset_ns = static_cast<std::int64_t>(std::llround(offset_s * 1e9));
          },
          in_range(-1e10, 1e10))
      .key("min_inliers", &A::min_inliers, in_range(3, 100000))
      .key("min_lateral_spread_m", &A::min_lateral_spread_m, non_negative())
      .key("freeze_inliers", &A::freeze_inliers, in_range(3, 1000000))
      .key("freeze_lateral_spread_m", &A::freeze_lateral_spread_m, non_negative());
  return s;
}

Section<AnchorStd> anchor_std_section() {
  Section<AnchorStd> s;
  s.key("position_m", &AnchorStd::position_m, in_range(0.0, 100.0))
      .key("attitude_deg", &AnchorStd::attitude_deg, in_range(0.0, 90.0));
  return s;
}

Section<GeoConfig> online_group() {
  Section<GeoConfig> s;
  s.choice("gnss_input", &GeoConfig::gnss_input,
           {Choice<GnssInput>{GnssInput::kLcm, "lcm"}, Choice<GnssInput>{GnssInput::kNmeaFile, "nmea_file"}})
      .key("nmea_file", &GeoConfig::nmea_file)
      .embed(&GeoConfig::anchor, anchor_section())
      .check([](const ReadKeys& keys, const GeoConfig& g) {
        if (g.mode != GeoMode::kOnline) return;
        if (g.gnss_input == GnssInput::kNmeaFile) keys.require("nmea_file", g.nmea_file, non_empty());
        if (auto st = anchor_options(g).validate(); !st) keys.map().report_here(st.error().message);
      });
  return s;
}

Section<GeoConfig> geo_section() {
  Section<GeoConfig> s;
  s.choice("mode", &GeoConfig::mode,
           {Choice<GeoMode>{GeoMode::kNone, "none"}, Choice<GeoMode>{GeoMode::kFixed, "fixed"},
            Choice<GeoMode>{GeoMode::kOnline, "online"}})
      .section("origin", &GeoConfig::origin, origin_section())
      .parsed(
          "forward_axis", &GeoConfig::forward_axis_cam,
          [](const std::string& t) { return geo::parse_forward_axis(t); },
          [](geo::ForwardAxis a) { return geo::to_string(a); })
      .section("T_site_slam", &GeoConfig::T_site_slam, site_slam_section())
      .section("anchor_std", &GeoConfig::anchor_std, anchor_std_section())
      .key("geoid", &GeoConfig::geoid)
      .group("online", online_group())
      .check([](const ReadKeys& keys, const GeoConfig& g) {
        if (g.mode == GeoMode::kNone) return;
        const config::YamlMap origin = keys.map().map("origin");
        for (const char* key : {"latitude_deg", "longitude_deg", "height_m"}) origin.require(key);
        if (g.mode == GeoMode::kFixed && !keys.map().has("T_site_slam")) {
          keys.report("T_site_slam", "required with geo.mode = fixed (translation_m, rotation_wxyz)");
        }
      });
  return s;
}

// ---- siteposed's keys in sitepose sections -----------------------------------

Section<MapPersistenceConfig> map_persistence_section() {
  using M = MapPersistenceConfig;
  Section<M> s;
  s.key("map_file", &M::map_file)
      .key("checkpoint_interval_s", &M::checkpoint_interval_s,
           make_rule([](double v) { return v == 0.0 || (v >= 0.1 && v <= 86400.0); },
                     "must be 0 (only at stop) or in [0.1, 86400]"));
  return s;
}

Section<DetectDeadlineConfig> detect_deadline_section() {
  Section<DetectDeadlineConfig> s;
  s.key("detector_deadline_ms", &DetectDeadlineConfig::detector_deadline_ms, in_range(0.0, 60000.0))
      .choice("detector_isolation", &DetectDeadlineConfig::detector_isolation,
              {Choice<DetectorIsolation>{DetectorIsolation::kProcess, "process"},
               Choice<DetectorIsolation>{DetectorIsolation::kInProcess, "in-process"}});
  return s;
}

// ---- the file ---------------------------------------------------------------

Section<DaemonConfig> make_daemon_sections() {
  Section<DaemonConfig> s;
  s.group("source", source_group())
      .section("pipeline", &DaemonConfig::pipeline, pipeline_section())
      .section("supervisor", &DaemonConfig::supervisor, supervisor_section())
      .group("outputs", outputs_group())
      .section("geo", &DaemonConfig::geo, geo_section())
      .embed(&DaemonConfig::sitepose, config::sitepose_sections())
      // After the sitepose sections: written into their `mapping` (YamlWriter reopens it).
      .section("mapping", &DaemonConfig::map, map_persistence_section())
      .section("dynamic", &DaemonConfig::detect_deadline, detect_deadline_section())
      .check([](const ReadKeys& keys, const DaemonConfig& c) {
        if (c.can.enabled && c.geo.mode == GeoMode::kNone) {
          keys.map().map("outputs").map("can").report(
              "enabled", "CAN frames carry WGS84 positions: needs geo.mode fixed or online");
        }
        if (c.sitepose.dynamic.mode != config::MaskingMode::kNone && c.sitepose.detector.name == "labels" &&
            c.source_type != "replay") {
          keys.map()
              .map("detector")
              .report("name", "\"labels\" reads a recorded sequence's labels: needs source.type replay");
        }
        if (!c.reference_point.lever_arm_m.isZero()) {
          if (auto r = output::rotation_cam_machine(c.geo.forward_axis_cam); !r) {
            keys.map().map("outputs").map("reference_point").report("lever_arm_m", r.error().message);
          }
        }
      });
  return s;
}

// source.orbslam2_settings over the sitepose sections it overrides; its
// errors name the key and the file (exit 2 at start, like any bad key).
Status import_orbslam2_settings(DaemonConfig& c, const std::string& source_name) {
  if (c.orbslam2_settings.empty()) return ok_status();
  auto settings = config::load_orbslam2_settings(c.orbslam2_settings);
  if (!settings) {
    return make_error(ErrorCode::kInvalidArgument,
                      source_name + ": source.orbslam2_settings: " + settings.error().message);
  }
  config::apply_orbslam2_settings(*settings, c.sitepose);
  c.orbslam2_ignored_keys = settings->ignored_keys;
  return ok_status();
}

}  // namespace

pipeline::ReplayOptions replay_options(const DaemonConfig& config) {
  pipeline::ReplayOptions o = config.replay;
  o.channel_order = config.sitepose.camera.channel_order;
  return o;
}

drivers::v4l2::V4l2SourceOptions v4l2_source_options(const DaemonConfig& config) {
  drivers::v4l2::V4l2SourceOptions o = config.v4l2.options;
  if (config.v4l2.side_by_side) o.right_device.clear();
  o.pair_tolerance_ns = std::llround(config.v4l2.pair_tolerance_ms * 1e6);
  o.wait_for_camera_s = config.wait_for_camera_s;
  return o;
}

const Section<DaemonConfig>& daemon_sections() {
  static const Section<DaemonConfig> sections = make_daemon_sections();
  return sections;
}

Expected<DaemonConfig> load_daemon_config_from_string(const std::string& text, const std::string& source_name,
                                                      const std::string& base_dir) {
  SITEPOSE_TRY(config::YamlReader reader, config::YamlReader::from_string(text, source_name));
  DaemonConfig c;
  daemon_sections().read(reader.root(), c);
  SITEPOSE_TRY_STATUS(reader.finish());
  for (std::string* path : {&c.replay.sequence_dir, &c.aravis.calibration, &c.aravis.feature_file,
                            &c.v4l2.options.calibration_file, &c.trajectory.path, &c.can.path,
                            &c.geo.nmea_file, &c.geo.geoid, &c.map.map_file, &c.orbslam2_settings}) {
    *path = resolve(base_dir, *path);
  }
  SITEPOSE_TRY_STATUS(import_orbslam2_settings(c, source_name));
  c.geo.anchor = anchor_options(c.geo);
  detect::add_inherent_dynamic_classes(c.sitepose.detector, c.sitepose.dynamic);
  if (auto st = pipeline::check_pipeline_options(c.pipeline); !st) {
    return make_error(ErrorCode::kInvalidArgument, source_name + ": " + st.error().message);
  }
  return c;
}

Expected<DaemonConfig> load_daemon_config(const std::string& path) {
  SITEPOSE_TRY(const std::string text, config::read_yaml_file(path));
  std::error_code ec;  // absolute() throws when the working directory is gone
  const fs::path absolute = fs::absolute(fs::path(path), ec);
  if (ec) return make_error(ErrorCode::kNotFound, "config file " + path + ": " + ec.message());
  const std::string base = absolute.parent_path().string();
  return load_daemon_config_from_string(text, path, base);
}

std::string to_yaml(const DaemonConfig& config) { return config::write_yaml(daemon_sections(), config); }

}  // namespace sitepose::daemon
