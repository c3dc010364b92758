#pragma once
// Identifier of a frame with a fixed, known-valid PDU2 PGN. A priority above
// 7 is a programmer error here (configured priorities are checked when the
// options are validated).

#include "sitepose/output/can_frame.hpp"

namespace sitepose::output::detail {

inline std::uint32_t pdu2_id(std::uint32_t pgn, std::uint8_t priority,
                             std::uint8_t source_address) {
  SITEPOSE_CHECK(priority <= 7);
  SITEPOSE_CHECK(((pgn >> 8) & 0xFF) >= 240 && pgn <= 0x3FFFF);
  const auto id = make_j1939_id(J1939Id{priority, pgn, source_address, kJ1939GlobalAddress});
  SITEPOSE_CHECK(id.has_value());
  return *id;
}

inline CanFrame full_frame(std::uint32_t id) {
  CanFrame f;
  f.id = id;
  f.extended = true;
  f.dlc = kCanMaxDataBytes;
  return f;
}

}  // namespace sitepose::output::detail
