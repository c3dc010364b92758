#pragma once
// GigE Vision action commands as bytes: the ACTION_CMD packet a host sends
// and the ACTION_ACK a camera answers with (GVCP, GigE Vision 2.x). Codec
// only, no sockets (action_sender.hpp sends and collects them).
//
// Layout, every field big-endian:
//   header      key 0x42 | flags u8 | command u16 | length u16 | request id u16
//   ACTION_CMD  device_key u32 | group_key u32 | group_mask u32 [| action_time u64]
//   ACTION_ACK  status u16 | command u16 | length u16 (0) | ack id u16
// `length` counts the bytes after the header (12, or 20 with action_time).
// Flags: 0x01 acknowledge required; 0x80 scheduled action, set exactly when
// action_time is present (the device's timestamp clock, PTP nanoseconds when
// PTP is on). A request id is never 0.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"

namespace sitepose::drivers::aravis::gvcp {

inline constexpr std::uint16_t kGvcpPort = 3956;  // a device's GVCP port
inline constexpr std::uint8_t kCommandKey = 0x42;
inline constexpr std::uint8_t kFlagAckRequired = 0x01;
inline constexpr std::uint8_t kFlagScheduledAction = 0x80;
inline constexpr std::uint16_t kActionCommand = 0x0100;
inline constexpr std::uint16_t kActionAck = 0x0101;
inline constexpr std::size_t kHeaderBytes = 8;
inline constexpr std::size_t kActionPayloadBytes = 12;
inline constexpr std::size_t kScheduledActionPayloadBytes = 20;

// ACTION_ACK statuses a host acts on; any other non-zero status is an error
// code of the device's (GigE Vision's status table).
inline constexpr std::uint16_t kStatusSuccess = 0x0000;
inline constexpr std::uint16_t kStatusNoRefTime = 0x8013;   // scheduled, but no PTP time to act on
inline constexpr std::uint16_t kStatusOverflow = 0x8015;    // the device's action queue is full
inline constexpr std::uint16_t kStatusActionLate = 0x8016;  // action_time had passed on arrival

// "SUCCESS", "NO_REF_TIME", ..., or the code in hex for others.
std::string status_name(std::uint16_t status);

struct ActionCommand {
  std::uint32_t device_key = 0;
  std::uint32_t group_key = 0;
  std::uint32_t group_mask = 0;
  // Scheduled: act at this time of the device's clock; absent: act on arrival.
  std::optional<std::uint64_t> action_time_ns;
};

struct ActionPacket {
  ActionCommand command;
  std::uint16_t request_id = 1;
  bool ack_required = true;
};

struct ActionAck {
  std::uint16_t status = kStatusSuccess;
  std::uint16_t ack_id = 1;  // the request id it answers
};

// Whether a device with these keys acts on `command` (and acknowledges it):
// both keys equal and a group mask bit in common.
bool action_matches(const ActionCommand& command, std::uint32_t device_key, std::uint32_t group_key,
                    std::uint32_t group_mask);

// A 32-bit key or mask as written in settings: decimal or 0x-hexadecimal
// ("0x00000024"). kInvalidArgument otherwise or beyond 0xFFFFFFFF.
Expected<std::uint32_t> parse_key(const std::string& text);
// "0x" and eight hexadecimal digits, which parse_key reads back.
std::string format_key(std::uint32_t key);

// The request id after `id`: 1 after 0xFFFF (0 is not a valid id).
std::uint16_t next_request_id(std::uint16_t id);

// request_id must not be 0 (checked).
std::vector<std::uint8_t> encode_action_command(const ActionPacket& packet);
// kParseError saying what is wrong: too short, not a command (key), another
// command, a length that disagrees with the datagram or the flags, id 0.
Expected<ActionPacket> decode_action_command(std::span<const std::uint8_t> datagram);

std::vector<std::uint8_t> encode_action_ack(const ActionAck& ack);
// kParseError as above; a non-success status is a value, not an error.
Expected<ActionAck> decode_action_ack(std::span<const std::uint8_t> datagram);

}  // namespace sitepose::drivers::aravis::gvcp
