#include "sitepose/output/j1939_network.hpp"

#include <string>

#include "detail/field_codec.hpp"

namespace sitepose::output {

using detail::put_le;

namespace {

struct NameField {
  const char* name;
  std::uint64_t value;
  int bits;
};

std::uint64_t get_le(const CanFrame& f, std::size_t offset, std::size_t n_bytes) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < n_bytes; ++i) {
    v |= std::uint64_t{f.data[offset + i]} << (8 * i);
  }
  return v;
}

CanFrame pdu1_frame(std::uint32_t pgn, std::uint8_t priority, std::uint8_t source_address,
                    std::uint8_t destination, std::uint8_t dlc) {
  const auto id = make_j1939_id(J1939Id{priority, pgn, source_address, destination});
  SITEPOSE_CHECK(id.has_value());  // fixed PDU1 PGNs; priorities are checked by the callers
  CanFrame f;
  f.id = *id;
  f.extended = true;
  f.dlc = dlc;
  f.data.fill(0xFF);
  return f;
}

// The frame's J1939 parts when it is an extended frame of `pgn`.
std::optional<J1939Id> of_pgn(const CanFrame& frame, std::uint32_t pgn) {
  if (!frame.extended) return std::nullopt;
  const J1939Id parts = split_j1939_id(frame.id);
  if (parts.pgn != pgn) return std::nullopt;
  return parts;
}

}  // namespace

Status check_j1939_name(const J1939Name& n) {
  const NameField fields[] = {
      {"identity_number", n.identity_number, 21},
      {"manufacturer_code", n.manufacturer_code, 11},
      {"ecu_instance", n.ecu_instance, 3},
      {"function_instance", n.function_instance, 5},
      {"function", n.function, 8},
      {"vehicle_system", n.vehicle_system, 7},
      {"vehicle_system_instance", n.vehicle_system_instance, 4},
      {"industry_group", n.industry_group, 3},
  };
  for (const NameField& f : fields) {
    const std::uint64_t max = (std::uint64_t{1} << f.bits) - 1;
    if (f.value > max) {
      return make_error(ErrorCode::kInvalidArgument,
                        std::string("J1939 NAME ") + f.name + " = " + std::to_string(f.value) +
                            ": must be 0.." + std::to_string(max) + " (" +
                            std::to_string(f.bits) + " bits)");
    }
  }
  return ok_status();
}

std::uint64_t pack_j1939_name(const J1939Name& n) {
  SITEPOSE_CHECK(check_j1939_name(n).has_value());
  return std::uint64_t{n.identity_number} | (std::uint64_t{n.manufacturer_code} << 21) |
         (std::uint64_t{n.ecu_instance} << 32) | (std::uint64_t{n.function_instance} << 35) |
         (std::uint64_t{n.function} << 40) | (std::uint64_t{n.vehicle_system} << 49) |
         (std::uint64_t{n.vehicle_system_instance} << 56) |
         (std::uint64_t{n.industry_group} << 60) |
         (std::uint64_t{n.arbitrary_address_capable} << 63);
}

J1939Name unpack_j1939_name(std::uint64_t v) {
  auto bits = [v](int shift, int width) { return (v >> shift) & ((std::uint64_t{1} << width) - 1); };
  J1939Name n;
  n.identity_number = static_cast<std::uint32_t>(bits(0, 21));
  n.manufacturer_code = static_cast<std::uint16_t>(bits(21, 11));
  n.ecu_instance = static_cast<std::uint8_t>(bits(32, 3));
  n.function_instance = static_cast<std::uint8_t>(bits(35, 5));
  n.function = static_cast<std::uint8_t>(bits(40, 8));
  n.vehicle_system = static_cast<std::uint8_t>(bits(49, 7));
  n.vehicle_system_instance = static_cast<std::uint8_t>(bits(56, 4));
  n.industry_group = static_cast<std::uint8_t>(bits(60, 3));
  n.arbitrary_address_capable = bits(63, 1) != 0;
  return n;
}

CanFrame encode_address_claimed(std::uint64_t name, std::uint8_t source_address,
                                std::uint8_t priority) {
  CanFrame f = pdu1_frame(kPgnAddressClaimed, priority, source_address, kJ1939GlobalAddress, 8);
  put_le(f.data, 0, static_cast<std::int64_t>(name), 8);
  return f;
}

CanFrame encode_request(std::uint32_t pgn, std::uint8_t source_address, std::uint8_t destination,
                        std::uint8_t priority) {
  CanFrame f = pdu1_frame(kPgnRequest, priority, source_address, destination, 3);
  put_le(f.data, 0, pgn & 0x3FFFF, 3);
  for (std::size_t i = 3; i < kCanMaxDataBytes; ++i) f.data[i] = 0;  // bytes past dlc are 0
  return f;
}

CanFrame encode_acknowledgement(AckControl control, std::uint32_t pgn, std::uint8_t requester,
                                std::uint8_t source_address, std::uint8_t priority) {
  CanFrame f =
      pdu1_frame(kPgnAcknowledgement, priority, source_address, kJ1939GlobalAddress, 8);
  f.data[0] = static_cast<std::uint8_t>(control);
  f.data[1] = 0xFF;  // group function value: not applicable
  f.data[4] = requester;
  put_le(f.data, 5, pgn & 0x3FFFF, 3);
  return f;
}

std::optional<AddressClaim> parse_address_claimed(const CanFrame& frame) {
  const auto parts = of_pgn(frame, kPgnAddressClaimed);
  if (!parts || frame.dlc != 8) return std::nullopt;
  return AddressClaim{parts->source_address, get_le(frame, 0, 8)};
}

std::optional<Request> parse_request(const CanFrame& frame) {
  const auto parts = of_pgn(frame, kPgnRequest);
  if (!parts || frame.dlc < 3) return std::nullopt;
  return Request{static_cast<std::uint32_t>(get_le(frame, 0, 3)), parts->source_address,
                 parts->destination_address};
}

std::optional<Acknowledgement> parse_acknowledgement(const CanFrame& frame) {
  const auto parts = of_pgn(frame, kPgnAcknowledgement);
  if (!parts || frame.dlc != 8 || frame.data[0] > 3) return std::nullopt;
  return Acknowledgement{static_cast<AckControl>(frame.data[0]),
                         static_cast<std::uint32_t>(get_le(frame, 5, 3)), frame.data[4],
                         parts->source_address};
}

}  // namespace sitepose::output
