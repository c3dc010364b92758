#include "sitepose/output/can_pose_encoder.hpp"

#include <limits>
#include <string>
#include <utility>

#include "sitepose/output/nmea2000.hpp"

namespace sitepose::output {

namespace {
constexpr std::uint8_t kMaxSid = 252;  // 253..255 are reserved / not available
constexpr std::uint8_t kMaxSourceAddress = 253;
}  // namespace

Status check_can_output_options(const CanOutputOptions& o) {
  if (o.source_address > kMaxSourceAddress) {
    return make_error(ErrorCode::kInvalidArgument,
                      "can.source_address = " + std::to_string(o.source_address) +
                          ": must be 0..253 (254 is the null address, 255 global)");
  }
  if (!(o.j1939_vehicle_position || o.j1939_vehicle_direction_speed || o.n2k_position_rapid_update ||
        o.n2k_cog_sog_rapid_update || o.n2k_gnss_position_data || o.n2k_vessel_heading ||
        o.sitepose_pose_quality)) {
    return make_error(ErrorCode::kInvalidArgument, "can: every frame is disabled; enable at least one");
  }
  return ok_status();
}

std::vector<std::uint32_t> transmitted_pgns(const CanOutputOptions& o) {
  const std::pair<bool, std::uint32_t> frames[] = {
      {o.n2k_position_rapid_update, kPgnPositionRapidUpdate},
      {o.n2k_cog_sog_rapid_update, kPgnCogSogRapidUpdate},
      {o.n2k_vessel_heading, kPgnVesselHeading},
      {o.n2k_gnss_position_data, kPgnGnssPositionData},
      {o.j1939_vehicle_position, kPgnVehiclePosition},
      {o.j1939_vehicle_direction_speed, kPgnVehicleDirectionSpeed},
      {o.sitepose_pose_quality, kPgnSiteposePoseQuality},
  };
  std::vector<std::uint32_t> pgns;
  for (const auto& [enabled, pgn] : frames) {
    if (enabled) pgns.push_back(pgn);
  }
  return pgns;
}

CanPoseEncoder::CanPoseEncoder(const CanOutputOptions& options) : options_(options) {
  SITEPOSE_CHECK(check_can_output_options(options).has_value());
}

std::vector<CanFrame> CanPoseEncoder::encode(const CanPoseInputs& in) {
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  const TrackingState state = in.quality.state;
  const bool lost = state == TrackingState::kLost;
  const double lat = lost ? kNan : in.latitude_deg;
  const double lon = lost ? kNan : in.longitude_deg;
  const double alt = lost ? kNan : in.altitude_m;
  const double separation = lost ? kNan : in.geoidal_separation_m;
  const double heading = lost ? kNan : in.heading_rad;
  const std::uint8_t sa = options_.source_address;
  const std::uint8_t sid = sid_;
  sid_ = sid_ == kMaxSid ? 0 : static_cast<std::uint8_t>(sid_ + 1);

  std::vector<CanFrame> frames;
  frames.reserve(14);
  if (options_.n2k_position_rapid_update) {
    frames.push_back(encode_n2k_position_rapid_update(lat, lon, sa));
  }
  if (options_.n2k_cog_sog_rapid_update) {
    frames.push_back(encode_n2k_cog_sog_rapid_update(
        CogSog{sid, HeadingReference::kTrue, lost ? kNan : in.course_over_ground_rad,
               lost ? kNan : in.speed_over_ground_mps},
        sa));
  }
  if (options_.n2k_vessel_heading) {
    frames.push_back(
        encode_n2k_vessel_heading(VesselHeading{sid, heading, kNan, kNan, HeadingReference::kTrue}, sa));
  }
  if (options_.n2k_gnss_position_data) {
    GnssPositionData g;
    g.sid = sid;
    g.utc_t_ns = in.utc_t_ns;
    g.latitude_deg = lat;
    g.longitude_deg = lon;
    g.altitude_m = alt;
    g.geoidal_separation_m = separation;
    g.type = GnssType::kIntegrated;
    g.method = lost ? GnssMethod::kNoFix : GnssMethod::kEstimated;
    g.integrity = state == TrackingState::kRecovering || in.quality.integrity_alert
                      ? GnssIntegrity::kCaution
                      : GnssIntegrity::kNoChecking;
    const auto fp = encode_n2k_gnss_position_data(g, fast_packet_sequence_, sa);
    fast_packet_sequence_ = static_cast<std::uint8_t>((fast_packet_sequence_ + 1) & 0x7);
    frames.insert(frames.end(), fp.begin(), fp.end());
  }
  if (options_.j1939_vehicle_position) {
    frames.push_back(encode_j1939_vehicle_position(lat, lon, sa));
  }
  if (options_.j1939_vehicle_direction_speed) {
    frames.push_back(encode_j1939_vehicle_direction_speed(
        VehicleDirectionSpeed{heading, lost ? kNan : in.speed_over_ground_mps, lost ? kNan : in.pitch_rad,
                              alt - separation},
        sa));
  }
  if (options_.sitepose_pose_quality) {
    frames.push_back(encode_sitepose_pose_quality(in.quality, alive_counter_.next(), sa));
  }
  return frames;
}

}  // namespace sitepose::output
