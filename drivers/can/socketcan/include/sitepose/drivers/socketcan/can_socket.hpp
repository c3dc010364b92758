#pragma once
// The raw CAN socket and the seam around it. SocketCanSink makes exactly
// these calls on its descriptor; tests replace them (a socketpair(AF_UNIX,
// SOCK_SEQPACKET) end carries one struct can_frame per datagram, and a
// wrapper injects errno values), since CI has no AF_CAN (PLATFORM.md).

#include <linux/can.h>
#include <sys/types.h>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/output/can_frame.hpp"

namespace sitepose::drivers::socketcan {

// Each call returns -1 and sets errno on failure, like the system call.
struct CanSocketOps {
  // A non-blocking descriptor carrying struct can_frame datagrams.
  std::function<Expected<int>()> open;
  std::function<ssize_t(int fd, const struct can_frame& frame)> send;
  std::function<ssize_t(int fd, struct can_frame& frame)> recv;
  std::function<void(int fd)> close;
};

struct RawSocketOptions {
  std::string interface = "can0";
  // Receive error frames (bus-off, restarted, error passive/active).
  bool error_frames = true;
};

// socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW), a receive
// filter for the J1939 network management PGNs (Address Claimed, Request),
// the error-frame mask, bound to the interface. Fails with kUnsupported when
// the kernel has no AF_CAN / CAN_RAW, kNotFound when the interface does not
// exist, kIoError otherwise; the message names the interface and the call.
Expected<int> open_raw_can_socket(const RawSocketOptions& options);

// The real calls: open_raw_can_socket, send(MSG_DONTWAIT | MSG_NOSIGNAL),
// recv(MSG_DONTWAIT), close. send/recv of anything but a whole frame sets
// errno EMSGSIZE.
CanSocketOps raw_can_socket_ops(const RawSocketOptions& options);

// The same calls on a descriptor the caller made (a socketpair end in
// tests); `open` hands out `fd` once and then fails with ENODEV.
CanSocketOps fd_socket_ops(int fd);

// CanFrame <-> struct can_frame (29-bit ids get CAN_EFF_FLAG).
struct can_frame to_can_frame(const output::CanFrame& frame);
// Data frames only: nullopt for error and remote frames and bad dlc.
std::optional<output::CanFrame> from_can_frame(const struct can_frame& frame);

// What an error frame (CAN_ERR_FLAG) says about the controller.
struct ErrorFrameInfo {
  bool bus_off = false;
  bool restarted = false;       // controller restarted after bus-off
  bool error_passive = false;   // rx or tx error counter reached 128
  bool error_warning = false;   // reached 96
  bool back_to_active = false;  // recovered to error active
  bool tx_timeout = false;
};
// nullopt when `frame` is not an error frame.
std::optional<ErrorFrameInfo> decode_error_frame(const struct can_frame& frame);
// An error frame as the kernel sends it (for tests and tools).
struct can_frame make_error_frame(const ErrorFrameInfo& info);

}  // namespace sitepose::drivers::socketcan
