#include "sitepose/output/can_frame.hpp"

#include <string>

#include "sitepose/core/hex.hpp"

namespace sitepose::output {

Expected<std::uint32_t> make_j1939_id(const J1939Id& parts) {
  if (parts.priority > 7) {
    return make_error(ErrorCode::kInvalidArgument,
                      "CAN priority = " + std::to_string(parts.priority) + ": must be 0..7");
  }
  if (parts.pgn > 0x3FFFF) {
    return make_error(ErrorCode::kInvalidArgument,
                      "PGN = " + hex(parts.pgn, HexStyle::kLiteral) + ": must be at most 0x3FFFF (18 bits)");
  }
  const std::uint32_t pdu_format = (parts.pgn >> 8) & 0xFF;
  std::uint32_t pgn_field = parts.pgn;
  if (pdu_format < 240) {  // PDU1: the PS byte is the destination address
    if ((parts.pgn & 0xFF) != 0) {
      return make_error(ErrorCode::kInvalidArgument, "PGN = " + hex(parts.pgn, HexStyle::kLiteral) +
                                                         ": a PDU1 PGN (PF < 240) must have a zero low byte");
    }
    pgn_field |= parts.destination_address;
  }
  return (std::uint32_t{parts.priority} << 26) | (pgn_field << 8) | parts.source_address;
}

J1939Id split_j1939_id(std::uint32_t id) {
  J1939Id parts;
  parts.priority = static_cast<std::uint8_t>((id >> 26) & 0x7);
  parts.source_address = static_cast<std::uint8_t>(id & 0xFF);
  const std::uint32_t pgn_field = (id >> 8) & 0x3FFFF;
  if (((pgn_field >> 8) & 0xFF) < 240) {
    parts.pgn = pgn_field & 0x3FF00;
    parts.destination_address = static_cast<std::uint8_t>(pgn_field & 0xFF);
  } else {
    parts.pgn = pgn_field;
    parts.destination_address = kJ1939GlobalAddress;
  }
  return parts;
}

}  // namespace sitepose::output
