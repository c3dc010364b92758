// Frames written by the SocketCAN sink through the fd seam, logged as
// candump lines on the receiving side and decoded with the DBC by the
// independent decoder (tools/can_decode.py), decode to the values sent -
// including an altitude at the 129029 field's limit, inside the DBC range.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "can_test_support.hpp"
#include "sitepose/drivers/socketcan/socketcan_sink.hpp"
#include "sitepose/io/json_file.hpp"
#include "sitepose/output/can_pose_encoder.hpp"
#include "sitepose/output/can_sink.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::drivers::socketcan {
namespace {

using io::Json;

constexpr char kPython[] = "/usr/bin/python3";
constexpr int kPoses = 12;

output::CanPoseInputs pose(int k) {
  output::CanPoseInputs in;
  in.utc_t_ns = 1'700'000'000'000'000'000LL + k * 100'000'000LL;
  in.latitude_deg = 48.1 + k * 1.1e-5;
  in.longitude_deg = -11.5 - k * 2.3e-5;
  // The last pose: an altitude the 129029 field clamps to its largest valid value.
  in.altitude_m = k == kPoses - 1 ? 1e13 : 500.0 + k * 0.37;
  in.heading_rad = 0.2 * k;
  in.course_over_ground_rad = 0.1;
  in.speed_over_ground_mps = 2.0;
  in.quality.state = TrackingState::kOk;
  in.quality.features_used = 200 + k;
  return in;
}

TEST(SocketCanDbc, FramesFromTheSinkDecodeToTheValuesSent) {
  if (::access(kPython, X_OK) != 0) GTEST_SKIP() << kPython << " is missing";
  if (std::system("/usr/bin/python3 -c 'import can' 2>/dev/null") != 0) {
    GTEST_SKIP() << "python3-can is missing for /usr/bin/python3";
  }
  const sitepose::testing::TempDir dir;
  const std::string log = dir / "bus.log";

  testing::SocketPair pair;
  testing::FrameCollector bus(pair.bus());
  SocketCanSinkOptions o;
  o.interface = "test0";
  o.node.preferred_address = 0x2A;
  o.node.claim_settle_ns = 10'000'000;
  o.node.heartbeat_interval_ns = 0;
  auto sink = SocketCanSink::open(o, fd_socket_ops(pair.sink()));
  ASSERT_TRUE(sink.has_value()) << sink.error().message;
  ASSERT_TRUE(testing::wait_until([&] { return (*sink)->stats().state == CanLinkState::kUp; }));
  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  for (int k = 0; k < kPoses; ++k) {
    for (const auto& f : encoder.encode(pose(k))) ASSERT_TRUE((*sink)->send(0, f).has_value());
    // Refused while the queue is full: flush again, as the pipeline retries.
    ASSERT_TRUE(testing::wait_until([&] { return (*sink)->flush().has_value(); }));
  }
  (*sink)->close();
  ASSERT_EQ((*sink)->stats().poses_sent, static_cast<std::uint64_t>(kPoses));
  ASSERT_TRUE(testing::wait_until([&] {
    return bus.count([](const output::CanFrame&) { return true; }) >= static_cast<std::size_t>(13 * kPoses);
  }));

  // The receiving side: every pose frame into a candump log (network
  // management frames are not in the DBC).
  {
    auto logger = output::CandumpSink::open_file(log, "can0");
    ASSERT_TRUE(logger.has_value());
    std::int64_t t_ns = 1'700'000'000'000'000'000LL;
    for (const output::CanFrame& f : bus.frames()) {
      if (output::split_j1939_id(f.id).pgn == output::kPgnAddressClaimed) continue;
      ASSERT_TRUE((*logger)->send(t_ns += 1000, f).has_value());
    }
    ASSERT_TRUE((*logger)->flush().has_value());
  }
  const std::string json_path = dir / "decoded.json";
  const std::string cmd = std::string(kPython) + " " SITEPOSE_SOURCE_DIR "/tools/can_decode.py --dbc " +
                          SITEPOSE_SOURCE_DIR "/config/can/sitepose.dbc " + log + " > " + json_path;
  const int rc = std::system(cmd.c_str());
  auto out = io::read_json_file(json_path);
  ASSERT_TRUE(out.has_value()) << out.error().message;
  EXPECT_TRUE(out->at("errors").empty()) << sitepose::testing::read_text(json_path).substr(0, 2000);
  EXPECT_EQ(WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, 0);
  const auto& msgs = out->at("messages");
  ASSERT_EQ(msgs.size(), static_cast<std::size_t>(7 * kPoses));
  for (int k = 0; k < kPoses; ++k) {
    const output::CanPoseInputs p = pose(k);
    const std::string at = "pose " + std::to_string(k);
    for (int m = 0; m < 7; ++m) EXPECT_EQ(msgs[7 * k + m].at("source_address").get<double>(), 0x2A) << at;
    const Json& rapid = msgs[7 * k].at("signals");
    EXPECT_NEAR(rapid.at("Latitude").get<double>(), p.latitude_deg, 0.5e-7 + 1e-12) << at;
    EXPECT_NEAR(rapid.at("Longitude").get<double>(), p.longitude_deg, 0.5e-7 + 1e-12) << at;
    const Json& gnss = msgs[7 * k + 3];
    ASSERT_EQ(gnss.at("name").get<std::string>(), "N2kGnssPositionData") << at;
    const double alt = gnss.at("signals").at("Altitude").get<double>();
    if (k == kPoses - 1) {
      EXPECT_NEAR(alt, 9223372036854.775804, 0.01) << at;  // clamped, inside the DBC range
    } else {
      EXPECT_NEAR(alt, p.altitude_m, 0.5e-6 + 1e-9) << at;
    }
    const Json& vp = msgs[7 * k + 4].at("signals");
    EXPECT_NEAR(vp.at("Latitude").get<double>(), p.latitude_deg, 0.5e-7 + 1e-9) << at;
    EXPECT_NEAR(vp.at("Longitude").get<double>(), p.longitude_deg, 0.5e-7 + 1e-9) << at;
    EXPECT_TRUE(msgs[7 * k + 6].at("e2e").at("crc_ok").get<bool>()) << at;
    EXPECT_EQ(msgs[7 * k + 6].at("signals").at("FeaturesUsed").get<double>(), p.quality.features_used) << at;
  }
}

}  // namespace
}  // namespace sitepose::drivers::socketcan
