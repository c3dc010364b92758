#pragma once
// J1939 network management values: the 64-bit NAME that identifies a node
// (J1939-81), and the frames of address claiming (PGN 60928), Request
// (PGN 59904) and Acknowledgement (PGN 59392, J1939-21). Pure functions; the
// node that uses them is j1939_node.hpp.

#include <cstdint>
#include <optional>

#include "sitepose/core/expected.hpp"
#include "sitepose/output/can_frame.hpp"

namespace sitepose::output {

inline constexpr std::uint32_t kPgnAddressClaimed = 60928;  // 0xEE00, PDU1
inline constexpr std::uint32_t kPgnRequest = 59904;         // 0xEA00, PDU1
inline constexpr std::uint32_t kPgnAcknowledgement = 59392; // 0xE800, PDU1
inline constexpr std::uint8_t kJ1939NullAddress = 254;       // "Cannot Claim" source
inline constexpr std::uint8_t kJ1939MaxUnicastAddress = 253;
inline constexpr std::uint8_t kDefaultPriorityNetworkManagement = 6;

// NAME fields, least significant first (J1939-81 4.1.1). A lower NAME value
// wins an address contest. NMEA 2000 uses the same layout (vehicle system =
// device class, industry group 4 = marine).
struct J1939Name {
  std::uint32_t identity_number = 0;         // 21 bits: unique per unit (its serial number)
  std::uint16_t manufacturer_code = 0;       // 11 bits
  std::uint8_t ecu_instance = 0;             // 3 bits
  std::uint8_t function_instance = 0;        // 5 bits
  std::uint8_t function = 0;                 // 8 bits
  std::uint8_t vehicle_system = 0;           // 7 bits
  std::uint8_t vehicle_system_instance = 0;  // 4 bits
  std::uint8_t industry_group = 0;           // 3 bits
  bool arbitrary_address_capable = true;     // bit 63: may move to another address

  friend bool operator==(const J1939Name&, const J1939Name&) = default;
};

// Fails naming the field whose value does not fit its bit width.
Status check_j1939_name(const J1939Name& name);
// `name` must pass check_j1939_name (checked: programmer error).
std::uint64_t pack_j1939_name(const J1939Name& name);
J1939Name unpack_j1939_name(std::uint64_t packed);

// Address Claimed from `source_address` (kJ1939NullAddress: Cannot Claim),
// to the global address, 8 data bytes = NAME little-endian.
CanFrame encode_address_claimed(std::uint64_t name, std::uint8_t source_address,
                                std::uint8_t priority = kDefaultPriorityNetworkManagement);
// Request for `pgn` (3 data bytes, little-endian) to `destination`
// (kJ1939GlobalAddress: everyone).
CanFrame encode_request(std::uint32_t pgn, std::uint8_t source_address, std::uint8_t destination,
                        std::uint8_t priority = kDefaultPriorityNetworkManagement);

// Acknowledgement control byte (J1939-21 5.4.4).
enum class AckControl : std::uint8_t {
  kAck = 0,
  kNack = 1,            // PGN not supported
  kAccessDenied = 2,
  kCannotRespond = 3,   // supported, but no data to send now
};
// Acknowledgement of `pgn` requested by `requester`, sent to the global
// address: control, group function 0xFF, 2 reserved bytes, the requester's
// address, the PGN (3 bytes).
CanFrame encode_acknowledgement(AckControl control, std::uint32_t pgn, std::uint8_t requester,
                                std::uint8_t source_address,
                                std::uint8_t priority = kDefaultPriorityNetworkManagement);

// Received frames, decoded. std::nullopt when the frame is not of that PGN
// or malformed (wrong length, 11-bit id).
struct AddressClaim {
  std::uint8_t source_address = kJ1939NullAddress;
  std::uint64_t name = 0;
};
std::optional<AddressClaim> parse_address_claimed(const CanFrame& frame);
struct Request {
  std::uint32_t pgn = 0;
  std::uint8_t requester = kJ1939NullAddress;
  std::uint8_t destination = kJ1939GlobalAddress;
};
std::optional<Request> parse_request(const CanFrame& frame);
struct Acknowledgement {
  AckControl control = AckControl::kAck;
  std::uint32_t pgn = 0;
  std::uint8_t requester = kJ1939NullAddress;
  std::uint8_t source_address = kJ1939NullAddress;
};
std::optional<Acknowledgement> parse_acknowledgement(const CanFrame& frame);

}  // namespace sitepose::output
