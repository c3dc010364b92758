#include "daemon_config.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "sitepose/config/config.hpp"
#include "sitepose/config/yaml_reader.hpp"
#include "sitepose/detect/create_detector.hpp"

namespace sitepose::daemon {
namespace {

namespace fs = std::filesystem;
using config::YamlMap;

std::string resolve(const std::string& base_dir, const std::string& path) {
  if (path.empty() || fs::path(path).is_absolute() || base_dir.empty()) return path;
  return (fs::path(base_dir) / path).lexically_normal().string();
}

void read_source(const YamlMap& s, DaemonConfig& c, const std::string& base) {
  s.read("type", c.source_type, config::one_of({"replay"}));
  const YamlMap r = s.map("replay");
  if (c.source_type == "replay") {
    r.read_required("sequence", c.replay.sequence_dir, config::non_empty());
    c.replay.sequence_dir = resolve(base, c.replay.sequence_dir);
  }
  r.read_parsed("rate", c.replay.rate, [](const std::string& t) { return pipeline::parse_replay_rate(t); });
  r.read("loop", c.replay.loop);
  r.read("max_frames", c.replay.max_frames, config::non_negative());
}

void read_pipeline(const YamlMap& s, pipeline::PipelineOptions& p) {
  int capture = static_cast<int>(p.capture_ring_capacity);
  int detect = static_cast<int>(p.detect_ring_capacity);
  int publish = static_cast<int>(p.publish_ring_capacity);
  auto power_of_two = config::make_rule(
      [](int v) { return v >= 2 && v <= (1 << 20) && (v & (v - 1)) == 0; },
      "must be a power of two in [2, 1048576]");
  if (s.read("capture_ring_capacity", capture, power_of_two)) p.capture_ring_capacity = capture;
  if (s.read("detect_ring_capacity", detect, power_of_two)) p.detect_ring_capacity = detect;
  if (s.read("publish_ring_capacity", publish, power_of_two)) p.publish_ring_capacity = publish;
  s.read("stall_timeout_s", p.stall_timeout_s, config::in_range(0.05, 3600.0));
  s.read("publish_max_attempts", p.publish_max_attempts, config::in_range(1, 100));
  s.read("publish_retry_delay_s", p.publish_retry_delay_s, config::in_range(0.0, 1.0));
  s.read("health_interval_s", p.health_interval_s, config::in_range(0.05, 3600.0));
}

void read_supervisor(const YamlMap& s, pipeline::SupervisorOptions& o) {
  s.read("status_interval_s", o.status_interval_s, config::in_range(0.05, 3600.0));
  s.read("log_interval_s", o.log_interval_s, config::in_range(0.1, 86400.0));
}

void read_outputs(const YamlMap& s, DaemonConfig& c, const std::string& base) {
  const YamlMap t = s.map("trajectory");
  t.read("enabled", c.trajectory.enabled);
  if (c.trajectory.enabled) t.read_required("path", c.trajectory.path, config::non_empty());
  t.read("append", c.trajectory.append);
  c.trajectory.path = resolve(base, c.trajectory.path);

  const YamlMap can = s.map("can");
  can.read("enabled", c.can.enabled);
  std::string sink = "candump";
  if (can.read("sink", sink, config::one_of({"candump", "stdout"}))) {
    c.can.sink = sink == "stdout" ? CanSinkKind::kStdout : CanSinkKind::kCandumpFile;
  }
  if (c.can.enabled && c.can.sink == CanSinkKind::kCandumpFile) {
    can.read_required("path", c.can.path, config::non_empty());
  } else {
    can.read("path", c.can.path);
  }
  c.can.path = resolve(base, c.can.path);
  can.read("interface", c.can.interface,
           config::make_rule([](const std::string& v) {
             return !v.empty() && v.find_first_of(" \t") == std::string::npos;
           }, "must be a non-empty name without blanks"));
  int sa = c.can.frames.source_address;
  if (can.read("source_address", sa, config::in_range(0, 253))) {
    c.can.frames.source_address = static_cast<std::uint8_t>(sa);
  }
  const YamlMap f = can.map("frames");
  f.read("j1939_vehicle_position", c.can.frames.j1939_vehicle_position);
  f.read("j1939_vehicle_direction_speed", c.can.frames.j1939_vehicle_direction_speed);
  f.read("n2k_position_rapid_update", c.can.frames.n2k_position_rapid_update);
  f.read("n2k_cog_sog_rapid_update", c.can.frames.n2k_cog_sog_rapid_update);
  f.read("n2k_gnss_position_data", c.can.frames.n2k_gnss_position_data);
  f.read("n2k_vessel_heading", c.can.frames.n2k_vessel_heading);
  f.read("sitepose_pose_quality", c.can.frames.sitepose_pose_quality);
  if (c.can.enabled) {
    if (auto st = output::check_can_output_options(c.can.frames); !st) {
      can.report("frames", st.error().message);
    }
  }

  const YamlMap l = s.map("lcm");
  l.read("enabled", c.lcm.enabled);
  l.read("url", c.lcm.lcm.url);
  l.read("pose_channel", c.lcm.lcm.pose_channel);
  l.read("health_channel", c.lcm.lcm.health_channel);
  l.read("gnss_channel", c.lcm.lcm.gnss_channel);
  l.read("max_send_attempts", c.lcm.lcm.max_send_attempts);
  if (auto st = c.lcm.lcm.validate(l.path()); !st) l.report_here(st.error().message);
}

bool read_vector3(const YamlMap& m, std::string_view key, Eigen::Vector3d& out) {
  std::vector<double> v;
  if (!m.has(key)) return false;
  if (!m.read(key, v, config::make_rule([](const std::vector<double>& x) { return x.size() == 3; },
                                        "expected a list of 3 numbers"))) {
    return false;
  }
  out = Eigen::Vector3d(v[0], v[1], v[2]);
  return true;
}

void read_geo(const YamlMap& s, GeoConfig& g, const std::string& base) {
  std::string mode = "none";
  if (s.read("mode", mode, config::one_of({"none", "fixed", "online"}))) {
    g.mode = mode == "fixed" ? GeoMode::kFixed : mode == "online" ? GeoMode::kOnline : GeoMode::kNone;
  }
  const bool needed = g.mode != GeoMode::kNone;
  const YamlMap o = s.map("origin");
  auto read_origin = [&](std::string_view key, double& v, auto rule) {
    if (needed) o.read_required(key, v, rule); else o.read(key, v, rule);
  };
  read_origin("latitude_deg", g.origin.latitude_deg, config::in_range(-90.0, 90.0));
  read_origin("longitude_deg", g.origin.longitude_deg, config::in_range(-180.0, 180.0));
  read_origin("height_m", g.origin.height_m, config::in_range(-1000.0, 10000.0));
  s.read_parsed("forward_axis", g.forward_axis_cam,
                [](const std::string& t) { return geo::parse_forward_axis(t); });

  const YamlMap t = s.map("T_site_slam");
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  std::vector<double> q{1.0, 0.0, 0.0, 0.0};
  if (g.mode == GeoMode::kFixed && !s.has("T_site_slam")) {
    s.report("T_site_slam", "required with geo.mode = fixed (translation_m, rotation_wxyz)");
  }
  read_vector3(t, "translation_m", translation);
  if (t.read("rotation_wxyz", q, config::make_rule([](const std::vector<double>& x) {
               if (x.size() != 4) return false;
               const double n = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]);
               return std::abs(n - 1.0) < 1e-3;
             }, "expected a unit quaternion [w, x, y, z] (norm within 1e-3 of 1)"))) {
  }
  g.T_site_slam = SE3(Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized(), translation);

  const YamlMap on = s.map("online");
  std::string input = "lcm";
  if (on.read("gnss_input", input, config::one_of({"lcm", "nmea_file"}))) {
    g.gnss_input = input == "nmea_file" ? GnssInput::kNmeaFile : GnssInput::kLcm;
  }
  if (g.mode == GeoMode::kOnline && g.gnss_input == GnssInput::kNmeaFile) {
    on.read_required("nmea_file", g.nmea_file, config::non_empty());
  } else {
    on.read("nmea_file", g.nmea_file);
  }
  g.nmea_file = resolve(base, g.nmea_file);
  read_vector3(on, "p_cam_antenna_m", g.anchor.p_cam_antenna_m);
  double offset_s = static_cast<double>(g.anchor.gnss_clock_offset_ns) * 1e-9;
  if (on.read("gnss_clock_offset_s", offset_s, config::in_range(-1e10, 1e10))) {
    g.anchor.gnss_clock_offset_ns = static_cast<std::int64_t>(std::llround(offset_s * 1e9));
  }
  on.read("min_inliers", g.anchor.min_inliers, config::in_range(3, 100000));
  on.read("min_lateral_spread_m", g.anchor.min_lateral_spread_m, config::non_negative());
  on.read("freeze_inliers", g.anchor.freeze_inliers, config::in_range(3, 1000000));
  on.read("freeze_lateral_spread_m", g.anchor.freeze_lateral_spread_m, config::non_negative());
  g.anchor.origin = g.origin;
  g.anchor.forward_axis_cam = g.forward_axis_cam;
  if (g.mode == GeoMode::kOnline) {
    if (auto st = g.anchor.validate(); !st) on.report_here(st.error().message);
  }
}

}  // namespace

Expected<DaemonConfig> load_daemon_config_from_string(const std::string& text,
                                                      const std::string& source_name,
                                                      const std::string& base_dir) {
  SITEPOSE_TRY(config::YamlReader reader, config::YamlReader::from_string(text, source_name));
  const YamlMap root = reader.root();
  DaemonConfig c;
  read_source(root.map("source"), c, base_dir);
  read_pipeline(root.map("pipeline"), c.pipeline);
  read_supervisor(root.map("supervisor"), c.supervisor);
  read_outputs(root.map("outputs"), c, base_dir);
  read_geo(root.map("geo"), c.geo, base_dir);
  config::read_config(root, c.sitepose);
  if (c.can.enabled && c.geo.mode == GeoMode::kNone) {
    root.map("outputs").map("can").report(
        "enabled", "CAN frames carry WGS84 positions: needs geo.mode fixed or online");
  }
  if (c.sitepose.dynamic.mode != config::MaskingMode::kNone && c.sitepose.detector.name == "labels" &&
      c.source_type != "replay") {
    root.map("detector").report("name", "\"labels\" reads a recorded sequence's labels: needs source.type replay");
  }
  SITEPOSE_TRY_STATUS(reader.finish());
  detect::add_inherent_dynamic_classes(c.sitepose.detector, c.sitepose.dynamic);
  if (auto st = pipeline::check_pipeline_options(c.pipeline); !st) {
    return make_error(ErrorCode::kInvalidArgument, source_name + ": " + st.error().message);
  }
  return c;
}

Expected<DaemonConfig> load_daemon_config(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return make_error(ErrorCode::kNotFound, "cannot open config file " + path + ": " + std::strerror(errno));
  }
  std::ostringstream text;
  text << in.rdbuf();
  std::error_code ec;  // absolute() throws when the working directory is gone
  const fs::path absolute = fs::absolute(fs::path(path), ec);
  if (ec) return make_error(ErrorCode::kNotFound, "config file " + path + ": " + ec.message());
  const std::string base = absolute.parent_path().string();
  return load_daemon_config_from_string(text.str(), path, base);
}

std::string daemon_sections_to_yaml(const DaemonConfig& c) {
  const auto b = [](bool v) { return v ? "true" : "false"; };
  std::string y;
  y += fmt::format("source:\n  type: {}\n  replay:\n    sequence: \"{}\"\n    rate: {}\n    loop: {}\n    max_frames: {}\n",
                   c.source_type, c.replay.sequence_dir, pipeline::to_string(c.replay.rate),
                   b(c.replay.loop), c.replay.max_frames);
  const auto& p = c.pipeline;
  y += fmt::format("pipeline:\n  capture_ring_capacity: {}\n  detect_ring_capacity: {}\n  publish_ring_capacity: {}\n"
                   "  stall_timeout_s: {}\n  publish_max_attempts: {}\n  publish_retry_delay_s: {}\n  health_interval_s: {}\n",
                   p.capture_ring_capacity, p.detect_ring_capacity, p.publish_ring_capacity, p.stall_timeout_s,
                   p.publish_max_attempts, p.publish_retry_delay_s, p.health_interval_s);
  y += fmt::format("supervisor:\n  status_interval_s: {}\n  log_interval_s: {}\n", c.supervisor.status_interval_s,
                   c.supervisor.log_interval_s);
  y += fmt::format("outputs:\n  trajectory:\n    enabled: {}\n    path: \"{}\"\n    append: {}\n", b(c.trajectory.enabled),
                   c.trajectory.path, b(c.trajectory.append));
  const auto& f = c.can.frames;
  y += fmt::format("  can:\n    enabled: {}\n    sink: {}\n    path: \"{}\"\n    interface: {}\n    source_address: {}\n"
                   "    frames: {{j1939_vehicle_position: {}, j1939_vehicle_direction_speed: {}, n2k_position_rapid_update: {}, "
                   "n2k_cog_sog_rapid_update: {}, n2k_gnss_position_data: {}, n2k_vessel_heading: {}, sitepose_pose_quality: {}}}\n",
                   b(c.can.enabled), c.can.sink == CanSinkKind::kStdout ? "stdout" : "candump", c.can.path,
                   c.can.interface, static_cast<int>(f.source_address), b(f.j1939_vehicle_position),
                   b(f.j1939_vehicle_direction_speed), b(f.n2k_position_rapid_update), b(f.n2k_cog_sog_rapid_update),
                   b(f.n2k_gnss_position_data), b(f.n2k_vessel_heading), b(f.sitepose_pose_quality));
  y += fmt::format("  lcm:\n    enabled: {}\n    url: \"{}\"\n    pose_channel: {}\n    health_channel: {}\n    gnss_channel: {}\n"
                   "    max_send_attempts: {}\n",
                   b(c.lcm.enabled), c.lcm.lcm.url, c.lcm.lcm.pose_channel, c.lcm.lcm.health_channel,
                   c.lcm.lcm.gnss_channel, c.lcm.lcm.max_send_attempts);
  const auto& g = c.geo;
  const auto& q = g.T_site_slam.rotation();
  const auto& t = g.T_site_slam.translation();
  y += fmt::format("geo:\n  mode: {}\n  origin: {{latitude_deg: {}, longitude_deg: {}, height_m: {}}}\n  forward_axis: \"{}\"\n"
                   "  T_site_slam: {{translation_m: [{}, {}, {}], rotation_wxyz: [{}, {}, {}, {}]}}\n",
                   g.mode == GeoMode::kFixed ? "fixed" : g.mode == GeoMode::kOnline ? "online" : "none",
                   g.origin.latitude_deg, g.origin.longitude_deg, g.origin.height_m, geo::to_string(g.forward_axis_cam),
                   t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z());
  const auto& a = g.anchor;
  y += fmt::format("  online:\n    gnss_input: {}\n    nmea_file: \"{}\"\n    p_cam_antenna_m: [{}, {}, {}]\n"
                   "    gnss_clock_offset_s: {}\n    min_inliers: {}\n    min_lateral_spread_m: {}\n"
                   "    freeze_inliers: {}\n    freeze_lateral_spread_m: {}\n",
                   g.gnss_input == GnssInput::kNmeaFile ? "nmea_file" : "lcm", g.nmea_file, a.p_cam_antenna_m.x(),
                   a.p_cam_antenna_m.y(), a.p_cam_antenna_m.z(), static_cast<double>(a.gnss_clock_offset_ns) * 1e-9,
                   a.min_inliers, a.min_lateral_spread_m, a.freeze_inliers, a.freeze_lateral_spread_m);
  return y;
}

}  // namespace sitepose::daemon
