#include "sitepose/output/can_sink.hpp"

#include <linux/can.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "sitepose/output/candump.hpp"

namespace sitepose::output {

namespace {
std::string errno_text(int err) {
  return std::string(std::strerror(err)) + " (errno " + std::to_string(err) + ")";
}
}  // namespace

CandumpSink::CandumpSink(io::LineFile file, std::string interface)
    : file_(std::move(file)), interface_(std::move(interface)) {}

Expected<std::unique_ptr<CandumpSink>> CandumpSink::open_file(const std::string& path,
                                                              const std::string& interface) {
  auto file = io::LineFile::open(path, /*append=*/true);
  if (!file) return make_error(file.error().code, "candump log: " + file.error().message);
  return std::unique_ptr<CandumpSink>(new CandumpSink(std::move(*file), interface));
}

std::unique_ptr<CandumpSink> CandumpSink::make_stdout(const std::string& interface) {
  std::fflush(stdout);  // lines go to the descriptor: what stdio holds goes first
  return std::unique_ptr<CandumpSink>(
      new CandumpSink(io::LineFile::borrow(STDOUT_FILENO, "stdout"), interface));
}

Status CandumpSink::do_send(std::int64_t t_ns, const CanFrame& frame) {
  SITEPOSE_TRY(std::string line, format_candump_line(CandumpRecord{t_ns, interface_, frame}));
  line += '\n';
  if (auto st = file_.write(line); !st) {
    return make_error(ErrorCode::kIoError, "candump log " + st.error().message);
  }
  return ok_status();
}

Status CanFrameFdSink::do_send(std::int64_t /*t_ns: the kernel stamps frames itself*/,
                               const CanFrame& frame) {
  if (frame.dlc > CAN_MAX_DLEN) {
    return make_error(ErrorCode::kInvalidArgument,
                      "CAN frame dlc = " + std::to_string(frame.dlc) + ": must be 0..8");
  }
  struct can_frame cf;
  std::memset(&cf, 0, sizeof(cf));
  cf.can_id =
      frame.extended ? ((frame.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (frame.id & CAN_SFF_MASK);
  cf.can_dlc = frame.dlc;
  std::memcpy(cf.data, frame.data.data(), frame.dlc);
  for (;;) {
    // send(), not write(): MSG_NOSIGNAL turns a closed peer into EPIPE
    // instead of a SIGPIPE that would kill the daemon.
    const ssize_t n = ::send(fd_, &cf, sizeof(cf), MSG_NOSIGNAL);
    if (n == static_cast<ssize_t>(sizeof(cf))) return ok_status();
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      return make_error(ErrorCode::kIoError,
                        "CAN fd " + std::to_string(fd_) + ": write failed: " + errno_text(errno));
    }
    return make_error(ErrorCode::kIoError, "CAN fd " + std::to_string(fd_) + ": short write of " +
                                               std::to_string(n) + " of " +
                                               std::to_string(sizeof(cf)) + " bytes");
  }
}

Expected<CanFrame> read_can_frame_fd(int fd) {
  struct can_frame cf;
  ssize_t n;
  do {
    n = ::read(fd, &cf, sizeof(cf));
  } while (n < 0 && errno == EINTR);
  if (n < 0)
    return make_error(ErrorCode::kIoError,
                      "CAN fd " + std::to_string(fd) + ": read failed: " + errno_text(errno));
  if (n == 0)
    return make_error(ErrorCode::kIoError, "CAN fd " + std::to_string(fd) + ": end of stream");
  if (n != static_cast<ssize_t>(sizeof(cf))) {
    return make_error(ErrorCode::kParseError, "CAN fd " + std::to_string(fd) + ": datagram of " +
                                                  std::to_string(n) + " bytes, expected " +
                                                  std::to_string(sizeof(cf)));
  }
  if ((cf.can_id & (CAN_ERR_FLAG | CAN_RTR_FLAG)) != 0 || cf.can_dlc > CAN_MAX_DLEN) {
    return make_error(ErrorCode::kParseError,
                      "CAN fd " + std::to_string(fd) + ": error/remote frame or dlc > 8");
  }
  CanFrame f;
  f.extended = (cf.can_id & CAN_EFF_FLAG) != 0;
  f.id = cf.can_id & (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  f.dlc = cf.can_dlc;
  std::memcpy(f.data.data(), cf.data, f.dlc);
  return f;
}

}  // namespace sitepose::output
