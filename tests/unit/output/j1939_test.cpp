#include "sitepose/output/j1939.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "sitepose/output/e2e.hpp"
#include "test_util.hpp"

namespace sitepose::output {
namespace {

using testing::expect_data;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = std::numbers::pi;

TEST(J1939VehiclePosition, HandComputedBytes) {
  // lat 52.5: (52.5 + 210) * 1e7 = 2625000000 = 0x9C765240;
  // lon 13.4: 2234000000 = 0x85282280.
  const CanFrame f = encode_j1939_vehicle_position(52.5, 13.4, 0x1C);
  EXPECT_EQ(f.id, 0x18FEF31Cu);
  EXPECT_TRUE(f.extended);
  expect_data(f, {0x40, 0x52, 0x76, 0x9C, 0x80, 0x22, 0x28, 0x85});
  // Southern / western: (-33.8568 + 210) * 1e7 = 1761432000 = 0x68FD51C0;
  // (-70.5 + 210) * 1e7 = 1395000000 = 0x532602C0.
  expect_data(encode_j1939_vehicle_position(-33.8568, -70.5, 0x1C),
              {0xC0, 0x51, 0xFD, 0x68, 0xC0, 0x02, 0x26, 0x53});
}

TEST(J1939VehiclePosition, NotAvailableAndClamping) {
  expect_data(encode_j1939_vehicle_position(kNan, kNan, 0x1C),
              {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF});
  // Below the offset clamps to 0; above the range to 0xFAFFFFFF.
  expect_data(encode_j1939_vehicle_position(-300.0, 500.0, 0x1C),
              {0x00, 0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFA});
  EXPECT_EQ(encode_j1939_vehicle_position(0.0, 0.0, 0x1C, 3).id, 0x0CFEF31Cu);
}

TEST(J1939VehicleDirectionSpeed, HandComputedBytes) {
  // bearing 90 deg * 128 = 11520 = 0x2D00; 10 m/s = 36 km/h * 256 = 9216 =
  // 0x2400; pitch 0: (0 + 200) * 128 = 25600 = 0x6400; altitude 100 m:
  // (100 + 2500) * 8 = 20800 = 0x5140.
  const CanFrame f = encode_j1939_vehicle_direction_speed({kPi / 2, 10.0, 0.0, 100.0}, 0x1C);
  EXPECT_EQ(f.id, 0x18FEE81Cu);
  expect_data(f, {0x00, 0x2D, 0x00, 0x24, 0x00, 0x64, 0x40, 0x51});
  // Heading -90 deg wraps to 270 deg = 34560 = 0x8700; pitch -5 deg:
  // 195 * 128 = 24960 = 0x6180; altitude -2500 m -> 0.
  expect_data(
      encode_j1939_vehicle_direction_speed({-kPi / 2, 0.0, -5.0 * kPi / 180, -2500.0}, 0x1C),
      {0x00, 0x87, 0x00, 0x00, 0x80, 0x61, 0x00, 0x00});
}

TEST(J1939VehicleDirectionSpeed, NotAvailableAndClamping) {
  expect_data(encode_j1939_vehicle_direction_speed({kNan, kNan, kNan, kNan}, 0x1C),
              {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF});
  // 300 m/s = 1080 km/h > 250.996 -> 0xFAFF; reversing (negative) -> 0;
  // altitude 9000 m > 5531.875 -> 0xFAFF; pitch -250 deg < -200 -> 0.
  expect_data(encode_j1939_vehicle_direction_speed({0.0, 300.0, -250.0 * kPi / 180, 9000.0}, 0x1C),
              {0x00, 0x00, 0xFF, 0xFA, 0x00, 0x00, 0xFF, 0xFA});
  expect_data(encode_j1939_vehicle_direction_speed({0.0, -3.0, 0.0, 0.0}, 0x1C),
              {0x00, 0x00, 0x00, 0x00, 0x00, 0x64, 0x20, 0x4E});
}

TEST(SiteposePoseQuality, HandComputedBytesAndCrc) {
  // state OK (0) | counter 3 -> 0x03; 350 features = 0x015E; 0.0123 m ->
  // 12 mm = 0x000C; 0.5 deg -> 5; mar 0.3 -> 75 = 0x4B. CRC-8 J1850 over
  // [0x10, 0xFF, 03 5E 01 0C 00 05 4B] = 0x51 (computed independently).
  PoseQuality q;
  q.state = TrackingState::kOk;
  q.features_used = 350;
  q.position_std_m = 0.0123;
  q.rotation_std_rad = 0.5 * kPi / 180;
  q.masked_area_ratio = 0.3;
  const CanFrame f = encode_sitepose_pose_quality(q, 3, 0x1C);
  EXPECT_EQ(f.id, 0x18FF101Cu);
  expect_data(f, {0x51, 0x03, 0x5E, 0x01, 0x0C, 0x00, 0x05, 0x4B});
  EXPECT_TRUE(check_sitepose_pose_quality_crc(f));
}

TEST(SiteposePoseQuality, StateNibbleCounterWrapAndNotAvailable) {
  PoseQuality q;
  q.state = TrackingState::kLost;
  q.features_used = -1;  // clamps to 0
  q.position_std_m = kNan;
  q.rotation_std_rad = kNan;
  q.masked_area_ratio = kNan;
  const CanFrame f = encode_sitepose_pose_quality(q, 0x1F /* only 4 bits used */, 0x1C);
  EXPECT_EQ(f.data[1], 0x2F);
  EXPECT_EQ(f.data[2], 0x00);
  EXPECT_EQ(f.data[3], 0x00);
  EXPECT_EQ(f.data[4], 0xFF);
  EXPECT_EQ(f.data[5], 0xFF);
  EXPECT_EQ(f.data[6], 0xFF);
  EXPECT_EQ(f.data[7], 0xFF);
  EXPECT_TRUE(check_sitepose_pose_quality_crc(f));
  q.state = TrackingState::kRecovering;
  q.features_used = 100000;   // clamps to 0xFAFF
  q.position_std_m = 100.0;   // clamps to 0xFAFF (64.255 m)
  q.rotation_std_rad = 1.0;   // 57 deg clamps to 250 (25.0 deg)
  q.masked_area_ratio = 1.5;  // clamps to 250 (100 %)
  const CanFrame g = encode_sitepose_pose_quality(q, 9, 0x1C);
  EXPECT_EQ(g.data[1], 0x19);
  EXPECT_EQ(g.data[2], 0xFF);
  EXPECT_EQ(g.data[3], 0xFA);
  EXPECT_EQ(g.data[4], 0xFF);
  EXPECT_EQ(g.data[5], 0xFA);
  EXPECT_EQ(g.data[6], 0xFA);
  EXPECT_EQ(g.data[7], 0xFA);
}

TEST(SiteposePoseQuality, CrcCatchesCorruptionAndWrongDataId) {
  PoseQuality q;
  q.state = TrackingState::kOk;
  q.features_used = 123;
  const CanFrame f = encode_sitepose_pose_quality(q, 7, 0x1C);
  ASSERT_TRUE(check_sitepose_pose_quality_crc(f));
  EXPECT_FALSE(check_sitepose_pose_quality_crc(f, 0x1234));
  for (int byte = 0; byte < 8; ++byte) {
    CanFrame bad = f;
    bad.data[byte] ^= 0x10;
    EXPECT_FALSE(check_sitepose_pose_quality_crc(bad)) << byte;
  }
}

TEST(SiteposePoseQuality, FromEstimateUsesCovarianceTraces) {
  PoseEstimate e;
  e.state = TrackingState::kRecovering;
  e.counters.features_used = 42;
  e.counters.masked_area_ratio = 0.25;
  e.covariance = Matrix6d::Zero();
  e.covariance.diagonal() << 1e-4, 1e-4, 2e-4, 1e-6, 2e-6, 1e-6;
  const PoseQuality q = pose_quality_from_estimate(e);
  EXPECT_EQ(q.state, TrackingState::kRecovering);
  EXPECT_EQ(q.features_used, 42);
  EXPECT_NEAR(q.position_std_m, 0.02, 1e-12);
  EXPECT_NEAR(q.rotation_std_rad, 0.002, 1e-12);
  EXPECT_DOUBLE_EQ(q.masked_area_ratio, 0.25);
}

}  // namespace
}  // namespace sitepose::output
