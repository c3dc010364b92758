#pragma once
// One classic CAN 2.0 frame as the encoders produce it and the sinks send it,
// plus the J1939 / NMEA 2000 29-bit identifier layout (PLATFORM.md "CAN
// message facts"): id = priority << 26 | PGN << 8 | source address, where a
// PDU1 PGN (PF < 240) carries the destination address in its low byte.
// Values only: no I/O, no threads.

#include <array>
#include <cstdint>

#include "sitepose/core/expected.hpp"

namespace sitepose::output {

inline constexpr std::uint32_t kCanExtendedIdMask = 0x1FFFFFFFu;
inline constexpr std::uint32_t kCanStandardIdMask = 0x7FFu;
inline constexpr std::uint8_t kCanMaxDataBytes = 8;
inline constexpr std::uint8_t kJ1939GlobalAddress = 0xFF;  // "to everyone"

struct CanFrame {
  std::uint32_t id = 0;                               // 29-bit when `extended`, 11-bit otherwise
  bool extended = true;                               // J1939 and NMEA 2000 use extended ids only
  std::uint8_t dlc = 0;                               // number of data bytes, 0..8
  std::array<std::uint8_t, kCanMaxDataBytes> data{};  // bytes past dlc are 0

  friend bool operator==(const CanFrame&, const CanFrame&) = default;
};

// Parts of a 29-bit J1939 / NMEA 2000 identifier.
struct J1939Id {
  std::uint8_t priority = 6;  // 0 (highest) .. 7
  std::uint32_t pgn = 0;      // 18 bits: EDP, DP, PF, PS
  std::uint8_t source_address = 0;
  std::uint8_t destination_address = kJ1939GlobalAddress;  // PDU1 PGNs only
};

// Builds the 29-bit id. Fails (kInvalidArgument, naming the field and value)
// for priority > 7, PGN > 0x3FFFF, or a PDU1 PGN whose low byte is not 0.
Expected<std::uint32_t> make_j1939_id(const J1939Id& parts);

// Splits a 29-bit id; for a PDU1 id the PS byte goes to destination_address
// and the PGN's low byte is 0.
J1939Id split_j1939_id(std::uint32_t id);

}  // namespace sitepose::output
