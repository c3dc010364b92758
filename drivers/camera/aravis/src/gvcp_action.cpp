#include "sitepose/drivers/aravis/gvcp_action.hpp"

#include <charconv>
#include <cstdio>

#include "sitepose/core/hex.hpp"

namespace sitepose::drivers::aravis::gvcp {
namespace {

void put_u16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v >> 8));
  out.push_back(static_cast<std::uint8_t>(v));
}

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  put_u16(out, static_cast<std::uint16_t>(v >> 16));
  put_u16(out, static_cast<std::uint16_t>(v));
}

std::uint64_t get_be(std::span<const std::uint8_t> bytes, std::size_t at, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < n; ++i) v = (v << 8) | bytes[at + i];
  return v;
}

std::uint16_t get_u16(std::span<const std::uint8_t> bytes, std::size_t at) {
  return static_cast<std::uint16_t>(get_be(bytes, at, 2));
}

std::uint32_t get_u32(std::span<const std::uint8_t> bytes, std::size_t at) {
  return static_cast<std::uint32_t>(get_be(bytes, at, 4));
}

std::string hex16(std::uint16_t v) { return hex(v, HexStyle::kLiteral); }

Unexpected parse_error(const std::string& what, const std::string& message) {
  return make_error(ErrorCode::kParseError, what + ": " + message);
}

// The header's command and length against the datagram; the request id.
Expected<std::uint16_t> check_header(std::span<const std::uint8_t> datagram, std::uint16_t command,
                                     const std::string& what) {
  if (datagram.size() < kHeaderBytes) {
    return parse_error(what, std::to_string(datagram.size()) + " bytes, shorter than the 8-byte header");
  }
  if (get_u16(datagram, 2) != command) {
    return parse_error(what, "command " + hex16(get_u16(datagram, 2)) + ", expected " + hex16(command));
  }
  const std::uint16_t length = get_u16(datagram, 4);
  if (length != datagram.size() - kHeaderBytes) {
    return parse_error(what, "length field " + std::to_string(length) + " but " +
                                 std::to_string(datagram.size() - kHeaderBytes) + " bytes follow the header");
  }
  const std::uint16_t id = get_u16(datagram, 6);
  if (id == 0) return parse_error(what, "request id 0");
  return id;
}

}  // namespace

std::string status_name(std::uint16_t status) {
  switch (status) {
    case kStatusSuccess: return "SUCCESS";
    case kStatusNoRefTime: return "NO_REF_TIME";
    case kStatusOverflow: return "OVERFLOW";
    case kStatusActionLate: return "ACTION_LATE";
    default: return "status " + hex16(status);
  }
}

bool action_matches(const ActionCommand& command, std::uint32_t device_key, std::uint32_t group_key,
                    std::uint32_t group_mask) {
  return command.device_key == device_key && command.group_key == group_key &&
         (command.group_mask & group_mask) != 0;
}

Expected<std::uint32_t> parse_key(const std::string& text) {
  const bool hexadecimal = text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X');
  const char* first = text.data() + (hexadecimal ? 2 : 0);
  const char* last = text.data() + text.size();
  std::uint32_t value = 0;
  const auto [end, error] = std::from_chars(first, last, value, hexadecimal ? 16 : 10);
  if (text.empty() || error != std::errc() || end != last) {
    return make_error(ErrorCode::kInvalidArgument,
                      "expected a 32-bit key: decimal or 0x-hexadecimal, at most 0xFFFFFFFF");
  }
  return value;
}

std::string format_key(std::uint32_t key) {
  char text[11];
  std::snprintf(text, sizeof(text), "0x%08X", key);
  return text;
}

std::uint16_t next_request_id(std::uint16_t id) {
  return id == 0xFFFF ? 1 : static_cast<std::uint16_t>(id + 1);
}

std::vector<std::uint8_t> encode_action_command(const ActionPacket& packet) {
  SITEPOSE_CHECK(packet.request_id != 0);
  const ActionCommand& c = packet.command;
  const bool scheduled = c.action_time_ns.has_value();
  std::vector<std::uint8_t> out;
  out.reserve(kHeaderBytes + kScheduledActionPayloadBytes);
  out.push_back(kCommandKey);
  out.push_back(static_cast<std::uint8_t>((packet.ack_required ? kFlagAckRequired : 0) |
                                          (scheduled ? kFlagScheduledAction : 0)));
  put_u16(out, kActionCommand);
  put_u16(out, static_cast<std::uint16_t>(scheduled ? kScheduledActionPayloadBytes : kActionPayloadBytes));
  put_u16(out, packet.request_id);
  put_u32(out, c.device_key);
  put_u32(out, c.group_key);
  put_u32(out, c.group_mask);
  if (scheduled) {
    put_u32(out, static_cast<std::uint32_t>(*c.action_time_ns >> 32));
    put_u32(out, static_cast<std::uint32_t>(*c.action_time_ns));
  }
  return out;
}

Expected<ActionPacket> decode_action_command(std::span<const std::uint8_t> datagram) {
  const std::string what = "ACTION_CMD";
  if (!datagram.empty() && datagram[0] != kCommandKey) {
    return parse_error(what, "key " + hex16(datagram[0]) + ", not a GVCP command (0x42)");
  }
  SITEPOSE_TRY(const std::uint16_t id, check_header(datagram, kActionCommand, what));
  const std::uint8_t flags = datagram[1];
  const bool scheduled = (flags & kFlagScheduledAction) != 0;
  const std::size_t expected = scheduled ? kScheduledActionPayloadBytes : kActionPayloadBytes;
  if (datagram.size() - kHeaderBytes != expected) {
    return parse_error(what, std::to_string(datagram.size() - kHeaderBytes) + " payload bytes, expected " +
                                 std::to_string(expected) +
                                 (scheduled ? " (scheduled)" : " (not scheduled)"));
  }
  ActionPacket packet;
  packet.request_id = id;
  packet.ack_required = (flags & kFlagAckRequired) != 0;
  packet.command.device_key = get_u32(datagram, kHeaderBytes);
  packet.command.group_key = get_u32(datagram, kHeaderBytes + 4);
  packet.command.group_mask = get_u32(datagram, kHeaderBytes + 8);
  if (scheduled) packet.command.action_time_ns = get_be(datagram, kHeaderBytes + 12, 8);
  return packet;
}

std::vector<std::uint8_t> encode_action_ack(const ActionAck& ack) {
  std::vector<std::uint8_t> out;
  out.reserve(kHeaderBytes);
  put_u16(out, ack.status);
  put_u16(out, kActionAck);
  put_u16(out, 0);
  put_u16(out, ack.ack_id);
  return out;
}

Expected<ActionAck> decode_action_ack(std::span<const std::uint8_t> datagram) {
  SITEPOSE_TRY(const std::uint16_t id, check_header(datagram, kActionAck, "ACTION_ACK"));
  return ActionAck{get_u16(datagram, 0), id};
}

}  // namespace sitepose::drivers::aravis::gvcp
