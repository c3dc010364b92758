#pragma once
// NMEA 2000 frames of the sitepose CAN output: pure functions from values to
// frames, and the fast-packet segmentation for messages over 8 bytes.
//
// Conventions (NMEA 2000 / canboat): little-endian fields; NaN inputs are
// sent as "not available" (unsigned: all bits 1, signed: max positive);
// finite values are rounded to the resolution and clamped to the valid range
// (unsigned max - 3, signed max - 3: the top codes mean "out of range",
// "reserved", "not available"); reserved bits are 1. Angles in radians.

#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/output/can_frame.hpp"

namespace sitepose::output {

inline constexpr std::uint32_t kPgnPositionRapidUpdate = 129025;  // 0x1F801
inline constexpr std::uint32_t kPgnCogSogRapidUpdate = 129026;    // 0x1F802
inline constexpr std::uint32_t kPgnGnssPositionData = 129029;     // 0x1F805, fast packet
inline constexpr std::uint32_t kPgnVesselHeading = 127250;        // 0x1F112
inline constexpr std::size_t kGnssPositionDataBytes = 43;         // without reference stations
inline constexpr std::size_t kFastPacketMaxBytes = 223;           // 6 + 31 * 7
inline constexpr std::uint8_t kN2kSidNotAvailable = 0xFF;

// PGN 129025 Position Rapid Update: lat, lon int32 1e-7 deg. Priority 2.
CanFrame encode_n2k_position_rapid_update(double latitude_deg, double longitude_deg,
                                          std::uint8_t source_address, std::uint8_t priority = 2);

// PGN 127250 Vessel Heading: SID, heading u16 1e-4 rad (wrapped into
// [0, 2 pi)), deviation and variation int16 1e-4 rad (NaN = n/a), reference
// 2 bits (0 true, 1 magnetic), 6 reserved bits. Priority 2.
enum class HeadingReference : std::uint8_t { kTrue = 0, kMagnetic = 1 };
struct VesselHeading {
  std::uint8_t sid = kN2kSidNotAvailable;
  double heading_rad = 0.0;
  double deviation_rad = 0.0;
  double variation_rad = 0.0;
  HeadingReference reference = HeadingReference::kTrue;
};
CanFrame encode_n2k_vessel_heading(const VesselHeading& v, std::uint8_t source_address,
                                   std::uint8_t priority = 2);

// PGN 129026 COG & SOG Rapid Update: SID, COG reference 2 bits + 6 reserved,
// COG u16 1e-4 rad (wrapped into [0, 2 pi)), SOG u16 0.01 m/s (negative
// clamps to 0), 2 reserved bytes. Priority 2.
struct CogSog {
  std::uint8_t sid = kN2kSidNotAvailable;
  HeadingReference reference = HeadingReference::kTrue;
  double cog_rad = 0.0;
  double sog_mps = 0.0;
};
CanFrame encode_n2k_cog_sog_rapid_update(const CogSog& v, std::uint8_t source_address,
                                         std::uint8_t priority = 2);

// PGN 129029 GNSS Position Data, 43 bytes (PLATFORM.md):
//   SID u8; date u16 days since 1970-01-01; time u32 1e-4 s since midnight
//   (UTC); lat, lon int64 1e-16 deg; altitude int64 1e-6 m (WGS84
//   ellipsoid); type 4 b | method 4 b; integrity 2 b + 6 reserved; nSV u8;
//   HDOP, PDOP int16 0.01; geoidal separation int32 0.01 m; nRef u8 (0).
enum class GnssType : std::uint8_t { kGps = 0, kIntegrated = 6, kSurveyed = 7 };
enum class GnssMethod : std::uint8_t {
  kNoFix = 0,
  kGnssFix = 1,
  kDgnss = 2,
  kPreciseGnss = 3,
  kRtkFixed = 4,
  kRtkFloat = 5,
  kEstimated = 6,  // dead reckoning: what a visual positioning system is
  kManual = 7,
  kSimulated = 8,
};
enum class GnssIntegrity : std::uint8_t { kNoChecking = 0, kSafe = 1, kCaution = 2 };
struct GnssPositionData {
  std::uint8_t sid = kN2kSidNotAvailable;
  std::int64_t utc_t_ns = -1;  // ns since the Unix epoch; < 0 = date/time n/a
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
  double altitude_m = 0.0;
  GnssType type = GnssType::kIntegrated;
  GnssMethod method = GnssMethod::kEstimated;
  GnssIntegrity integrity = GnssIntegrity::kNoChecking;
  int satellites = -1;  // < 0 = n/a
  double hdop = kNan;
  double pdop = kNan;
  double geoidal_separation_m = kNan;  // geoid above the ellipsoid; NaN = n/a

  static constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
};
// The 43-byte payload (reassembled view, as the DBC describes it).
std::vector<std::uint8_t> encode_n2k_gnss_position_payload(const GnssPositionData& v);
// The payload cut into fast-packet frames. Priority 3.
std::vector<CanFrame> encode_n2k_gnss_position_data(const GnssPositionData& v, std::uint8_t sequence_counter,
                                                    std::uint8_t source_address, std::uint8_t priority = 3);

// PGN 126993 Heartbeat, 8 bytes, priority 7: data transmit offset (the
// interval until the next heartbeat; <= 0: not available) u16 0.01 s; sequence counter u8 (0..252,
// wraps); byte 3: controller 1 state bits 0-1, controller 2 state bits 2-3
// (not available: 3), equipment status bits 4-5, bits 6-7 reserved (1);
// bytes 4-7 reserved (0xFF).
inline constexpr std::uint32_t kPgnHeartbeat = 126993;  // 0x1F011
enum class N2kControllerState : std::uint8_t { kErrorActive = 0, kErrorPassive = 1, kBusOff = 2 };
enum class N2kEquipmentStatus : std::uint8_t { kOperational = 0, kFault = 1 };
CanFrame encode_n2k_heartbeat(std::int64_t interval_ns, std::uint8_t sequence_counter,
                              N2kControllerState controller, N2kEquipmentStatus equipment,
                              std::uint8_t source_address, std::uint8_t priority = 7);

// PGN 126996 Product Information, 134 bytes as a fast packet, priority 6:
// NMEA 2000 database version u16 0.001; product code u16; model id,
// software version, model version and serial code, 32 bytes each (ASCII,
// padded with 0xFF); certification level u8; load equivalency u8 (50 mA).
inline constexpr std::uint32_t kPgnProductInformation = 126996;  // 0x1F014
inline constexpr std::size_t kProductInformationBytes = 134;
inline constexpr std::size_t kProductInformationStringBytes = 32;
struct N2kProductInformation {
  std::uint16_t database_version = 2100;  // 2.100
  std::uint16_t product_code = 0xFFFF;    // not available unless one is assigned
  std::string model_id = "sitepose";
  std::string software_version;
  std::string model_version;
  std::string serial_code;
  std::uint8_t certification_level = 0xFF;  // not certified: not available
  std::uint8_t load_equivalency = 1;        // units of 50 mA (powered apart from the bus)
};
// Fails naming the field when a string is longer than 32 bytes or holds a
// byte outside printable ASCII.
Status check_n2k_product_information(const N2kProductInformation& info);
// `info` must pass the check (checked: programmer error).
std::vector<std::uint8_t> encode_n2k_product_information_payload(const N2kProductInformation& info);

// NMEA 2000 fast packet: frame 0 = [seq << 5 | 0, total length, 6 bytes],
// frame k = [seq << 5 | k, 7 bytes]; the last frame is padded with 0xFF; every
// frame has dlc 8. `sequence_counter` is 3 bits (0..7) and should advance per
// message of the same PGN. Fails when the payload is empty, longer than 223
// bytes, or the counter exceeds 7.
Expected<std::vector<CanFrame>> fast_packet_frames(std::uint32_t can_id,
                                                   std::span<const std::uint8_t> payload,
                                                   std::uint8_t sequence_counter);

}  // namespace sitepose::output
