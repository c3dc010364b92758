#pragma once
// The frame set sent on CAN for one published pose: J1939 65267 / 65256,
// NMEA 2000 129025 / 129026 / 129029 (fast packet) / 127250 and the sitepose
// pose/quality frame with its E2E counter and CRC. Stateful only in the
// counters that link frames over time (NMEA SID, fast-packet sequence, E2E
// alive counter). One instance per CAN output; not thread-safe (the publish
// stage owns it). No I/O: the frames go to a CanSink.
//
// Tracking state policy: LOST -> position, heading, speed, pitch and altitude
// fields are sent as "not available" and 129029 method "no fix"; RECOVERING
// -> values are sent, 129029 integrity "caution"; OK -> integrity "no
// checking" (a visual fix is not GNSS-integrity-monitored), "caution" when
// the integrity alert is set (PoseQuality::integrity_alert). The pose/quality
// frame always carries the state, so the ECU can tell the three apart.

#include <cstdint>
#include <limits>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/output/can_frame.hpp"
#include "sitepose/output/e2e.hpp"
#include "sitepose/output/j1939.hpp"

namespace sitepose::output {

// Which frames are sent and from which address. Priorities are those of the
// standards (J1939-71: 6; NMEA 2000: 2, 3 for 129029).
struct CanOutputOptions {
  std::uint8_t source_address = 0x1C;  // 0..253 (254 = null, 255 = global)
  bool j1939_vehicle_position = true;
  bool j1939_vehicle_direction_speed = true;
  bool n2k_position_rapid_update = true;
  bool n2k_cog_sog_rapid_update = true;
  bool n2k_gnss_position_data = true;
  bool n2k_vessel_heading = true;
  bool sitepose_pose_quality = true;
};

// Fails naming the field ("can.source_address = 254: must be 0..253") or when
// no frame is enabled.
Status check_can_output_options(const CanOutputOptions& options);

// The PGNs the enabled frames use, in the order encode() sends them.
std::vector<std::uint32_t> transmitted_pgns(const CanOutputOptions& options);

// One pose in global terms, as the geo anchoring delivers it.
struct CanPoseInputs {
  std::int64_t utc_t_ns = 0;  // capture time, ns since the Unix epoch (UTC)
  double latitude_deg = 0.0;  // WGS84
  double longitude_deg = 0.0;
  double altitude_m = 0.0;  // above the WGS84 ellipsoid
  // Geoid height above the ellipsoid (geo::GeoidGrid): 129029's geoidal
  // separation, and J1939 SPN 580 gets the height above mean sea level
  // altitude_m - it. NaN (no geoid): both "not available".
  double geoidal_separation_m = std::numeric_limits<double>::quiet_NaN();
  double heading_rad = 0.0;  // of the machine, clockwise from true north
  double course_over_ground_rad = 0.0;
  double speed_over_ground_mps = 0.0;
  double pitch_rad = 0.0;  // nose up positive
  PoseQuality quality;
};

class CanPoseEncoder {
 public:
  // `options` must pass check_can_output_options (checked: programmer error).
  explicit CanPoseEncoder(const CanOutputOptions& options);

  // The frames of one pose in this order (disabled ones left out):
  // 129025, 129026, 127250, 129029 (7 fast-packet frames), 65267, 65256,
  // sitepose pose/quality. Advances SID (0..252), the 129029 fast-packet
  // sequence (0..7) and the E2E alive counter (0..15).
  std::vector<CanFrame> encode(const CanPoseInputs& in);

 private:
  CanOutputOptions options_;
  std::uint8_t sid_ = 0;
  std::uint8_t fast_packet_sequence_ = 0;
  E2eAliveCounter alive_counter_;
};

}  // namespace sitepose::output
