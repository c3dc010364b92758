#include "sitepose/output/j1939.hpp"

#include <array>
#include <cmath>

#include "detail/field_codec.hpp"
#include "detail/frame_id.hpp"
#include "sitepose/output/e2e.hpp"

namespace sitepose::output {

using detail::put_le;
using detail::to_raw;

CanFrame encode_j1939_vehicle_position(double latitude_deg, double longitude_deg, std::uint8_t source_address,
                                       std::uint8_t priority) {
  CanFrame f = detail::full_frame(detail::pdu2_id(kPgnVehiclePosition, priority, source_address));
  constexpr auto kLatLon = detail::j1939_u32(1e7, -210.0);
  put_le(f.data, 0, to_raw(latitude_deg, kLatLon), 4);
  put_le(f.data, 4, to_raw(longitude_deg, kLatLon), 4);
  return f;
}

CanFrame encode_j1939_vehicle_direction_speed(const VehicleDirectionSpeed& v, std::uint8_t source_address,
                                              std::uint8_t priority) {
  CanFrame f = detail::full_frame(detail::pdu2_id(kPgnVehicleDirectionSpeed, priority, source_address));
  const double bearing_deg = detail::wrap_two_pi(v.heading_rad) * detail::kRadToDeg;
  put_le(f.data, 0, to_raw(bearing_deg, detail::j1939_u16(128.0, 0.0)), 2);
  const double speed_kmh = v.speed_mps * 3.6;
  put_le(f.data, 2, to_raw(speed_kmh, detail::j1939_u16(256.0, 0.0)), 2);
  put_le(f.data, 4, to_raw(v.pitch_rad * detail::kRadToDeg, detail::j1939_u16(128.0, -200.0)), 2);
  put_le(f.data, 6, to_raw(v.altitude_m, detail::j1939_u16(8.0, -2500.0)), 2);
  return f;
}

PoseQuality pose_quality_from_estimate(const PoseEstimate& estimate) {
  PoseQuality q;
  q.state = estimate.state;
  q.features_used = estimate.counters.features_used;
  q.position_std_m = std::sqrt(std::max(0.0, estimate.covariance.topLeftCorner<3, 3>().trace()));
  q.rotation_std_rad = std::sqrt(std::max(0.0, estimate.covariance.bottomRightCorner<3, 3>().trace()));
  q.masked_area_ratio = estimate.counters.masked_area_ratio;
  return q;
}

namespace {

std::uint8_t state_code(TrackingState state) {
  switch (state) {
    case TrackingState::kOk: return 0;
    case TrackingState::kRecovering: return 1;
    case TrackingState::kLost: return 2;
  }
  return 0xF;
}

std::uint8_t pose_quality_crc(const CanFrame& f, std::uint16_t data_id) {
  const std::array<std::uint8_t, 2> id_bytes{static_cast<std::uint8_t>(data_id & 0xFF),
                                             static_cast<std::uint8_t>(data_id >> 8)};
  std::uint8_t crc = crc8_sae_j1850_update(kCrc8J1850Init, id_bytes);
  crc = crc8_sae_j1850_update(crc, std::span<const std::uint8_t>(f.data).subspan(1, 7));
  return crc ^ kCrc8J1850XorOut;
}

}  // namespace

CanFrame encode_sitepose_pose_quality(const PoseQuality& quality, std::uint8_t alive_counter,
                                      std::uint8_t source_address, std::uint8_t priority,
                                      std::uint16_t data_id) {
  CanFrame f = detail::full_frame(detail::pdu2_id(kPgnSiteposePoseQuality, priority, source_address));
  f.data[1] = static_cast<std::uint8_t>((alive_counter & 0x0F) | ((state_code(quality.state) & 0x3) << 4) |
                                        (quality.integrity_alert ? 0x40 : 0x00));
  put_le(f.data, 2, to_raw(static_cast<double>(quality.features_used), detail::j1939_u16(1.0, 0.0)), 2);
  put_le(f.data, 4, to_raw(quality.position_std_m, detail::j1939_u16(1000.0, 0.0)), 2);
  put_le(f.data, 6, to_raw(quality.rotation_std_rad * detail::kRadToDeg, detail::j1939_u8(10.0, 0.0)), 1);
  put_le(f.data, 7, to_raw(quality.masked_area_ratio, detail::j1939_u8(250.0, 0.0)), 1);
  f.data[0] = pose_quality_crc(f, data_id);
  return f;
}

bool check_sitepose_pose_quality_crc(const CanFrame& frame, std::uint16_t data_id) {
  return frame.dlc == 8 && frame.data[0] == pose_quality_crc(frame, data_id);
}

}  // namespace sitepose::output
