#include "sitepose/drivers/socketcan/can_socket.hpp"

#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <memory>

namespace sitepose::drivers::socketcan {

namespace {

std::string errno_text(int err) {
  return std::string(std::strerror(err)) + " (errno " + std::to_string(err) + ")";
}

// J1939 PDU format byte plus the data page bits: matches every PGN 0xEE00 /
// 0xEA00 frame whatever its priority, destination and source.
constexpr canid_t kPduFormatMask = CAN_EFF_FLAG | CAN_RTR_FLAG | 0x03FF0000U;

ssize_t send_frame(int fd, const struct can_frame& frame) {
  ssize_t n;
  do {
    n = ::send(fd, &frame, sizeof(frame), MSG_DONTWAIT | MSG_NOSIGNAL);
  } while (n < 0 && errno == EINTR);
  if (n >= 0 && n != static_cast<ssize_t>(sizeof(frame))) {
    errno = EMSGSIZE;
    return -1;
  }
  return n;
}

ssize_t recv_frame(int fd, struct can_frame& frame) {
  ssize_t n;
  do {
    n = ::recv(fd, &frame, sizeof(frame), MSG_DONTWAIT);
  } while (n < 0 && errno == EINTR);
  if (n == 0) {  // a stream peer that closed: the link is gone
    errno = ENODEV;
    return -1;
  }
  if (n > 0 && n != static_cast<ssize_t>(sizeof(frame))) {
    errno = EMSGSIZE;
    return -1;
  }
  return n;
}

}  // namespace

Expected<int> open_raw_can_socket(const RawSocketOptions& options) {
  const std::string& name = options.interface;
  if (name.empty() || name.size() >= IFNAMSIZ) {
    return make_error(ErrorCode::kInvalidArgument,
                      "SocketCAN interface name '" + name + "': must be 1.." +
                          std::to_string(IFNAMSIZ - 1) + " characters");
  }
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int err = errno;
    const bool no_can = err == EAFNOSUPPORT || err == EPROTONOSUPPORT;
    return make_error(no_can ? ErrorCode::kUnsupported : ErrorCode::kIoError,
                      "SocketCAN " + name + ": socket(PF_CAN, SOCK_RAW, CAN_RAW): " +
                          errno_text(err) +
                          (no_can ? "; the kernel has no CAN support (modules can, can_raw)" : ""));
  }
  auto fail = [&](ErrorCode code, const std::string& what) -> Unexpected {
    const int err = errno;
    ::close(fd);
    return make_error(code, "SocketCAN " + name + ": " + what + ": " + errno_text(err));
  };
  const unsigned index = ::if_nametoindex(name.c_str());
  if (index == 0) return fail(ErrorCode::kNotFound, "no such interface");
  const struct can_filter filters[] = {
      {CAN_EFF_FLAG | 0x00EE0000U, kPduFormatMask},  // Address Claimed, PGN 60928
      {CAN_EFF_FLAG | 0x00EA0000U, kPduFormatMask},  // Request, PGN 59904
  };
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters, sizeof(filters)) != 0) {
    return fail(ErrorCode::kIoError, "setsockopt(CAN_RAW_FILTER)");
  }
  const can_err_mask_t error_mask =
      options.error_frames ? (CAN_ERR_BUSOFF | CAN_ERR_RESTARTED | CAN_ERR_CRTL | CAN_ERR_TX_TIMEOUT)
                           : 0;
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &error_mask, sizeof(error_mask)) != 0) {
    return fail(ErrorCode::kIoError, "setsockopt(CAN_RAW_ERR_FILTER)");
  }
  struct sockaddr_can address;
  std::memset(&address, 0, sizeof(address));
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(index);
  if (::bind(fd, reinterpret_cast<struct sockaddr*>(&address), sizeof(address)) != 0) {
    return fail(ErrorCode::kIoError, "bind");
  }
  return fd;
}

CanSocketOps raw_can_socket_ops(const RawSocketOptions& options) {
  CanSocketOps ops;
  ops.open = [options] { return open_raw_can_socket(options); };
  ops.send = send_frame;
  ops.recv = recv_frame;
  ops.close = [](int fd) { ::close(fd); };
  return ops;
}

CanSocketOps fd_socket_ops(int fd) {
  CanSocketOps ops;
  auto handed_out = std::make_shared<bool>(false);
  ops.open = [fd, handed_out]() -> Expected<int> {
    if (*handed_out) {
      return make_error(ErrorCode::kNotFound, "CAN fd " + std::to_string(fd) + ": already closed");
    }
    *handed_out = true;
    return fd;
  };
  ops.send = send_frame;
  ops.recv = recv_frame;
  ops.close = [](int) {};  // the caller owns the descriptor
  return ops;
}

struct can_frame to_can_frame(const output::CanFrame& frame) {
  struct can_frame cf;
  std::memset(&cf, 0, sizeof(cf));
  cf.can_id = frame.extended ? ((frame.id & CAN_EFF_MASK) | CAN_EFF_FLAG)
                             : (frame.id & CAN_SFF_MASK);
  cf.can_dlc = frame.dlc > CAN_MAX_DLEN ? CAN_MAX_DLEN : frame.dlc;
  std::memcpy(cf.data, frame.data.data(), cf.can_dlc);
  return cf;
}

std::optional<output::CanFrame> from_can_frame(const struct can_frame& cf) {
  if ((cf.can_id & (CAN_ERR_FLAG | CAN_RTR_FLAG)) != 0 || cf.can_dlc > CAN_MAX_DLEN) {
    return std::nullopt;
  }
  output::CanFrame f;
  f.extended = (cf.can_id & CAN_EFF_FLAG) != 0;
  f.id = cf.can_id & (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  f.dlc = cf.can_dlc;
  std::memcpy(f.data.data(), cf.data, f.dlc);
  return f;
}

std::optional<ErrorFrameInfo> decode_error_frame(const struct can_frame& cf) {
  if ((cf.can_id & CAN_ERR_FLAG) == 0) return std::nullopt;
  const canid_t classes = cf.can_id & CAN_ERR_MASK;
  ErrorFrameInfo info;
  info.bus_off = (classes & CAN_ERR_BUSOFF) != 0;
  info.restarted = (classes & CAN_ERR_RESTARTED) != 0;
  info.tx_timeout = (classes & CAN_ERR_TX_TIMEOUT) != 0;
  if ((classes & CAN_ERR_CRTL) != 0) {
    const std::uint8_t crtl = cf.data[1];
    info.error_passive = (crtl & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    info.error_warning = (crtl & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0;
    info.back_to_active = (crtl & CAN_ERR_CRTL_ACTIVE) != 0;
  }
  return info;
}

struct can_frame make_error_frame(const ErrorFrameInfo& info) {
  struct can_frame cf;
  std::memset(&cf, 0, sizeof(cf));
  cf.can_id = CAN_ERR_FLAG;
  cf.can_dlc = CAN_ERR_DLC;
  if (info.bus_off) cf.can_id |= CAN_ERR_BUSOFF;
  if (info.restarted) cf.can_id |= CAN_ERR_RESTARTED;
  if (info.tx_timeout) cf.can_id |= CAN_ERR_TX_TIMEOUT;
  if (info.error_passive || info.error_warning || info.back_to_active) {
    cf.can_id |= CAN_ERR_CRTL;
    if (info.error_passive) cf.data[1] |= CAN_ERR_CRTL_TX_PASSIVE;
    if (info.error_warning) cf.data[1] |= CAN_ERR_CRTL_TX_WARNING;
    if (info.back_to_active) cf.data[1] |= CAN_ERR_CRTL_ACTIVE;
  }
  return cf;
}

}  // namespace sitepose::drivers::socketcan
