// The SocketCAN sink on a real virtual CAN interface, vcan0, where the
// kernel has AF_CAN and the interface exists (set up with
// `ip link add dev vcan0 type vcan && ip link set up vcan0`). Skipped with
// the reason otherwise - as on CI, whose kernel has no AF_CAN (PLATFORM.md).

#include <gtest/gtest.h>
#include <linux/can/raw.h>
#include <sys/socket.h>
#include <unistd.h>

#include "can_test_support.hpp"
#include "sitepose/drivers/socketcan/socketcan_sink.hpp"
#include "sitepose/output/can_pose_encoder.hpp"
#include "sitepose/output/j1939.hpp"
#include "sitepose/output/j1939_network.hpp"

namespace sitepose::drivers::socketcan {
namespace {

using namespace std::chrono_literals;

constexpr char kInterface[] = "vcan0";

// A second raw socket on vcan0: sees what the sink sends (CAN_RAW_LOOPBACK
// is on by default) and talks to it.
class VcanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    RawSocketOptions o;
    o.interface = kInterface;
    o.error_frames = false;
    auto fd = open_raw_can_socket(o);
    if (!fd) {
      if (fd.error().code == ErrorCode::kUnsupported) {
        GTEST_SKIP() << "AF_CAN is missing from this kernel (" << fd.error().message << ")";
      }
      if (fd.error().code == ErrorCode::kNotFound) {
        GTEST_SKIP() << "no " << kInterface << " interface (" << fd.error().message
                     << "); create it: ip link add dev vcan0 type vcan && ip link set up vcan0";
      }
      FAIL() << fd.error().message;
    }
    monitor_ = *fd;
  }
  void TearDown() override {
    if (monitor_ >= 0) ::close(monitor_);
  }
  int monitor_ = -1;
};

TEST_F(VcanTest, ClaimsSendsPosesAndAnswersARequestOnVcan0) {
  SocketCanSinkOptions o;
  o.interface = kInterface;
  o.node.name.identity_number = 4242;
  o.node.preferred_address = 0x1C;
  o.node.heartbeat_interval_ns = 0;
  o.node.transmitted_pgns = output::transmitted_pgns(output::CanOutputOptions{});
  RawSocketOptions raw;
  raw.interface = kInterface;
  auto sink = SocketCanSink::open(o, raw_can_socket_ops(raw));
  ASSERT_TRUE(sink.has_value()) << sink.error().message;
  // The monitor's filter passes Address Claimed and Requests only.
  auto claim = testing::read_until(monitor_, [](const output::CanFrame& f) {
    return output::parse_address_claimed(f).has_value();
  });
  ASSERT_TRUE(claim);
  EXPECT_EQ(claim->id & 0xFF, 0x1Cu);
  ASSERT_TRUE(testing::wait_until([&] { return (*sink)->stats().state == CanLinkState::kUp; }));
  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  output::CanPoseInputs in;
  in.latitude_deg = 48.137;
  in.longitude_deg = 11.575;
  in.quality.state = TrackingState::kOk;
  for (const auto& f : encoder.encode(in)) ASSERT_TRUE((*sink)->send(0, f).has_value());
  ASSERT_TRUE((*sink)->flush().has_value());
  ASSERT_TRUE(testing::wait_until([&] { return (*sink)->stats().poses_sent == 1; }));
  // A Request for 65267 from address 0x80: the monitor widens its filter to
  // see the answer.
  ::setsockopt(monitor_, SOL_CAN_RAW, CAN_RAW_FILTER, nullptr, 0);
  ASSERT_TRUE(testing::write_frame(
      monitor_, to_can_frame(output::encode_request(output::kPgnVehiclePosition, 0x80, 0x1C))));
  auto answer = testing::read_until(monitor_, [](const output::CanFrame& f) {
    return output::split_j1939_id(f.id).pgn == output::kPgnVehiclePosition;
  });
  ASSERT_TRUE(answer);
  EXPECT_EQ(*answer, output::encode_j1939_vehicle_position(48.137, 11.575, 0x1C));
  (*sink)->close();
  EXPECT_EQ((*sink)->stats().tx_full + (*sink)->stats().write_errors, 0u);
}

}  // namespace
}  // namespace sitepose::drivers::socketcan
