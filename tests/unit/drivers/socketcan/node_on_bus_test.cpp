// The J1939 node of the SocketCAN sink on a virtual bus (socketpairs joined
// by a forwarding thread): address contests between two sinks, and Requests
// from a third node.

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "can_test_support.hpp"
#include "sitepose/drivers/socketcan/socketcan_sink.hpp"
#include "sitepose/output/can_pose_encoder.hpp"
#include "sitepose/output/j1939.hpp"
#include "sitepose/output/j1939_network.hpp"

namespace sitepose::drivers::socketcan {
namespace {

using namespace std::chrono_literals;
using output::CanFrame;
using testing::wait_until;

constexpr std::uint8_t kPreferred = 0x1C;
constexpr std::uint8_t kTester = 0x80;

SocketCanSinkOptions node_options(std::uint32_t identity, bool arbitrary) {
  SocketCanSinkOptions o;
  o.interface = "vbus";
  o.node.name.identity_number = identity;
  o.node.name.manufacturer_code = 0x7FE;
  o.node.name.arbitrary_address_capable = arbitrary;
  o.node.preferred_address = kPreferred;
  o.node.heartbeat_interval_ns = 0;
  o.node.transmitted_pgns = output::transmitted_pgns(output::CanOutputOptions{});
  o.backoff_min_ns = 100'000;
  o.backoff_max_ns = 20'000'000;
  return o;  // claim settle: the standard's 250 ms
}

std::unique_ptr<SocketCanSink> open_on(int fd, const SocketCanSinkOptions& o) {
  auto sink = SocketCanSink::open(o, fd_socket_ops(fd));
  EXPECT_TRUE(sink.has_value()) << sink.error().message;
  return sink ? std::move(*sink) : nullptr;
}

// Address Claimed / Cannot Claim frames on the bus, in order: (sender, address).
std::vector<std::pair<int, std::uint8_t>> claims(const testing::VirtualBus& bus) {
  std::vector<std::pair<int, std::uint8_t>> out;
  for (const auto& [from, f] : bus.log()) {
    if (auto c = output::parse_address_claimed(f)) out.emplace_back(from, c->source_address);
  }
  return out;
}

output::CanPoseInputs one_pose() {
  output::CanPoseInputs in;
  in.utc_t_ns = 1'700'000'000'000'000'000LL;
  in.latitude_deg = 48.137;
  in.longitude_deg = 11.575;
  in.altitude_m = 520.0;
  in.quality.state = TrackingState::kOk;
  return in;
}

Status publish(SocketCanSink& sink, const std::vector<CanFrame>& frames) {
  for (const CanFrame& f : frames) SITEPOSE_TRY_STATUS(sink.send(0, f));
  return sink.flush();
}

TEST(J1939OnBus, TwoNodesWithTheSamePreferredAddressResolveByName) {
  testing::VirtualBus bus;
  const int fd_low = bus.attach(), fd_high = bus.attach();
  bus.start();
  // Identity 5 < 9: node 0 has the lower NAME and keeps the address.
  auto low = open_on(fd_low, node_options(5, true));
  auto high = open_on(fd_high, node_options(9, true));
  ASSERT_TRUE(low && high);
  ASSERT_TRUE(wait_until([&] {
    return low->stats().state == CanLinkState::kUp && high->stats().state == CanLinkState::kUp;
  }));
  EXPECT_EQ(low->stats().source_address, kPreferred);
  EXPECT_EQ(high->stats().source_address, 128);
  EXPECT_EQ(high->stats().node.contests_lost, 1u);
  EXPECT_EQ(low->stats().node.contests_lost, 0u);
  // On the bus: both claimed 0x1C; the loser moved to 128 (and the winner
  // defended 0x1C when it heard the loser's claim, unless the loser had
  // already moved).
  const auto c = claims(bus);
  EXPECT_TRUE(std::count(c.begin(), c.end(), std::make_pair(0, kPreferred)) >= 1);
  EXPECT_TRUE(std::count(c.begin(), c.end(), std::make_pair(1, kPreferred)) == 1);
  EXPECT_TRUE(std::count(c.begin(), c.end(), std::make_pair(1, std::uint8_t{128})) == 1);
  // Both send poses, each from its own address.
  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  const auto frames = encoder.encode(one_pose());
  ASSERT_TRUE(publish(*low, frames).has_value());
  ASSERT_TRUE(publish(*high, frames).has_value());
  ASSERT_TRUE(wait_until([&] { return low->stats().poses_sent == 1 && high->stats().poses_sent == 1; }));
  ASSERT_TRUE(wait_until([&] {
    std::set<std::pair<int, std::uint8_t>> sources;
    for (const auto& [from, f] : bus.log()) {
      if (output::split_j1939_id(f.id).pgn == output::kPgnVehiclePosition) {
        sources.emplace(from, static_cast<std::uint8_t>(f.id & 0xFF));
      }
    }
    return sources == std::set<std::pair<int, std::uint8_t>>{{0, kPreferred}, {1, 128}};
  }));
}

TEST(J1939OnBus, LoserWithoutArbitraryAddressSendsCannotClaimAndSendsNoPoses) {
  testing::VirtualBus bus;
  const int fd_low = bus.attach(), fd_high = bus.attach();
  bus.start();
  auto low = open_on(fd_low, node_options(5, false));
  auto high = open_on(fd_high, node_options(9, false));
  ASSERT_TRUE(low && high);
  ASSERT_TRUE(wait_until([&] {
    return low->stats().state == CanLinkState::kUp &&
           high->stats().state == CanLinkState::kCannotClaim;
  }));
  const auto c = claims(bus);
  EXPECT_EQ(std::count(c.begin(), c.end(), std::make_pair(1, output::kJ1939NullAddress)), 1);
  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  const Status refused = publish(*high, encoder.encode(one_pose()));
  ASSERT_FALSE(refused.has_value());
  EXPECT_NE(refused.error().message.find("Cannot Claim"), std::string::npos);
  // A Request for Address Claimed gets Cannot Claim again (after its delay).
  bus.inject(output::encode_request(output::kPgnAddressClaimed, kTester, output::kJ1939GlobalAddress));
  ASSERT_TRUE(wait_until([&] {
    const auto cc = claims(bus);
    return std::count(cc.begin(), cc.end(), std::make_pair(1, output::kJ1939NullAddress)) == 2;
  }));
  for (const auto& [from, f] : bus.log()) {
    if (from == 1) {
      EXPECT_EQ(output::split_j1939_id(f.id).pgn, output::kPgnAddressClaimed);
    }
  }
}

TEST(J1939OnBus, RequestFor65267IsAnsweredWithTheLastVehiclePosition) {
  testing::VirtualBus bus;
  const int fd = bus.attach();
  bus.start();
  auto node = open_on(fd, node_options(5, true));
  ASSERT_TRUE(node);
  ASSERT_TRUE(wait_until([&] { return node->stats().state == CanLinkState::kUp; }));
  auto acks_and_positions = [&] {
    std::vector<CanFrame> out;
    for (const auto& [from, f] : bus.log()) {
      const auto pgn = output::split_j1939_id(f.id).pgn;
      if (from == 0 && (pgn == output::kPgnAcknowledgement || pgn == output::kPgnVehiclePosition)) {
        out.push_back(f);
      }
    }
    return out;
  };
  // No position yet: "cannot respond" to a request addressed to the node.
  bus.inject(output::encode_request(output::kPgnVehiclePosition, kTester, kPreferred));
  ASSERT_TRUE(wait_until([&] { return acks_and_positions().size() == 1; }));
  const auto ack = output::parse_acknowledgement(acks_and_positions()[0]);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->control, output::AckControl::kCannotRespond);
  EXPECT_EQ(ack->pgn, output::kPgnVehiclePosition);
  EXPECT_EQ(ack->requester, kTester);
  // After a pose: the request (global this time) gets the pose's 65267 frame again.
  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  const auto frames = encoder.encode(one_pose());
  ASSERT_TRUE(publish(*node, frames).has_value());
  ASSERT_TRUE(wait_until([&] { return acks_and_positions().size() == 2; }));
  bus.inject(output::encode_request(output::kPgnVehiclePosition, kTester, output::kJ1939GlobalAddress));
  ASSERT_TRUE(wait_until([&] { return acks_and_positions().size() == 3; }));
  const auto got = acks_and_positions();
  const CanFrame vp = output::encode_j1939_vehicle_position(48.137, 11.575, kPreferred);
  EXPECT_EQ(got[1], vp);
  EXPECT_EQ(got[2], vp);
  EXPECT_EQ(node->stats().node.requests_answered, 1u);
  EXPECT_EQ(node->stats().node.requests_refused, 1u);
}

}  // namespace
}  // namespace sitepose::drivers::socketcan
