#include "sitepose/output/can_pose_encoder.hpp"

#include <gtest/gtest.h>

#include <numbers>

#include "sitepose/output/j1939.hpp"
#include "sitepose/output/nmea2000.hpp"

namespace sitepose::output {
namespace {

CanPoseInputs example_inputs() {
  CanPoseInputs in;
  in.utc_t_ns = 1'700'000'000'000'000'000LL;
  in.latitude_deg = 48.1234567;
  in.longitude_deg = 11.7654321;
  in.altitude_m = 512.25;
  in.heading_rad = std::numbers::pi / 2;
  in.course_over_ground_rad = std::numbers::pi / 2;
  in.speed_over_ground_mps = 1.5;
  in.pitch_rad = 0.0;
  in.quality.state = TrackingState::kOk;
  in.quality.features_used = 300;
  in.quality.position_std_m = 0.02;
  return in;
}

std::uint32_t pgn_of(const CanFrame& f) { return split_j1939_id(f.id).pgn; }

TEST(CanPoseEncoder, OptionsAreChecked) {
  CanOutputOptions o;
  EXPECT_TRUE(check_can_output_options(o).has_value());
  o.source_address = 254;
  const Status st = check_can_output_options(o);
  ASSERT_FALSE(st.has_value());
  EXPECT_NE(st.error().message.find("can.source_address = 254"), std::string::npos);
  CanOutputOptions none{0x1C, false, false, false, false, false, false, false};
  EXPECT_FALSE(check_can_output_options(none).has_value());
}

TEST(CanPoseEncoder, FrameSetOrderAndSourceAddress) {
  CanOutputOptions o;
  o.source_address = 0x2A;
  CanPoseEncoder enc(o);
  const auto frames = enc.encode(example_inputs());
  ASSERT_EQ(frames.size(), 13u);
  const std::uint32_t expected_pgns[] = {
      kPgnPositionRapidUpdate, kPgnCogSogRapidUpdate, kPgnVesselHeading,
      kPgnGnssPositionData,    kPgnGnssPositionData,  kPgnGnssPositionData,
      kPgnGnssPositionData,    kPgnGnssPositionData,  kPgnGnssPositionData,
      kPgnGnssPositionData,    kPgnVehiclePosition,   kPgnVehicleDirectionSpeed,
      kPgnSiteposePoseQuality};
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(pgn_of(frames[i]), expected_pgns[i]) << i;
    EXPECT_EQ(frames[i].id & 0xFF, 0x2Au) << i;
    EXPECT_EQ(frames[i].dlc, 8) << i;
  }
  // The same values as the pure encoders give.
  EXPECT_EQ(frames[0], encode_n2k_position_rapid_update(48.1234567, 11.7654321, 0x2A));
  EXPECT_EQ(frames[10], encode_j1939_vehicle_position(48.1234567, 11.7654321, 0x2A));
  EXPECT_TRUE(check_sitepose_pose_quality_crc(frames[12]));
}

TEST(CanPoseEncoder, CountersAdvanceAndWrap) {
  CanPoseEncoder enc(CanOutputOptions{});
  for (int k = 0; k < 300; ++k) {
    const auto frames = enc.encode(example_inputs());
    const std::uint8_t sid = static_cast<std::uint8_t>(k % 253);
    EXPECT_EQ(frames[1].data[0], sid) << k;                 // 129026 SID
    EXPECT_EQ(frames[2].data[0], sid) << k;                 // 127250 SID
    EXPECT_EQ(frames[3].data[2], sid) << k;                 // 129029 SID (after seq, length)
    EXPECT_EQ(frames[3].data[0] >> 5, k % 8) << k;          // fast-packet sequence
    EXPECT_EQ(frames[9].data[0], ((k % 8) << 5) | 6) << k;  // its last frame
    EXPECT_EQ(frames[12].data[1] & 0x0F, k % 16) << k;      // E2E alive counter
  }
}

TEST(CanPoseEncoder, LostSendsNotAvailableButKeepsQuality) {
  CanPoseEncoder enc(CanOutputOptions{});
  CanPoseInputs in = example_inputs();
  in.quality.state = TrackingState::kLost;
  const auto frames = enc.encode(in);
  const CanFrame na_n2k_pos = encode_n2k_position_rapid_update(std::nan(""), std::nan(""), 0x1C);
  EXPECT_EQ(frames[0], na_n2k_pos);
  EXPECT_EQ(frames[0].data[3], 0x7F);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(frames[10].data[i], 0xFF) << i;  // VP n/a
  for (int i = 0; i < 8; ++i) EXPECT_EQ(frames[11].data[i], 0xFF) << i;  // VDS n/a
  EXPECT_EQ(frames[2].data[1], 0xFF);                                    // heading n/a
  EXPECT_EQ(frames[2].data[2], 0xFF);
  // 129029: method "no fix" (0) in the high nibble of payload byte 31 =
  // frame 4, byte 5 (frame 0 carries 6 bytes, then 7 a frame from byte 1).
  EXPECT_EQ(frames[7].data[5] >> 4, 0);
  EXPECT_EQ(frames[12].data[1] >> 4, 2);  // state LOST
  EXPECT_TRUE(check_sitepose_pose_quality_crc(frames[12]));
}

TEST(CanPoseEncoder, RecoveringMarksIntegrityCaution) {
  CanPoseEncoder enc(CanOutputOptions{});
  CanPoseInputs in = example_inputs();
  in.quality.state = TrackingState::kRecovering;
  const auto frames = enc.encode(in);
  EXPECT_EQ(frames[7].data[5] >> 4, static_cast<int>(GnssMethod::kEstimated));
  EXPECT_EQ(frames[7].data[6] & 0x3, static_cast<int>(GnssIntegrity::kCaution));
  EXPECT_EQ(frames[12].data[1] >> 4, 1);
  EXPECT_EQ(frames[0], encode_n2k_position_rapid_update(48.1234567, 11.7654321, 0x1C));
}

TEST(CanPoseEncoder, DisabledFramesAreLeftOut) {
  CanOutputOptions o;
  o.n2k_gnss_position_data = false;
  o.j1939_vehicle_direction_speed = false;
  CanPoseEncoder enc(o);
  const auto frames = enc.encode(example_inputs());
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_EQ(pgn_of(frames[3]), kPgnVehiclePosition);
  EXPECT_EQ(pgn_of(frames[4]), kPgnSiteposePoseQuality);
}

}  // namespace
}  // namespace sitepose::output
