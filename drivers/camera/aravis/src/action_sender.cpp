#include "sitepose/drivers/aravis/action_sender.hpp"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace sitepose::drivers::aravis {
namespace {

using Clock = std::chrono::steady_clock;

Unexpected socket_error(const std::string& what) {
  return make_error(ErrorCode::kIoError, what + ": " + std::strerror(errno));
}

Expected<in_addr> parse_ipv4(const std::string& text) {
  in_addr address{};
  if (inet_pton(AF_INET, text.c_str(), &address) != 1) {
    return make_error(ErrorCode::kInvalidArgument, "\"" + text + "\" is not a dotted IPv4 address");
  }
  return address;
}

class UdpPort final : public DatagramPort {
 public:
  UdpPort(int fd, sockaddr_in destination) : fd_(fd), destination_(destination) {}
  ~UdpPort() override { ::close(fd_); }
  UdpPort(const UdpPort&) = delete;
  UdpPort& operator=(const UdpPort&) = delete;

  Status send(std::span<const std::uint8_t> datagram) override {
    const ssize_t n = ::sendto(fd_, datagram.data(), datagram.size(), 0,
                               reinterpret_cast<const sockaddr*>(&destination_), sizeof(destination_));
    if (n < 0) return socket_error("sendto " + describe());
    return ok_status();
  }

  Expected<std::optional<std::vector<std::uint8_t>>> receive(std::chrono::microseconds timeout) override {
    pollfd p{fd_, POLLIN, 0};
    // Rounded up: a timeout under a millisecond still waits for a datagram.
    const auto timeout_ms = static_cast<int>((timeout.count() + 999) / 1000);
    const int ready = ::poll(&p, 1, timeout_ms);
    if (ready < 0 && errno != EINTR) return socket_error("poll");
    if (ready <= 0) return std::optional<std::vector<std::uint8_t>>{};
    std::vector<std::uint8_t> buffer(576);  // GVCP messages are far smaller
    const ssize_t n = ::recv(fd_, buffer.data(), buffer.size(), 0);
    if (n < 0) return socket_error("recv");
    buffer.resize(static_cast<std::size_t>(n));
    return std::optional<std::vector<std::uint8_t>>{std::move(buffer)};
  }

 private:
  std::string describe() const {
    char text[INET_ADDRSTRLEN] = {};
    inet_ntop(AF_INET, &destination_.sin_addr, text, sizeof(text));
    return std::string(text) + ":" + std::to_string(ntohs(destination_.sin_port));
  }

  int fd_;
  sockaddr_in destination_;
};

Expected<std::unique_ptr<DatagramPort>> open_udp_port(const std::string& address_ipv4, std::uint16_t port) {
  SITEPOSE_TRY(const in_addr address, parse_ipv4(address_ipv4));
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return socket_error("socket");
  const int on = 1;
  sockaddr_in local{};
  local.sin_family = AF_INET;
  local.sin_addr.s_addr = htonl(INADDR_ANY);
  if (::setsockopt(fd, SOL_SOCKET, SO_BROADCAST, &on, sizeof(on)) != 0 ||
      ::bind(fd, reinterpret_cast<const sockaddr*>(&local), sizeof(local)) != 0) {
    Unexpected error = socket_error("UDP socket for " + address_ipv4);
    ::close(fd);
    return error;
  }
  sockaddr_in destination{};
  destination.sin_family = AF_INET;
  destination.sin_addr = address;
  destination.sin_port = htons(port);
  return std::unique_ptr<DatagramPort>(new UdpPort(fd, destination));
}

}  // namespace

bool is_dotted_ipv4(const std::string& text) { return parse_ipv4(text).has_value(); }

DatagramPortOpener udp_port_opener() { return &open_udp_port; }

Expected<std::string> subnet_broadcast_of(const std::string& interface_ipv4) {
  SITEPOSE_TRY(const in_addr wanted, parse_ipv4(interface_ipv4));
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return socket_error("getifaddrs");
  std::optional<std::string> found;
  std::string name;
  for (const ifaddrs* i = list; i != nullptr; i = i->ifa_next) {
    if (i->ifa_addr == nullptr || i->ifa_addr->sa_family != AF_INET) continue;
    const auto* address = reinterpret_cast<const sockaddr_in*>(i->ifa_addr);
    if (address->sin_addr.s_addr != wanted.s_addr) continue;
    name = i->ifa_name;
    if ((i->ifa_flags & IFF_BROADCAST) == 0 || i->ifa_broadaddr == nullptr) break;
    char text[INET_ADDRSTRLEN] = {};
    inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(i->ifa_broadaddr)->sin_addr, text, sizeof(text));
    found = text;
    break;
  }
  ::freeifaddrs(list);
  if (found) return *found;
  if (name.empty())
    return make_error(ErrorCode::kNotFound, "no network interface has the address " + interface_ipv4);
  return make_error(ErrorCode::kNotFound,
                    "interface " + name + " (" + interface_ipv4 + ") has no broadcast address");
}

Expected<ActionResult> ActionSender::send(const gvcp::ActionCommand& command, int expected_acks,
                                          std::chrono::microseconds timeout) {
  request_id_ = gvcp::next_request_id(request_id_);
  ActionResult result;
  result.request_id = request_id_;
  SITEPOSE_TRY_STATUS(port_->send(gvcp::encode_action_command({command, request_id_, true})));
  const Clock::time_point until = Clock::now() + timeout;
  while (result.acks + static_cast<int>(result.failures.size()) < expected_acks) {
    const auto left = std::chrono::duration_cast<std::chrono::microseconds>(until - Clock::now());
    if (left.count() <= 0) break;
    SITEPOSE_TRY(const auto datagram, port_->receive(left));
    if (!datagram) break;
    const auto ack = gvcp::decode_action_ack(*datagram);
    if (!ack || ack->ack_id != request_id_) {
      ++stray_;
      continue;
    }
    if (ack->status == gvcp::kStatusSuccess) {
      ++result.acks;
    } else {
      result.failures.push_back(ack->status);
    }
  }
  return result;
}

}  // namespace sitepose::drivers::aravis
