// The J1939 / NMEA 2000 node without a bus: frames in, frames out, time
// given by the test.

#include "sitepose/output/j1939_node.hpp"

#include <gtest/gtest.h>

#include "sitepose/output/j1939.hpp"
#include "test_util.hpp"

namespace sitepose::output {
namespace {

constexpr std::int64_t kMs = 1'000'000;

J1939NodeOptions options(std::uint32_t identity, bool arbitrary = true) {
  J1939NodeOptions o;
  o.name.identity_number = identity;
  o.name.manufacturer_code = 0x7FE;
  o.name.function = 145;
  o.name.vehicle_system = 60;
  o.name.industry_group = 4;
  o.name.arbitrary_address_capable = arbitrary;
  o.preferred_address = 0x1C;
  o.transmitted_pgns = {kPgnVehiclePosition, kPgnPositionRapidUpdate};
  o.heartbeat_interval_ns = 60'000 * kMs;
  o.product.software_version = "0.1.0";
  o.product.serial_code = "SN-0042";
  return o;
}

// A node that claimed 0x1C at t = 0 and has sent its first heartbeat.
J1939Node claimed_node(std::uint32_t identity) {
  J1939Node node(options(identity));
  node.start(0);
  node.on_time(250 * kMs);
  (void)node.take_outgoing();
  return node;
}

std::uint32_t pgn_of(const CanFrame& f) { return split_j1939_id(f.id).pgn; }
std::uint8_t sa_of(const CanFrame& f) { return static_cast<std::uint8_t>(f.id & 0xFF); }

TEST(J1939Name, PacksEveryFieldAtItsBitsAndBack) {
  J1939Name n;
  n.identity_number = 0x1ABCDE;
  n.manufacturer_code = 0x5A5;
  n.ecu_instance = 5;
  n.function_instance = 17;
  n.function = 0xC3;
  n.vehicle_system = 0x55;
  n.vehicle_system_instance = 9;
  n.industry_group = 2;
  n.arbitrary_address_capable = true;
  const std::uint64_t packed = pack_j1939_name(n);
  EXPECT_EQ(packed & 0x1FFFFF, 0x1ABCDEu);
  EXPECT_EQ((packed >> 21) & 0x7FF, 0x5A5u);
  EXPECT_EQ((packed >> 32) & 0x7, 5u);
  EXPECT_EQ((packed >> 35) & 0x1F, 17u);
  EXPECT_EQ((packed >> 40) & 0xFF, 0xC3u);
  EXPECT_EQ((packed >> 48) & 0x1, 0u);  // reserved
  EXPECT_EQ((packed >> 49) & 0x7F, 0x55u);
  EXPECT_EQ((packed >> 56) & 0xF, 9u);
  EXPECT_EQ((packed >> 60) & 0x7, 2u);
  EXPECT_EQ(packed >> 63, 1u);
  EXPECT_EQ(unpack_j1939_name(packed), n);
}

TEST(J1939Name, CheckNamesTheFieldThatDoesNotFit) {
  J1939Name n;
  n.identity_number = 1u << 21;
  const Status st = check_j1939_name(n);
  ASSERT_FALSE(st.has_value());
  EXPECT_NE(st.error().message.find("identity_number"), std::string::npos);
  n.identity_number = 0;
  n.industry_group = 8;
  EXPECT_NE(check_j1939_name(n).error().message.find("industry_group"), std::string::npos);
}

TEST(J1939Network, FramesHaveTheirPgnAddressesAndLayout) {
  const CanFrame claim = encode_address_claimed(0x8123456789ABCDEFull, 0x1C);
  EXPECT_EQ(claim.id, 0x18EEFF1Cu);  // priority 6, PF 0xEE, global
  testing::expect_data(claim, {0xEF, 0xCD, 0xAB, 0x89, 0x67, 0x45, 0x23, 0x81});
  const auto parsed = parse_address_claimed(claim);
  ASSERT_TRUE(parsed);
  EXPECT_EQ(parsed->name, 0x8123456789ABCDEFull);
  EXPECT_EQ(parsed->source_address, 0x1C);

  const CanFrame request = encode_request(65267, 0x80, 0x1C);
  EXPECT_EQ(request.id, 0x18EA1C80u);
  testing::expect_data(request, {0xF3, 0xFE, 0x00});
  const auto r = parse_request(request);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->pgn, 65267u);
  EXPECT_EQ(r->requester, 0x80);
  EXPECT_EQ(r->destination, 0x1C);

  const CanFrame nack = encode_acknowledgement(AckControl::kNack, 65000, 0x80, 0x1C);
  EXPECT_EQ(nack.id, 0x18E8FF1Cu);
  testing::expect_data(nack, {0x01, 0xFF, 0xFF, 0xFF, 0x80, 0xE8, 0xFD, 0x00});
  EXPECT_FALSE(parse_request(nack));
  EXPECT_FALSE(parse_address_claimed(request));
}

TEST(J1939Node, ClaimsThePreferredAddressAndWaitsTheSettleTime) {
  J1939Node node(options(7));
  EXPECT_EQ(node.state(), J1939AddressState::kStopped);
  node.start(0);
  auto out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0], encode_address_claimed(node.name(), 0x1C));
  EXPECT_FALSE(node.may_transmit());
  EXPECT_EQ(node.next_deadline_ns(), 250 * kMs);
  node.on_time(249 * kMs);
  EXPECT_FALSE(node.may_transmit());
  node.on_time(250 * kMs);
  EXPECT_TRUE(node.may_transmit());
  out = node.take_outgoing();  // the first heartbeat
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(pgn_of(out[0]), kPgnHeartbeat);
  EXPECT_EQ(out[0].id >> 26, 7u);
  // 60 s = 6000 x 0.01 s; sequence 0; controller error active, controller 2 n/a.
  testing::expect_data(out[0], {0x70, 0x17, 0x00, 0xCC, 0xFF, 0xFF, 0xFF, 0xFF});
  EXPECT_EQ(node.next_deadline_ns(), 60'250 * kMs);
  node.set_controller_state(N2kControllerState::kErrorPassive);
  node.on_time(60'250 * kMs);
  out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].data[2], 1);     // sequence advanced
  EXPECT_EQ(out[0].data[3], 0xCD);  // error passive
}

TEST(J1939Node, WinsAContestWithALowerNameByClaimingAgain) {
  J1939Node node(options(7));
  node.start(0);
  (void)node.take_outgoing();
  const std::uint64_t higher = pack_j1939_name(options(9).name);
  ASSERT_LT(node.name(), higher);
  node.on_frame(encode_address_claimed(higher, 0x1C), 10 * kMs);
  const auto out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0], encode_address_claimed(node.name(), 0x1C));
  EXPECT_EQ(node.address(), 0x1C);
  EXPECT_EQ(node.counters().contests_won, 1u);
}

TEST(J1939Node, LoserWithArbitraryAddressMovesToAFreeDynamicAddress) {
  J1939Node node(options(9));
  node.start(0);
  (void)node.take_outgoing();
  // Address 128 is taken by a third node.
  node.on_frame(encode_address_claimed(pack_j1939_name(options(3).name), 128), 5 * kMs);
  node.on_time(300 * kMs);
  ASSERT_TRUE(node.may_transmit());
  (void)node.take_outgoing();
  node.on_frame(encode_address_claimed(pack_j1939_name(options(7).name), 0x1C), 400 * kMs);
  EXPECT_FALSE(node.may_transmit());
  EXPECT_EQ(node.state(), J1939AddressState::kClaiming);
  EXPECT_EQ(node.address(), 129);
  const auto out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0], encode_address_claimed(node.name(), 129));
  node.on_time(650 * kMs);
  EXPECT_TRUE(node.may_transmit());
  EXPECT_EQ(node.counters().contests_lost, 1u);
  EXPECT_EQ(node.counters().address_changes, 1u);
}

TEST(J1939Node, LoserWithoutArbitraryAddressSendsCannotClaimAndGoesSilent) {
  J1939Node node(options(9, /*arbitrary=*/false));
  node.start(0);
  (void)node.take_outgoing();
  // The arbitrary-address bit is the NAME's top bit: the winner lacks it too.
  node.on_frame(encode_address_claimed(pack_j1939_name(options(7, false).name), 0x1C), 5 * kMs);
  EXPECT_EQ(node.state(), J1939AddressState::kCannotClaim);
  auto out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0], encode_address_claimed(node.name(), kJ1939NullAddress));
  EXPECT_EQ(node.address(), kJ1939NullAddress);
  // Silent: no heartbeat, no answers but to Request for Address Claimed,
  // and that one after the pseudo-random delay.
  node.on_time(100'000 * kMs);
  node.on_frame(encode_request(kPgnVehiclePosition, 0x80, kJ1939GlobalAddress), 100'001 * kMs);
  EXPECT_TRUE(node.take_outgoing().empty());
  node.on_frame(encode_request(kPgnAddressClaimed, 0x80, kJ1939GlobalAddress), 100'002 * kMs);
  EXPECT_TRUE(node.take_outgoing().empty());
  const std::int64_t due = node.next_deadline_ns();
  ASSERT_GE(due, 100'002 * kMs);
  ASSERT_LE(due, 100'155 * kMs);
  node.on_time(due);
  out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0], encode_address_claimed(node.name(), kJ1939NullAddress));
  node.start(200'000 * kMs);  // a lost node stays silent after a link restart too
  EXPECT_TRUE(node.take_outgoing().empty());
}

TEST(J1939Node, AnswersRequestsForWhatItSendsAndRefusesTheRest) {
  J1939Node node = claimed_node(7);
  // Before any data: "cannot respond" to a request to this node, nothing to a global one.
  node.on_frame(encode_request(kPgnVehiclePosition, 0x80, 0x1C), 300 * kMs);
  auto out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  auto ack = parse_acknowledgement(out[0]);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->control, AckControl::kCannotRespond);
  EXPECT_EQ(ack->pgn, kPgnVehiclePosition);
  EXPECT_EQ(ack->requester, 0x80);
  node.on_frame(encode_request(kPgnVehiclePosition, 0x80, kJ1939GlobalAddress), 301 * kMs);
  EXPECT_TRUE(node.take_outgoing().empty());
  // A PGN it never sends: NACK.
  node.on_frame(encode_request(65000, 0x80, 0x1C), 302 * kMs);
  out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(parse_acknowledgement(out[0])->control, AckControl::kNack);
  // A request to another node: ignored.
  node.on_frame(encode_request(kPgnVehiclePosition, 0x80, 0x30), 303 * kMs);
  EXPECT_TRUE(node.take_outgoing().empty());
  // With data: the last message, from the node's address.
  const CanFrame vp = encode_j1939_vehicle_position(48.1, 11.5, 0x1C);
  node.remember_message(kPgnVehiclePosition, {vp});
  node.on_frame(encode_request(kPgnVehiclePosition, 0x80, kJ1939GlobalAddress), 304 * kMs);
  out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0], vp);
  // Address Claimed on request.
  node.on_frame(encode_request(kPgnAddressClaimed, kJ1939NullAddress, kJ1939GlobalAddress),
                305 * kMs);
  out = node.take_outgoing();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0], encode_address_claimed(node.name(), 0x1C));
  EXPECT_EQ(node.counters().requests_answered, 2u);
  EXPECT_EQ(node.counters().requests_refused, 2u);
}

TEST(J1939Node, ProductInformationIsA134ByteFastPacket) {
  J1939Node node = claimed_node(7);
  node.on_frame(encode_request(kPgnProductInformation, 0x80, 0x1C), 300 * kMs);
  const auto out = node.take_outgoing();
  ASSERT_EQ(out.size(), 20u);  // 6 + 19 * 7 >= 134
  std::vector<std::uint8_t> payload;
  for (std::size_t k = 0; k < out.size(); ++k) {
    EXPECT_EQ(pgn_of(out[k]), kPgnProductInformation);
    EXPECT_EQ(sa_of(out[k]), 0x1C);
    EXPECT_EQ(out[k].data[0] & 0x1F, k);
    const std::size_t first = k == 0 ? 2 : 1;
    if (k == 0) {
      EXPECT_EQ(out[k].data[1], 134);
    }
    payload.insert(payload.end(), out[k].data.begin() + first, out[k].data.end());
  }
  payload.resize(134);
  EXPECT_EQ(payload[0] | (payload[1] << 8), 2100);  // NMEA 2000 version 2.100
  const std::string model(payload.begin() + 4, payload.begin() + 12);
  EXPECT_EQ(model, "sitepose");
  EXPECT_EQ(payload[12], 0xFF);  // padding
  const std::string software(payload.begin() + 36, payload.begin() + 41);
  EXPECT_EQ(software, "0.1.0");
  const std::string serial(payload.begin() + 100, payload.begin() + 107);
  EXPECT_EQ(serial, "SN-0042");
  EXPECT_EQ(payload[133], 1);  // load equivalency 50 mA
}

TEST(J1939NodeOptions, CheckNamesTheField) {
  J1939NodeOptions o = options(7);
  o.preferred_address = 254;
  EXPECT_NE(check_j1939_node_options(o).error().message.find("preferred address"),
            std::string::npos);
  o = options(7);
  o.heartbeat_interval_ns = 1000;
  EXPECT_NE(check_j1939_node_options(o).error().message.find("heartbeat"), std::string::npos);
  o = options(7);
  o.product.model_id = std::string(33, 'x');
  EXPECT_NE(check_j1939_node_options(o).error().message.find("model_id"), std::string::npos);
  EXPECT_TRUE(check_j1939_node_options(options(7)).has_value());
}

}  // namespace
}  // namespace sitepose::output
