#pragma once
// SAE J1939 frames of the sitepose CAN output: pure functions from values to
// one 8-byte frame each (config/can/sitepose.dbc describes every signal).
//
// Conventions (J1939-71): little-endian fields; a NaN input is sent as "not
// available" (all bits 1); finite values are rounded to the resolution and
// clamped to the valid range (raw 0 .. 0xFA.. per field size), never wrapped.
// Angles in the inputs are radians; the frames carry degrees where J1939 does.

#include <cstdint>

#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/output/can_frame.hpp"

namespace sitepose::output {

inline constexpr std::uint32_t kPgnVehiclePosition = 65267;        // 0xFEF3, VP
inline constexpr std::uint32_t kPgnVehicleDirectionSpeed = 65256;  // 0xFEE8, VDS
// Proprietary B (PDU2, PF 0xFF): group extension chosen for sitepose.
inline constexpr std::uint32_t kPgnSiteposePoseQuality = 0xFF10;  // 65296
inline constexpr std::uint8_t kDefaultPriorityJ1939 = 6;          // J1939-71 default for VP/VDS

// PGN 65267 Vehicle Position: SPN 584 latitude, SPN 585 longitude, each u32
// 1e-7 deg/bit with offset -210 deg (valid -210 .. 211.1008 deg).
CanFrame encode_j1939_vehicle_position(double latitude_deg, double longitude_deg, std::uint8_t source_address,
                                       std::uint8_t priority = kDefaultPriorityJ1939);

// PGN 65256 Vehicle Direction/Speed. Inputs: heading clockwise from true
// north (wrapped into [0, 2 pi)), speed over ground (m/s, sent as km/h,
// negative clamps to 0), pitch (nose up positive), altitude (m).
// Fields: SPN 165 bearing u16 1/128 deg; SPN 517 speed u16 1/256 km/h;
// SPN 583 pitch u16 1/128 deg offset -200 deg; SPN 580 altitude u16 0.125 m
// offset -2500 m.
struct VehicleDirectionSpeed {
  double heading_rad = 0.0;
  double speed_mps = 0.0;
  double pitch_rad = 0.0;
  double altitude_m = 0.0;
};
CanFrame encode_j1939_vehicle_direction_speed(const VehicleDirectionSpeed& v, std::uint8_t source_address,
                                              std::uint8_t priority = kDefaultPriorityJ1939);

// The sitepose pose/quality frame (PGN 0xFF10), 8 bytes:
//   byte 0      CRC-8 SAE J1850 over [data id low, data id high, bytes 1..7]
//   byte 1      bits 0-3 alive counter (0..15), bits 4-5 tracking state
//               (0 OK, 1 RECOVERING, 2 LOST), bit 6 integrity alert (the
//               protection level exceeds the alert limit), bit 7 0
//   bytes 2-3   features used in the final pose, u16 1/bit (0..64255)
//   bytes 4-5   position std = sqrt(trace of the 3x3 position covariance),
//               u16 0.001 m/bit (0..64.255 m)
//   byte 6      rotation std = sqrt(trace of the rotation covariance),
//               u8 0.1 deg/bit (0..25 deg)
//   byte 7      masked-area ratio (Algorithm 1's mar), u8 0.4 %/bit (0..100 %)
// NaN / negative feature count -> "not available" / 0 as for the other frames.
// The ECU recomputes the CRC with the same data id and checks that the counter
// advanced by one (mod 16) since the previous frame.
inline constexpr std::uint16_t kPoseQualityDataId = 0xFF10;

struct PoseQuality {
  TrackingState state = TrackingState::kLost;
  int features_used = 0;
  double position_std_m = 0.0;
  double rotation_std_rad = 0.0;
  double masked_area_ratio = 0.0;  // [0, 1]
  bool integrity_alert = false;    // protection level over the alert limit (published_pose.hpp)
};

// The figures of a tracker's answer (covariance of the [translation;
// rotation] tangent, PoseEstimate contract).
PoseQuality pose_quality_from_estimate(const PoseEstimate& estimate);

CanFrame encode_sitepose_pose_quality(const PoseQuality& quality, std::uint8_t alive_counter,
                                      std::uint8_t source_address,
                                      std::uint8_t priority = kDefaultPriorityJ1939,
                                      std::uint16_t data_id = kPoseQualityDataId);

// Checks CRC of a received pose/quality frame (for tests and monitors).
bool check_sitepose_pose_quality_crc(const CanFrame& frame, std::uint16_t data_id = kPoseQualityDataId);

}  // namespace sitepose::output
