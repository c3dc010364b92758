// Encodes known poses into a candump log with the C++ encoder and sink, then
// decodes the log with the independent decoder (tools/can_decode.py: its own
// DBC parser over python3-can's log reader) and compares every decoded value
// with the input, within the field's resolution.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "sitepose/output/can_pose_encoder.hpp"
#include "sitepose/output/can_sink.hpp"
#include "sitepose/output/candump.hpp"
#include "sitepose/testing/files.hpp"
#include "sitepose/testing/mini_json.hpp"

namespace sitepose::output {
namespace {

using sitepose::testing::Json;
using sitepose::testing::JsonParser;

constexpr double kPi = std::numbers::pi;
constexpr char kPython[] = "/usr/bin/python3";
constexpr int kPoses = 40;

double wrap_two_pi(double a) {
  a = std::fmod(a, 2 * kPi);
  return a < 0 ? a + 2 * kPi : a;
}

CanPoseInputs pose(int k) {
  CanPoseInputs in;
  in.utc_t_ns = 1'700'000'000'000'000'000LL + k * 100'000'000LL + k * 1'234'567LL;
  in.latitude_deg = 48.1 + k * 1.1e-5 + 0.123456789e-7;
  in.longitude_deg = 11.5 - k * 2.3e-5;
  in.altitude_m = 500.0 + k * 0.37;
  // A geoid height, or none (every tenth pose): then n/a in 129029 and SPN 580.
  in.geoidal_separation_m = k % 10 == 5 ? std::numeric_limits<double>::quiet_NaN() : 47.0 + k * 0.013;
  in.heading_rad = k * 0.3 - 1.0;  // negative and > 2 pi values wrap
  in.course_over_ground_rad = in.heading_rad + 0.01;
  in.speed_over_ground_mps = k * 0.25;
  in.pitch_rad = 0.02 * std::sin(k);
  in.quality.state = k % 10 == 7   ? TrackingState::kLost
                     : k % 10 == 3 ? TrackingState::kRecovering
                                   : TrackingState::kOk;
  in.quality.features_used = 100 + 7 * k;
  in.quality.position_std_m = 0.001 * k;
  in.quality.rotation_std_rad = 0.001 * k;
  in.quality.masked_area_ratio = k / 50.0;
  return in;
}

class CanDecodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::access(kPython, X_OK) != 0) GTEST_SKIP() << kPython << " is missing";
    if (std::system("/usr/bin/python3 -c 'import can' 2>/dev/null") != 0) {
      GTEST_SKIP() << "python3-can is missing for /usr/bin/python3";
    }
  }

  std::string write_log() {
    const std::string path = (dir_ / "poses.log").string();
    auto sink = CandumpSink::open_file(path, "can0");
    EXPECT_TRUE(sink.has_value());
    CanPoseEncoder encoder(CanOutputOptions{});
    for (int k = 0; k < kPoses; ++k) {
      const CanPoseInputs in = pose(k);
      for (const CanFrame& f : encoder.encode(in)) EXPECT_TRUE((*sink)->send(in.utc_t_ns, f).has_value());
      EXPECT_TRUE((*sink)->flush().has_value());
    }
    return path;
  }

  // Runs the decoder; returns its exit status and fills `out`.
  int decode(const std::string& log, Json& out) {
    const std::string json_path = (dir_ / "decoded.json").string();
    const std::string cmd = std::string(kPython) + " " SITEPOSE_SOURCE_DIR "/tools/can_decode.py --dbc " +
                            SITEPOSE_SOURCE_DIR "/config/can/sitepose.dbc " + log + " > " + json_path;
    const int rc = std::system(cmd.c_str());
    const std::string json = sitepose::testing::read_text(json_path);  // the parser keeps a view of it
    JsonParser parser(json);
    auto parsed = parser.parse();
    EXPECT_TRUE(parsed.has_value()) << parser.error() << "\n" << json.substr(0, 500);
    if (parsed) out = *parsed;
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  }

  sitepose::testing::TempDir tmp_;
  const std::filesystem::path dir_ = tmp_.path();
};

void expect_near_or_null(const Json& v, bool expect_null, double expected, double tol,
                         const std::string& what) {
  if (expect_null) {
    EXPECT_TRUE(v.is_null()) << what << " should be not-available";
    return;
  }
  ASSERT_FALSE(v.is_null()) << what;
  EXPECT_NEAR(v.number(), expected, tol) << what;
}

TEST_F(CanDecodeTest, DecodedValuesMatchThePosesWithinResolution) {
  Json out;
  ASSERT_EQ(decode(write_log(), out), 0);
  ASSERT_TRUE(out["errors"].array().empty());
  const auto& msgs = out["messages"].array();
  const char* order[] = {"N2kPositionRapidUpdate", "N2kCogSogRapidUpdate", "N2kVesselHeading",
                         "N2kGnssPositionData",    "J1939VehiclePosition", "J1939VehicleDirectionSpeed",
                         "SiteposePoseQuality"};
  ASSERT_EQ(msgs.size(), static_cast<std::size_t>(7 * kPoses));
  for (int k = 0; k < kPoses; ++k) {
    const CanPoseInputs in = pose(k);
    const bool lost = in.quality.state == TrackingState::kLost;
    const std::string at = "pose " + std::to_string(k);
    for (int m = 0; m < 7; ++m) {
      const Json& msg = msgs[7 * k + m];
      ASSERT_EQ(msg["name"].string(), order[m]) << at;
      EXPECT_EQ(msg["source_address"].number(), 0x1C) << at;
      // The log keeps microseconds, truncated.
      EXPECT_NEAR(msg["t"].number(), (in.utc_t_ns / 1000) * 1e-6, 2e-6) << at;
    }
    const Json& rapid = msgs[7 * k]["signals"];
    expect_near_or_null(rapid["Latitude"], lost, in.latitude_deg, 0.5e-7 + 1e-12, at + " 129025 lat");
    expect_near_or_null(rapid["Longitude"], lost, in.longitude_deg, 0.5e-7 + 1e-12, at + " 129025 lon");

    const Json& cog = msgs[7 * k + 1]["signals"];
    EXPECT_EQ(cog["Sid"].number(), k % 253) << at;
    EXPECT_EQ(cog["CogReference"].number(), 0) << at;
    expect_near_or_null(cog["Cog"], lost, wrap_two_pi(in.course_over_ground_rad), 0.5e-4 + 1e-9, at + " cog");
    expect_near_or_null(cog["Sog"], lost, in.speed_over_ground_mps, 0.005 + 1e-9, at + " sog");

    const Json& hdg = msgs[7 * k + 2]["signals"];
    EXPECT_EQ(hdg["Sid"].number(), k % 253) << at;
    expect_near_or_null(hdg["Heading"], lost, wrap_two_pi(in.heading_rad), 0.5e-4 + 1e-9, at + " heading");
    EXPECT_TRUE(hdg["Deviation"].is_null()) << at;
    EXPECT_TRUE(hdg["Variation"].is_null()) << at;
    EXPECT_EQ(hdg["Reference"].number(), 0) << at;

    const Json& gnss = msgs[7 * k + 3]["signals"];
    EXPECT_EQ(gnss["Sid"].number(), k % 253) << at;
    const double t_s = gnss["Date"].number() * 86400.0 + gnss["Time"].number();
    EXPECT_NEAR(t_s, in.utc_t_ns * 1e-9, 1e-4 + 1e-6) << at;
    expect_near_or_null(gnss["Latitude"], lost, in.latitude_deg, 1e-12, at + " 129029 lat");
    expect_near_or_null(gnss["Longitude"], lost, in.longitude_deg, 1e-12, at + " 129029 lon");
    expect_near_or_null(gnss["Altitude"], lost, in.altitude_m, 0.5e-6 + 1e-9, at + " 129029 alt");
    EXPECT_EQ(gnss["GnssType"].number(), 6) << at;
    EXPECT_EQ(gnss["Method"].number(), lost ? 0 : 6) << at;
    EXPECT_EQ(gnss["Integrity"].number(), in.quality.state == TrackingState::kRecovering ? 2 : 0) << at;
    EXPECT_TRUE(gnss["NumberOfSvs"].is_null()) << at;
    EXPECT_TRUE(gnss["Hdop"].is_null()) << at;
    const bool no_geoid = std::isnan(in.geoidal_separation_m);
    expect_near_or_null(gnss["GeoidalSeparation"], lost || no_geoid, in.geoidal_separation_m, 0.005 + 1e-9,
                        at + " 129029 separation");
    EXPECT_EQ(gnss["ReferenceStations"].number(), 0) << at;

    const Json& vp = msgs[7 * k + 4]["signals"];
    expect_near_or_null(vp["Latitude"], lost, in.latitude_deg, 0.5e-7 + 1e-9, at + " VP lat");
    expect_near_or_null(vp["Longitude"], lost, in.longitude_deg, 0.5e-7 + 1e-9, at + " VP lon");

    const Json& vds = msgs[7 * k + 5]["signals"];
    expect_near_or_null(vds["CompassBearing"], lost, wrap_two_pi(in.heading_rad) * 180 / kPi,
                        0.5 / 128 + 1e-9, at + " bearing");
    expect_near_or_null(vds["NavigationBasedVehicleSpeed"], lost, in.speed_over_ground_mps * 3.6,
                        0.5 / 256 + 1e-9, at + " speed");
    expect_near_or_null(vds["Pitch"], lost, in.pitch_rad * 180 / kPi, 0.5 / 128 + 1e-9, at + " pitch");
    // SPN 580 is above mean sea level.
    expect_near_or_null(vds["Altitude"], lost || no_geoid, in.altitude_m - in.geoidal_separation_m,
                        0.0625 + 1e-9, at + " altitude");

    const Json& pq = msgs[7 * k + 6];
    EXPECT_TRUE(pq["e2e"]["crc_ok"].boolean()) << at;
    EXPECT_EQ(pq["e2e"]["counter"].number(), k % 16) << at;
    const int state_code = lost ? 2 : (in.quality.state == TrackingState::kRecovering ? 1 : 0);
    EXPECT_EQ(pq["signals"]["TrackingState"].number(), state_code) << at;
    EXPECT_EQ(pq["signals"]["FeaturesUsed"].number(), in.quality.features_used) << at;
    EXPECT_NEAR(pq["signals"]["PositionStd"].number(), in.quality.position_std_m, 0.0005 + 1e-9) << at;
    EXPECT_NEAR(pq["signals"]["RotationStd"].number(), in.quality.rotation_std_rad * 180 / kPi, 0.05 + 1e-9)
        << at;
    EXPECT_NEAR(pq["signals"]["MaskedAreaRatio"].number(), in.quality.masked_area_ratio * 100, 0.2 + 1e-9)
        << at;
  }
}

// The decoder's own checks are live: a flipped bit fails the CRC and a lost
// fast-packet frame is reported.
TEST_F(CanDecodeTest, CorruptionAndMissingFramesAreDetected) {
  const std::string log = write_log();
  auto records = read_candump_file(log);
  ASSERT_TRUE(records.has_value());
  const std::string bad_log = (dir_ / "bad.log").string();
  {
    std::ofstream out(bad_log);
    int pq_seen = 0;
    bool skipped_fast_packet = false;
    for (auto r : *records) {
      const std::uint32_t pgn = split_j1939_id(r.frame.id).pgn;
      if (pgn == 0xFF10 && pq_seen++ == 2) r.frame.data[4] ^= 0x01;  // third pose/quality frame
      if (pgn == 129029 && !skipped_fast_packet && (r.frame.data[0] & 0x1F) == 3) {
        skipped_fast_packet = true;  // drop frame 3 of the first 129029
        continue;
      }
      out << *format_candump_line(r) << "\n";
    }
  }
  Json out;
  EXPECT_EQ(decode(bad_log, out), 1);
  ASSERT_FALSE(out["errors"].array().empty());
  EXPECT_NE(out["errors"].array()[0].string().find("fast packet"), std::string::npos);
  int crc_failures = 0;
  int gnss = 0;
  for (const Json& m : out["messages"].array()) {
    if (m["name"].string() == "SiteposePoseQuality" && !m["e2e"]["crc_ok"].boolean()) ++crc_failures;
    if (m["name"].string() == "N2kGnssPositionData") ++gnss;
  }
  EXPECT_EQ(crc_failures, 1);
  EXPECT_EQ(gnss, kPoses - 1);
}

}  // namespace
}  // namespace sitepose::output
