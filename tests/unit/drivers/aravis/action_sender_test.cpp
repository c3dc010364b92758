// ActionSender over a real UDP socket against a fake GVCP responder on
// 127.0.0.1: a thread that decodes each ACTION_CMD and, for every camera it
// plays whose keys match (as a camera decides), sends an ACTION_ACK.
#include "sitepose/drivers/aravis/action_sender.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <mutex>
#include <thread>

namespace sitepose::drivers::aravis {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

struct PlayedCamera {
  std::uint32_t device_key = 0x5EC0;
  std::uint32_t group_key = 1;
  std::uint32_t group_mask = 0x1;
  std::uint16_t status = gvcp::kStatusSuccess;
  int extra_stale_acks = 0;  // acks of an older request sent first (a late answer)
};

class GvcpResponder {
 public:
  explicit GvcpResponder(std::vector<PlayedCamera> cameras) : cameras_(std::move(cameras)) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof(address);
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<const sockaddr*>(&address), size) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &size) != 0) {
      ADD_FAILURE() << "responder socket";
    }
    port_ = ntohs(address.sin_port);
    thread_ = std::jthread([this](const std::stop_token& stop) { serve(stop); });
  }
  ~GvcpResponder() {
    thread_.request_stop();
    thread_.join();
    ::close(fd_);
  }
  GvcpResponder(const GvcpResponder&) = delete;
  GvcpResponder& operator=(const GvcpResponder&) = delete;

  std::uint16_t port() const { return port_; }
  std::vector<gvcp::ActionPacket> received() {
    std::lock_guard lock(mutex_);
    return received_;
  }

 private:
  void serve(const std::stop_token& stop) {
    while (!stop.stop_requested()) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 10) <= 0) continue;
      std::uint8_t buffer[64];
      sockaddr_in from{};
      socklen_t from_size = sizeof(from);
      const ssize_t n =
          ::recvfrom(fd_, buffer, sizeof(buffer), 0, reinterpret_cast<sockaddr*>(&from), &from_size);
      if (n <= 0) continue;
      const auto packet = gvcp::decode_action_command(std::span<const std::uint8_t>(buffer, n));
      if (!packet) continue;  // a camera ignores what it cannot parse
      {
        std::lock_guard lock(mutex_);
        received_.push_back(*packet);
      }
      for (const PlayedCamera& c : cameras_) {
        if (!packet->ack_required ||
            !gvcp::action_matches(packet->command, c.device_key, c.group_key, c.group_mask))
          continue;
        for (int i = 0; i < c.extra_stale_acks; ++i) {
          reply(from, {gvcp::kStatusSuccess, static_cast<std::uint16_t>(packet->request_id + 100)});
        }
        reply(from, {c.status, packet->request_id});
      }
    }
  }
  void reply(const sockaddr_in& to, const gvcp::ActionAck& ack) {
    const auto bytes = gvcp::encode_action_ack(ack);
    ::sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof(to));
  }

  std::vector<PlayedCamera> cameras_;
  int fd_ = -1;
  std::uint16_t port_ = 0;
  std::mutex mutex_;
  std::vector<gvcp::ActionPacket> received_;
  std::jthread thread_;
};

ActionSender sender_to(const GvcpResponder& responder) {
  auto port = udp_port_opener()("127.0.0.1", responder.port());
  EXPECT_TRUE(port) << port.error().message;
  return ActionSender(std::move(*port));
}

gvcp::ActionCommand command(std::uint32_t group_mask, std::optional<std::uint64_t> at_ns) {
  return {0x5EC0, 1, group_mask, at_ns};
}

TEST(ActionSender, TwoCamerasAcknowledgeAScheduledAction) {
  GvcpResponder responder({{}, {.group_mask = 0x3}});
  ActionSender sender = sender_to(responder);
  for (std::uint16_t i = 1; i <= 3; ++i) {
    const auto result = sender.send(command(0x1, 1'000'000'000ULL * i), 2, 1s);
    ASSERT_TRUE(result) << result.error().message;
    EXPECT_EQ(result->acks, 2);
    EXPECT_TRUE(result->failures.empty());
    EXPECT_EQ(result->request_id, i);
  }
  const auto received = responder.received();
  ASSERT_EQ(received.size(), 3u);
  EXPECT_EQ(received[2].command.action_time_ns, 3'000'000'000ULL);
  EXPECT_EQ(received[2].request_id, 3);
  EXPECT_TRUE(received[2].ack_required);
}

TEST(ActionSender, ACameraOutsideTheGroupMaskStaysSilentAndTheWaitEndsAtTheTimeout) {
  GvcpResponder responder({{}, {.group_mask = 0x2}});
  ActionSender sender = sender_to(responder);
  const Clock::time_point start = Clock::now();
  const auto result = sender.send(command(0x1, std::nullopt), 2, 150ms);
  const auto elapsed = Clock::now() - start;
  ASSERT_TRUE(result) << result.error().message;
  EXPECT_EQ(result->acks, 1);
  EXPECT_GE(elapsed, 150ms);
  EXPECT_LT(elapsed, 2s);
}

TEST(ActionSender, ReportsRefusalsAndSkipsStaleAcks) {
  GvcpResponder responder({{.extra_stale_acks = 2}, {.status = gvcp::kStatusNoRefTime}});
  ActionSender sender = sender_to(responder);
  const auto result = sender.send(command(0x1, 42), 2, 1s);
  ASSERT_TRUE(result) << result.error().message;
  EXPECT_EQ(result->acks, 1);
  ASSERT_EQ(result->failures.size(), 1u);
  EXPECT_EQ(result->failures[0], gvcp::kStatusNoRefTime);
  EXPECT_EQ(sender.stray(), 2u);
}

TEST(ActionSender, RefusesAnAddressThatIsNotIpv4) {
  const auto port = udp_port_opener()("camera-nic", gvcp::kGvcpPort);
  ASSERT_FALSE(port);
  EXPECT_EQ(port.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(port.error().message.find("\"camera-nic\" is not a dotted IPv4 address"), std::string::npos);
}

TEST(ActionSender, LoopbackHasNoSubnetBroadcast) {
  // lo has no broadcast flag: naming it is better than a datagram that reaches no camera.
  const auto broadcast = subnet_broadcast_of("127.0.0.1");
  ASSERT_FALSE(broadcast);
  EXPECT_EQ(broadcast.error().code, ErrorCode::kNotFound);
  EXPECT_NE(broadcast.error().message.find("has no broadcast address"), std::string::npos)
      << broadcast.error().message;
  const auto nowhere = subnet_broadcast_of("192.0.2.77");  // TEST-NET-1: on no interface
  ASSERT_FALSE(nowhere);
  EXPECT_NE(nowhere.error().message.find("no network interface has the address 192.0.2.77"),
            std::string::npos);
}

}  // namespace
}  // namespace sitepose::drivers::aravis
