#pragma once
// Sends GigE Vision action commands (gvcp_action.hpp) and collects the
// cameras' acknowledgements. Aravis 0.8 has no action command API, so this
// speaks GVCP on a UDP socket of its own.
// The socket is behind a seam (DatagramPort): tests replace it to deliver
// commands to scripted cameras, or use the real one against a responder on
// 127.0.0.1.
// Threads: a sender and its port are used by one thread.

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/drivers/aravis/gvcp_action.hpp"

namespace sitepose::drivers::aravis {

// One UDP socket with a fixed destination (unicast or broadcast).
class DatagramPort {
 public:
  virtual ~DatagramPort() = default;
  virtual Status send(std::span<const std::uint8_t> datagram) = 0;
  // The next datagram that arrives within `timeout`; nullopt when none did.
  virtual Expected<std::optional<std::vector<std::uint8_t>>> receive(std::chrono::microseconds timeout) = 0;
};

// Opens a port to address_ipv4:port (dotted IPv4). kInvalidArgument for an
// address that is not one, kIoError when the socket fails.
using DatagramPortOpener = std::function<Expected<std::unique_ptr<DatagramPort>>(
    const std::string& address_ipv4, std::uint16_t port)>;

// Whether `text` is a dotted IPv4 address ("192.168.10.255").
bool is_dotted_ipv4(const std::string& text);

// The UDP socket: bound to an ephemeral port on any address, broadcast
// allowed (SO_BROADCAST), so the acks come back to it.
DatagramPortOpener udp_port_opener();

// The broadcast address of the host interface that has `interface_ipv4`
// (getifaddrs): where one datagram reaches every camera on that NIC. A
// limited broadcast (255.255.255.255) would leave by the default route's
// interface instead. kNotFound when no interface has the address or it has
// no broadcast address.
Expected<std::string> subnet_broadcast_of(const std::string& interface_ipv4);

struct ActionResult {
  std::uint16_t request_id = 0;
  int acks = 0;                         // SUCCESS acknowledgements
  std::vector<std::uint16_t> failures;  // the other acknowledgements' statuses
};

class ActionSender {
 public:
  explicit ActionSender(std::unique_ptr<DatagramPort> port) : port_(std::move(port)) {}

  // Sends one ACTION_CMD (acknowledge required) and collects the
  // ACTION_ACKs that answer it until `expected_acks` came (SUCCESS or not)
  // or `timeout` passed; fewer acks are not an error (the result says how
  // many). Late acks of earlier requests and other datagrams are skipped
  // (stray()). Errors: the socket's.
  Expected<ActionResult> send(const gvcp::ActionCommand& command, int expected_acks,
                              std::chrono::microseconds timeout);

  // Datagrams received that did not answer the request being collected.
  std::uint64_t stray() const { return stray_; }

 private:
  std::unique_ptr<DatagramPort> port_;
  std::uint16_t request_id_ = 0;  // the last one sent; 0 before the first
  std::uint64_t stray_ = 0;
};

}  // namespace sitepose::drivers::aravis
