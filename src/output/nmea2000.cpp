#include "sitepose/output/nmea2000.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "detail/field_codec.hpp"
#include "detail/frame_id.hpp"

namespace sitepose::output {

using detail::put_le;
using detail::to_raw;

namespace {
constexpr std::int64_t kNsPerDay = 86'400'000'000'000LL;
constexpr std::int64_t kNsPerTimeBit = 100'000;  // 1e-4 s
}  // namespace

CanFrame encode_n2k_position_rapid_update(double latitude_deg, double longitude_deg,
                                          std::uint8_t source_address, std::uint8_t priority) {
  CanFrame f =
      detail::full_frame(detail::pdu2_id(kPgnPositionRapidUpdate, priority, source_address));
  put_le(f.data, 0, to_raw(latitude_deg, detail::n2k_i32(1e7)), 4);
  put_le(f.data, 4, to_raw(longitude_deg, detail::n2k_i32(1e7)), 4);
  return f;
}

CanFrame encode_n2k_vessel_heading(const VesselHeading& v, std::uint8_t source_address,
                                   std::uint8_t priority) {
  CanFrame f = detail::full_frame(detail::pdu2_id(kPgnVesselHeading, priority, source_address));
  f.data[0] = v.sid;
  put_le(f.data, 1, to_raw(detail::wrap_two_pi(v.heading_rad), detail::n2k_u16(1e4)), 2);
  put_le(f.data, 3, to_raw(v.deviation_rad, detail::n2k_i16(1e4)), 2);
  put_le(f.data, 5, to_raw(v.variation_rad, detail::n2k_i16(1e4)), 2);
  f.data[7] = static_cast<std::uint8_t>(0xFC | (static_cast<std::uint8_t>(v.reference) & 0x3));
  return f;
}

CanFrame encode_n2k_cog_sog_rapid_update(const CogSog& v, std::uint8_t source_address,
                                         std::uint8_t priority) {
  CanFrame f = detail::full_frame(detail::pdu2_id(kPgnCogSogRapidUpdate, priority, source_address));
  f.data[0] = v.sid;
  f.data[1] = static_cast<std::uint8_t>(0xFC | (static_cast<std::uint8_t>(v.reference) & 0x3));
  put_le(f.data, 2, to_raw(detail::wrap_two_pi(v.cog_rad), detail::n2k_u16(1e4)), 2);
  put_le(f.data, 4, to_raw(v.sog_mps, detail::n2k_u16(100.0)), 2);
  f.data[6] = 0xFF;
  f.data[7] = 0xFF;
  return f;
}

std::vector<std::uint8_t> encode_n2k_gnss_position_payload(const GnssPositionData& v) {
  std::vector<std::uint8_t> p(kGnssPositionDataBytes, 0xFF);
  p[0] = v.sid;
  if (v.utc_t_ns >= 0) {
    const std::int64_t days = v.utc_t_ns / kNsPerDay;
    const std::int64_t time_bits = (v.utc_t_ns % kNsPerDay) / kNsPerTimeBit;
    put_le(p, 1, days > 0xFFFC ? 0xFFFC : days, 2);
    put_le(p, 3, time_bits, 4);
  }  // else: date and time stay 0xFF.. (not available)
  put_le(p, 7, to_raw(v.latitude_deg, detail::n2k_i64(1e16)), 8);
  put_le(p, 15, to_raw(v.longitude_deg, detail::n2k_i64(1e16)), 8);
  put_le(p, 23, to_raw(v.altitude_m, detail::n2k_i64(1e6)), 8);
  p[31] = static_cast<std::uint8_t>((static_cast<std::uint8_t>(v.type) & 0x0F) |
                                    ((static_cast<std::uint8_t>(v.method) & 0x0F) << 4));
  p[32] = static_cast<std::uint8_t>(0xFC | (static_cast<std::uint8_t>(v.integrity) & 0x3));
  p[33] = v.satellites < 0 ? 0xFF
                           : static_cast<std::uint8_t>(v.satellites > 0xFC ? 0xFC : v.satellites);
  put_le(p, 34, to_raw(v.hdop, detail::n2k_i16(100.0)), 2);
  put_le(p, 36, to_raw(v.pdop, detail::n2k_i16(100.0)), 2);
  put_le(p, 38, to_raw(v.geoidal_separation_m, detail::n2k_i32(100.0)), 4);
  p[42] = 0;  // no reference stations follow
  return p;
}

std::vector<CanFrame> encode_n2k_gnss_position_data(const GnssPositionData& v,
                                                    std::uint8_t sequence_counter,
                                                    std::uint8_t source_address,
                                                    std::uint8_t priority) {
  const std::vector<std::uint8_t> payload = encode_n2k_gnss_position_payload(v);
  auto frames = fast_packet_frames(detail::pdu2_id(kPgnGnssPositionData, priority, source_address),
                                   payload, sequence_counter & 0x7);
  SITEPOSE_CHECK(frames.has_value());  // 43 bytes and a 3-bit counter always fit
  return std::move(frames).value();
}

CanFrame encode_n2k_heartbeat(std::int64_t interval_ns, std::uint8_t sequence_counter,
                              N2kControllerState controller, N2kEquipmentStatus equipment,
                              std::uint8_t source_address, std::uint8_t priority) {
  CanFrame f = detail::full_frame(detail::pdu2_id(kPgnHeartbeat, priority, source_address));
  f.data.fill(0xFF);
  const double interval_s = interval_ns > 0 ? static_cast<double>(interval_ns) * 1e-9 : detail::kNaN;
  put_le(f.data, 0, to_raw(interval_s, detail::n2k_u16(100.0)), 2);
  f.data[2] = sequence_counter > 252 ? 252 : sequence_counter;
  f.data[3] = static_cast<std::uint8_t>(0xC0 | (static_cast<std::uint8_t>(controller) & 0x3) |
                                        (0x3 << 2) |
                                        ((static_cast<std::uint8_t>(equipment) & 0x3) << 4));
  return f;
}

Status check_n2k_product_information(const N2kProductInformation& info) {
  const std::pair<const char*, const std::string*> strings[] = {
      {"model_id", &info.model_id},
      {"software_version", &info.software_version},
      {"model_version", &info.model_version},
      {"serial_code", &info.serial_code}};
  for (const auto& [field, value] : strings) {
    if (value->size() > kProductInformationStringBytes) {
      return make_error(ErrorCode::kInvalidArgument,
                        std::string("product information ") + field + ": " +
                            std::to_string(value->size()) + " bytes, at most 32");
    }
    for (const char c : *value) {
      if (c < 0x20 || c > 0x7E) {
        return make_error(ErrorCode::kInvalidArgument,
                          std::string("product information ") + field +
                              ": only printable ASCII characters");
      }
    }
  }
  return ok_status();
}

std::vector<std::uint8_t> encode_n2k_product_information_payload(
    const N2kProductInformation& info) {
  SITEPOSE_CHECK(check_n2k_product_information(info).has_value());
  std::vector<std::uint8_t> p(kProductInformationBytes, 0xFF);
  put_le(p, 0, info.database_version, 2);
  put_le(p, 2, info.product_code, 2);
  std::size_t at = 4;
  for (const std::string* s :
       {&info.model_id, &info.software_version, &info.model_version, &info.serial_code}) {
    std::copy(s->begin(), s->end(), p.begin() + static_cast<std::ptrdiff_t>(at));
    at += kProductInformationStringBytes;
  }
  p[at++] = info.certification_level;
  p[at] = info.load_equivalency;
  return p;
}

Expected<std::vector<CanFrame>> fast_packet_frames(std::uint32_t can_id,
                                                   std::span<const std::uint8_t> payload,
                                                   std::uint8_t sequence_counter) {
  if (payload.empty() || payload.size() > kFastPacketMaxBytes) {
    return make_error(ErrorCode::kInvalidArgument,
                      "fast packet payload of " + std::to_string(payload.size()) +
                          " bytes: must be 1.." + std::to_string(kFastPacketMaxBytes));
  }
  if (sequence_counter > 7) {
    return make_error(
        ErrorCode::kInvalidArgument,
        "fast packet sequence counter = " + std::to_string(sequence_counter) + ": must be 0..7");
  }
  std::vector<CanFrame> frames;
  std::size_t pos = 0;
  for (std::uint8_t index = 0; pos < payload.size(); ++index) {
    CanFrame f = detail::full_frame(can_id);
    f.data.fill(0xFF);
    f.data[0] = static_cast<std::uint8_t>((sequence_counter << 5) | index);
    std::size_t out = 1;
    if (index == 0) f.data[out++] = static_cast<std::uint8_t>(payload.size());
    while (out < kCanMaxDataBytes && pos < payload.size()) f.data[out++] = payload[pos++];
    frames.push_back(f);
  }
  return frames;
}

}  // namespace sitepose::output
