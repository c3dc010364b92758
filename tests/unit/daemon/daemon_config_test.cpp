#include "sitepose/daemon/daemon_config.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <string>
#include <vector>

#include "sitepose/config/config.hpp"
#include "sitepose/config/yaml_reader.hpp"

namespace sitepose::daemon {
namespace {

const std::string kShippedFile = SITEPOSE_SOURCE_DIR "/config/siteposed.yaml";

// A valid file: every output on, site frame fixed.
const std::string kValid =
    "source:\n  replay: {sequence: seq, rate: max}\n"
    "outputs:\n  trajectory: {path: traj.tum}\n  can: {path: logs/can.log}\n"
    "geo:\n  mode: fixed\n"
    "  origin: {latitude_deg: 48.137, longitude_deg: 11.575, height_m: 520.0}\n"
    "  T_site_slam: {translation_m: [0, 0, 2], rotation_wxyz: [0.5, -0.5, 0.5, -0.5]}\n"
    "dynamic: {mode: none}\n";

std::string load_error(const std::string& text) {
  const auto config = load_daemon_config_from_string(text, "d.yaml", "/etc/sitepose");
  EXPECT_FALSE(config.has_value()) << "loaded without error:\n" << text;
  return config ? "" : config.error().message;
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

bool contains_item(const std::vector<std::string>& list, const std::string& item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

// Every key of the daemon's sections is in config/siteposed.yaml with its
// default, except the deployment values the shipped file sets on purpose
// (each comment there states the default); the sitepose sections are
// documented in config/sitepose.yaml.
TEST(DaemonConfig, DocumentedFileAgreesWithTheTable) {
  config::DocumentedFile file{
      kShippedFile,
      {"source.replay.sequence", "outputs.trajectory.path", "outputs.can.path", "outputs.lcm.url", "geo.mode",
       "geo.origin.latitude_deg", "geo.origin.longitude_deg", "geo.origin.height_m",
       "geo.T_site_slam.translation_m", "geo.T_site_slam.rotation_wxyz", "detector.name", "mapping.map_file"},
      {}};
  for (const auto& entry : config::entries(config::sitepose_sections(), config::SiteposeConfig{}, false)) {
    if (entry.depth == 0) file.documented_elsewhere.push_back(entry.key);
  }
  ASSERT_EQ(file.documented_elsewhere.size(), 8u);
  const Status status = config::check_documented(daemon_sections(), file);
  EXPECT_TRUE(status.has_value()) << status.error().message;
  // siteposed's own keys inside sitepose sections (mapping.map_file, ...)
  // are documented here, not in config/sitepose.yaml: each must be in this
  // file with its default, or listed as a deployment value.
  std::vector<std::string> sitepose_paths;
  for (const auto& entry : config::entries(config::sitepose_sections(), config::SiteposeConfig{}, true)) {
    sitepose_paths.push_back(entry.path);
  }
  const auto shipped = load_daemon_config(kShippedFile);
  ASSERT_TRUE(shipped.has_value()) << shipped.error().message;
  const auto documented = config::entries(daemon_sections(), *shipped, true);
  auto reader = config::YamlReader::from_file(kShippedFile);
  ASSERT_TRUE(reader.has_value()) << reader.error().message;
  int own = 0;
  for (const auto& entry : config::entries(daemon_sections(), DaemonConfig{}, true)) {
    const std::string top = entry.path.substr(0, entry.path.find('.'));
    if (entry.section || !contains_item(file.documented_elsewhere, top) ||
        contains_item(sitepose_paths, entry.path)) {
      continue;
    }
    ++own;
    EXPECT_TRUE(reader->root().map(top).has(entry.key))
        << entry.path << ": not documented in " << kShippedFile;
    for (const auto& d : documented) {
      if (d.path != entry.path) continue;
      EXPECT_EQ(d.value != entry.value, contains_item(file.shipped_values, entry.path))
          << entry.path << " = " << d.value << " (default " << entry.value << ")";
    }
  }
  // mapping.map_file, mapping.checkpoint_interval_s, dynamic.detector_deadline_ms, dynamic.detector_isolation
  EXPECT_EQ(own, 4);
}

TEST(DaemonConfig, ShippedFileLoadsAndWritesWhatReadsBackTheSame) {
  const auto shipped = load_daemon_config(kShippedFile);
  ASSERT_TRUE(shipped.has_value()) << shipped.error().message;
  EXPECT_EQ(shipped->replay.sequence_dir, "/var/lib/siteposed/replay");
  EXPECT_EQ(shipped->geo.mode, GeoMode::kFixed);
  // The paper's system, with a detector that works on live cameras.
  EXPECT_EQ(shipped->sitepose.dynamic.mode, config::MaskingMode::kFull);
  EXPECT_EQ(shipped->sitepose.detector.name, "stereo-geometric");
  const std::string text = to_yaml(*shipped);
  const auto again = load_daemon_config_from_string(text, "resolved.yaml", "");
  ASSERT_TRUE(again.has_value()) << again.error().message << "\n" << text;
  EXPECT_EQ(to_yaml(*again), text);
}

TEST(DaemonConfig, ReadsTheDaemonSectionsAndResolvesPaths) {
  std::string text = kValid;
  const std::string can = "  can: {path: logs/can.log}\n";
  text.replace(text.find(can), can.size(),
               "  can: {sink: stdout, source_address: 30, frames: {n2k_vessel_heading: false}}\n"
               "  lcm: {url: \"memq://\", max_send_attempts: 2}\n");
  const auto config = load_daemon_config_from_string(
      text + "pipeline: {capture_ring_capacity: 8}\nsupervisor: {log_interval_s: 2.5}\n", "d.yaml",
      "/etc/sitepose");
  ASSERT_TRUE(config.has_value()) << config.error().message;
  EXPECT_EQ(config->replay.sequence_dir, "/etc/sitepose/seq");
  EXPECT_EQ(config->replay.rate, pipeline::ReplayRate::kMax);
  EXPECT_EQ(config->trajectory.path, "/etc/sitepose/traj.tum");
  EXPECT_EQ(config->pipeline.capture_ring_capacity, 8u);
  EXPECT_DOUBLE_EQ(config->supervisor.log_interval_s, 2.5);
  EXPECT_EQ(config->can.sink, CanSinkKind::kStdout);
  EXPECT_EQ(config->can.frames.source_address, 30);
  EXPECT_FALSE(config->can.frames.n2k_vessel_heading);
  EXPECT_EQ(config->lcm.lcm.url, "memq://");
  EXPECT_EQ(config->lcm.lcm.max_send_attempts, 2);
  EXPECT_DOUBLE_EQ(config->geo.T_site_slam.translation().z(), 2.0);
  EXPECT_DOUBLE_EQ(config->geo.T_site_slam.rotation().w(), 0.5);
  // The anchor takes the site origin, given once for every mode.
  EXPECT_DOUBLE_EQ(config->geo.anchor.origin.latitude_deg, 48.137);
}

TEST(DaemonConfig, BadValuesAreNamedWithFileLineKeyAndRule) {
  const std::string message = load_error(
      "source:\n  replay: {sequence: /nonexistent, rate: fastest}\n"
      "pipeline: {capture_ring_capacity: 6}\n"
      "outputs:\n  lcm: {urll: x}\n  can: {enabled: true, path: can.log}\n"
      "dynamic: {mode: fullest}\n");
  EXPECT_TRUE(contains(message, "d.yaml:2: source.replay.rate = \"fastest\"")) << message;
  EXPECT_TRUE(contains(message,
                       "d.yaml:3: pipeline.capture_ring_capacity = 6: must be a power of "
                       "two in [2, 1048576]"))
      << message;
  EXPECT_TRUE(contains(message, "d.yaml:5: outputs.lcm.urll: unknown key")) << message;
  EXPECT_TRUE(contains(message,
                       "d.yaml:6: outputs.can.enabled = true: CAN frames carry WGS84 "
                       "positions: needs geo.mode fixed or online"))
      << message;
  EXPECT_TRUE(contains(message, "d.yaml:7: dynamic.mode = \"fullest\": unknown masking mode")) << message;
  EXPECT_TRUE(contains(message, "outputs.trajectory.path: missing (required key)")) << message;
  // A zero floor would let a first pose go out with a zero covariance.
  const std::string zero_floor = load_error(
      "source:\n  replay: {sequence: /nonexistent}\noutputs:\n  covariance: {floor_position_m: 0}\n");
  EXPECT_TRUE(contains(zero_floor, "outputs.covariance.floor_position_m = 0")) << zero_floor;
  // A protection level under one standard deviation would claim an
  // integrity the covariance does not give.
  const std::string thin_protection = load_error(
      "source:\n  replay: {sequence: /nonexistent}\noutputs:\n  integrity: {protection_level_sigmas: 0.5}\n");
  EXPECT_TRUE(contains(thin_protection, "outputs.integrity.protection_level_sigmas = 0.5"))
      << thin_protection;
}

TEST(DaemonConfig, RequirementsThatDependOnOtherKeys) {
  EXPECT_TRUE(contains(load_error("outputs:\n  can: {enabled: false}\n  trajectory: {enabled: false}\n"),
                       "source.replay.sequence: missing (required key)"));
  const std::string geo_needs = load_error(
      "source: {replay: {sequence: s}}\noutputs: {trajectory: {enabled: false}, can: {path: c}}\n"
      "geo: {mode: fixed}\n");
  EXPECT_TRUE(contains(geo_needs, "geo.origin.latitude_deg: missing (required key)")) << geo_needs;
  EXPECT_TRUE(contains(geo_needs, "geo.T_site_slam: required with geo.mode = fixed")) << geo_needs;
  const std::string nmea = load_error(
      "source: {replay: {sequence: s}}\noutputs: {trajectory: {enabled: false}, can: {enabled: false}}\n"
      "geo:\n  mode: online\n  origin: {latitude_deg: 1, longitude_deg: 2, height_m: 3}\n"
      "  online: {gnss_input: nmea_file, min_inliers: 5000}\n");
  EXPECT_TRUE(contains(nmea, "geo.online.nmea_file: missing (required key)")) << nmea;
  // The anchor's own rules, reported at the section.
  EXPECT_TRUE(contains(nmea, "d.yaml:6: geo.online: ")) << nmea;
  // A disabled output needs no path.
  const auto quiet = load_daemon_config_from_string(
      "source: {replay: {sequence: s}}\noutputs: {trajectory: {enabled: false}, can: {enabled: false}}\n",
      "d.yaml", "");
  EXPECT_TRUE(quiet.has_value()) << quiet.error().message;
}

TEST(DaemonConfig, FortyThousandKeysAreRejectedWithinSeconds) {
  std::string text = kValid + "pipeline:\n";
  for (int i = 0; i < 40000; ++i) text += "  ring" + std::to_string(i) + ": 4\n";
  const std::clock_t start = std::clock();  // CPU time: a loaded machine cannot fail it
  const std::string message = load_error(text);
  EXPECT_LT(static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC, 2.0);
  EXPECT_TRUE(contains(message, "pipeline.ring0: unknown key")) << message.substr(0, 300);
  EXPECT_TRUE(contains(message, "39900 more problems not shown")) << message.substr(0, 300);
}

TEST(DaemonConfig, DirectoryOrMissingFileIsAnError) {
  const auto dir = load_daemon_config(std::filesystem::temp_directory_path().string());
  ASSERT_FALSE(dir.has_value());
  EXPECT_EQ(dir.error().exit_status(), 2);
  EXPECT_TRUE(contains(dir.error().message, "is a directory")) << dir.error().message;
  const auto missing = load_daemon_config("/nonexistent/nope.yaml");
  ASSERT_FALSE(missing.has_value());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  EXPECT_TRUE(contains(missing.error().message, "/nonexistent/nope.yaml"));
}

}  // namespace
}  // namespace sitepose::daemon

namespace sitepose::daemon {
namespace {

const std::string kAravisBase =
    "outputs:\n  can: {enabled: false}\n  trajectory: {path: t.tum}\n"
    "dynamic: {mode: none}\nsource:\n  type: aravis\n";

TEST(DaemonConfig, AravisSourceReadsItsKeysAndResolvesTheCalibration) {
  const auto config = load_daemon_config_from_string(
      kAravisBase +
          "  wait_for_camera_s: 5\n"
          "  aravis: {left_id: Cam-A, right_id: Cam-B, calibration: rig/stereo.yaml, pixel_format: "
          "BayerRG8,\n"
          "           trigger: software, frame_rate_hz: 15, roi: {x: 8, width: 1280, height: 720},\n"
          "           pair_clock: camera, exposure_auto: false, exposure_us: 2500}\n",
      "d.yaml", "/etc/sitepose");
  ASSERT_TRUE(config) << config.error().message;
  EXPECT_EQ(config->source_type, "aravis");
  EXPECT_EQ(config->wait_for_camera_s, 5.0);
  const drivers::aravis::AravisSourceOptions& a = config->aravis;
  EXPECT_EQ(a.right_id, "Cam-B");
  EXPECT_EQ(a.calibration, "/etc/sitepose/rig/stereo.yaml");
  EXPECT_EQ(a.camera.pixel_format, drivers::aravis::PixelFormat::kBayerRG8);
  EXPECT_EQ(a.camera.trigger, drivers::aravis::TriggerMode::kSoftware);
  EXPECT_EQ(a.camera.roi.x, 8);
  EXPECT_EQ(a.camera.roi.height, 720);
  EXPECT_EQ(a.pair_clock, drivers::aravis::PairClock::kCamera);
  EXPECT_FALSE(a.camera.exposure_auto);
  // Written and read back the same.
  const auto again = load_daemon_config_from_string(to_yaml(*config), "resolved.yaml", "");
  ASSERT_TRUE(again) << again.error().message;
  EXPECT_EQ(again->aravis.calibration, a.calibration);
  EXPECT_EQ(again->aravis.camera.frame_rate_hz, 15.0);
}

TEST(DaemonConfig, AravisSourceErrorsNameTheKeys) {
  const std::string missing = load_error(kAravisBase + "  aravis: {left_id: Cam-A}\n");
  EXPECT_TRUE(contains(missing, "source.aravis.right_id")) << missing;
  EXPECT_TRUE(contains(missing, "source.aravis.calibration")) << missing;
  const std::string format = load_error(
      kAravisBase + "  aravis: {left_id: A, right_id: B, calibration: c.yaml, pixel_format: RGB8}\n");
  EXPECT_TRUE(contains(format, "source.aravis.pixel_format")) << format;
  EXPECT_TRUE(contains(format, "Mono8, Mono16, BayerRG8")) << format;
  const std::string relations =
      load_error(kAravisBase +
                 "  aravis: {left_id: A, right_id: A, calibration: c.yaml, frame_rate_hz: 30,\n"
                 "           pair_tolerance_ms: 20}\n");
  EXPECT_TRUE(contains(relations, "right_id: must differ from left_id")) << relations;
  EXPECT_TRUE(contains(relations, "pair_tolerance_ms = 20")) << relations;
  const std::string trigger =
      load_error(kAravisBase + "  aravis: {left_id: A, right_id: B, calibration: c.yaml, trigger: laser}\n");
  EXPECT_TRUE(contains(trigger, "source.aravis.trigger")) << trigger;
  const std::string hardware = load_error(
      kAravisBase + "  aravis: {left_id: A, right_id: B, calibration: c.yaml, trigger: hardware}\n");
  EXPECT_TRUE(contains(hardware, "trigger: hardware needs a feature_file")) << hardware;
  // A replay source still needs its sequence.
  const std::string replay = load_error("source: {type: replay}\n");
  EXPECT_TRUE(contains(replay, "source.replay.sequence")) << replay;
}

const std::string kActionCameras =
    "  aravis:\n"
    "    left_id: A\n    right_id: B\n    calibration: c.yaml\n"
    "    trigger: action\n    pair_clock: camera\n    frame_rate_hz: 20\n";

TEST(DaemonConfig, AravisActionTriggerReadsItsKeys) {
  const auto config = load_daemon_config_from_string(
      kAravisBase + kActionCameras +
          "    action: {device_key: 0x5EC0, group_key: 36, group_mask: 0x80000001,\n"
          "             destination: 192.168.10.255, lead_time_ms: 8}\n",
      "d.yaml", "/etc/sitepose");
  ASSERT_TRUE(config) << config.error().message;
  const drivers::aravis::CameraSettings& c = config->aravis.camera;
  EXPECT_EQ(c.trigger, drivers::aravis::TriggerMode::kAction);
  EXPECT_EQ(c.action.device_key, 0x5EC0u);
  EXPECT_EQ(c.action.group_key, 36u);
  EXPECT_EQ(c.action.group_mask, 0x80000001u);
  EXPECT_EQ(c.action.destination, "192.168.10.255");
  EXPECT_EQ(c.action.lead_time_ms, 8.0);
  const std::string written = to_yaml(*config);
  EXPECT_TRUE(contains(written, "group_mask: 0x80000001")) << written;
  const auto again = load_daemon_config_from_string(written, "resolved.yaml", "");
  ASSERT_TRUE(again) << again.error().message;
  EXPECT_EQ(again->aravis.camera.action.group_mask, 0x80000001u);
  EXPECT_EQ(again->aravis.camera.trigger, drivers::aravis::TriggerMode::kAction);
}

TEST(DaemonConfig, AravisActionTriggerErrorsNameTheKeys) {
  const auto failed = load_daemon_config_from_string(
      kAravisBase + kActionCameras + "    action: {device_key: 0x1FFFFFFFF, lead_time_ms: 0}\n", "d.yaml",
      "");
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().exit_status(), 2);
  const std::string& bad = failed.error().message;
  EXPECT_TRUE(contains(bad, "source.aravis.action.device_key = \"0x1FFFFFFFF\": expected a 32-bit key"))
      << bad;
  EXPECT_TRUE(contains(bad, "source.aravis.action.lead_time_ms = 0")) << bad;
  const std::string relations = load_error(
      kAravisBase + kActionCameras + "    action: {group_mask: 0, lead_time_ms: 50, destination: nic0}\n");
  EXPECT_TRUE(contains(relations, "action.group_mask: must not be 0")) << relations;
  EXPECT_TRUE(contains(relations, "action.lead_time_ms = 50.000000: must be in (0, 50.000000)")) << relations;
  EXPECT_TRUE(contains(relations, "action.destination = \"nic0\": expected a dotted IPv4 address"))
      << relations;
  const std::string host_clock = load_error(
      kAravisBase +
      "  aravis: {left_id: A, right_id: B, calibration: c.yaml, trigger: action, pair_clock: host}\n");
  EXPECT_TRUE(contains(host_clock, "pair_clock: trigger action needs camera")) << host_clock;
}

}  // namespace
}  // namespace sitepose::daemon
