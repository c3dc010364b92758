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

#include "sitepose/io/json_file.hpp"
#include "sitepose/output/can_pose_encoder.hpp"
#include "sitepose/output/can_sink.hpp"
#include "sitepose/output/candump.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::output {
namespace {

using io::Json;

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
    auto parsed = io::read_json_file(json_path);
    EXPECT_TRUE(parsed.has_value()) << parsed.error().message << "\n"
                                    << sitepose::testing::read_text(json_path).substr(0, 500);
    if (parsed) out = std::move(*parsed);
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
  EXPECT_NEAR(v.get<double>(), expected, tol) << what;
}

TEST_F(CanDecodeTest, DecodedValuesMatchThePosesWithinResolution) {
  Json out;
  ASSERT_EQ(decode(write_log(), out), 0);
  ASSERT_TRUE(out.at("errors").empty());
  const auto& msgs = out.at("messages");
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
      ASSERT_EQ(msg.at("name").get<std::string>(), order[m]) << at;
      EXPECT_EQ(msg.at("source_address").get<double>(), 0x1C) << at;
      // The log keeps microseconds, truncated.
      EXPECT_NEAR(msg.at("t").get<double>(), (in.utc_t_ns / 1000) * 1e-6, 2e-6) << at;
    }
    const Json& rapid = msgs[7 * k].at("signals");
    expect_near_or_null(rapid.at("Latitude"), lost, in.latitude_deg, 0.5e-7 + 1e-12, at + " 129025 lat");
    expect_near_or_null(rapid.at("Longitude"), lost, in.longitude_deg, 0.5e-7 + 1e-12, at + " 129025 lon");

    const Json& cog = msgs[7 * k + 1].at("signals");
    EXPECT_EQ(cog.at("Sid").get<double>(), k % 253) << at;
    EXPECT_EQ(cog.at("CogReference").get<double>(), 0) << at;
    expect_near_or_null(cog.at("Cog"), lost, wrap_two_pi(in.course_over_ground_rad), 0.5e-4 + 1e-9,
                        at + " cog");
    expect_near_or_null(cog.at("Sog"), lost, in.speed_over_ground_mps, 0.005 + 1e-9, at + " sog");

    const Json& hdg = msgs[7 * k + 2].at("signals");
    EXPECT_EQ(hdg.at("Sid").get<double>(), k % 253) << at;
    expect_near_or_null(hdg.at("Heading"), lost, wrap_two_pi(in.heading_rad), 0.5e-4 + 1e-9, at + " heading");
    EXPECT_TRUE(hdg.at("Deviation").is_null()) << at;
    EXPECT_TRUE(hdg.at("Variation").is_null()) << at;
    EXPECT_EQ(hdg.at("Reference").get<double>(), 0) << at;

    const Json& gnss = msgs[7 * k + 3].at("signals");
    EXPECT_EQ(gnss.at("Sid").get<double>(), k % 253) << at;
    const double t_s = gnss.at("Date").get<double>() * 86400.0 + gnss.at("Time").get<double>();
    EXPECT_NEAR(t_s, in.utc_t_ns * 1e-9, 1e-4 + 1e-6) << at;
    expect_near_or_null(gnss.at("Latitude"), lost, in.latitude_deg, 1e-12, at + " 129029 lat");
    expect_near_or_null(gnss.at("Longitude"), lost, in.longitude_deg, 1e-12, at + " 129029 lon");
    expect_near_or_null(gnss.at("Altitude"), lost, in.altitude_m, 0.5e-6 + 1e-9, at + " 129029 alt");
    EXPECT_EQ(gnss.at("GnssType").get<double>(), 6) << at;
    EXPECT_EQ(gnss.at("Method").get<double>(), lost ? 0 : 6) << at;
    EXPECT_EQ(gnss.at("Integrity").get<double>(), in.quality.state == TrackingState::kRecovering ? 2 : 0)
        << at;
    EXPECT_TRUE(gnss.at("NumberOfSvs").is_null()) << at;
    EXPECT_TRUE(gnss.at("Hdop").is_null()) << at;
    const bool no_geoid = std::isnan(in.geoidal_separation_m);
    expect_near_or_null(gnss.at("GeoidalSeparation"), lost || no_geoid, in.geoidal_separation_m, 0.005 + 1e-9,
                        at + " 129029 separation");
    EXPECT_EQ(gnss.at("ReferenceStations").get<double>(), 0) << at;

    const Json& vp = msgs[7 * k + 4].at("signals");
    expect_near_or_null(vp.at("Latitude"), lost, in.latitude_deg, 0.5e-7 + 1e-9, at + " VP lat");
    expect_near_or_null(vp.at("Longitude"), lost, in.longitude_deg, 0.5e-7 + 1e-9, at + " VP lon");

    const Json& vds = msgs[7 * k + 5].at("signals");
    expect_near_or_null(vds.at("CompassBearing"), lost, wrap_two_pi(in.heading_rad) * 180 / kPi,
                        0.5 / 128 + 1e-9, at + " bearing");
    expect_near_or_null(vds.at("NavigationBasedVehicleSpeed"), lost, in.speed_over_ground_mps * 3.6,
                        0.5 / 256 + 1e-9, at + " speed");
    expect_near_or_null(vds.at("Pitch"), lost, in.pitch_rad * 180 / kPi, 0.5 / 128 + 1e-9, at + " pitch");
    // SPN 580 is above mean sea level.
    expect_near_or_null(vds.at("Altitude"), lost || no_geoid, in.altitude_m - in.geoidal_separation_m,
                        0.0625 + 1e-9, at + " altitude");

    const Json& pq = msgs[7 * k + 6];
    EXPECT_TRUE(pq.at("e2e").at("crc_ok").get<bool>()) << at;
    EXPECT_EQ(pq.at("e2e").at("counter").get<double>(), k % 16) << at;
    const int state_code = lost ? 2 : (in.quality.state == TrackingState::kRecovering ? 1 : 0);
    EXPECT_EQ(pq.at("signals").at("TrackingState").get<double>(), state_code) << at;
    EXPECT_EQ(pq.at("signals").at("FeaturesUsed").get<double>(), in.quality.features_used) << at;
    EXPECT_NEAR(pq.at("signals").at("PositionStd").get<double>(), in.quality.position_std_m, 0.0005 + 1e-9)
        << at;
    EXPECT_NEAR(pq.at("signals").at("RotationStd").get<double>(), in.quality.rotation_std_rad * 180 / kPi,
                0.05 + 1e-9)
        << at;
    EXPECT_NEAR(pq.at("signals").at("MaskedAreaRatio").get<double>(), in.quality.masked_area_ratio * 100,
                0.2 + 1e-9)
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
  ASSERT_FALSE(out.at("errors").empty());
  EXPECT_NE(out.at("errors").at(0).get<std::string>().find("fast packet"), std::string::npos);
  int crc_failures = 0;
  int gnss = 0;
  for (const Json& m : out.at("messages")) {
    if (m.at("name").get<std::string>() == "SiteposePoseQuality" && !m.at("e2e").at("crc_ok").get<bool>())
      ++crc_failures;
    if (m.at("name").get<std::string>() == "N2kGnssPositionData") ++gnss;
  }
  EXPECT_EQ(crc_failures, 1);
  EXPECT_EQ(gnss, kPoses - 1);
}

}  // namespace
}  // namespace sitepose::output
