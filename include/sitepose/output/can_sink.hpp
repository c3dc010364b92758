#pragma once
// Where encoded CAN frames go. One interface, three sinks:
//  * CandumpSink on a file (`candump -L` log, candump.hpp), appended, or on stdout;
//  * CanFrameFdSink: writes one Linux `struct can_frame` per write() to a file
//    descriptor - a bound SocketCAN raw socket in the daemon (opened by the
//    drivers layer), a socketpair(AF_UNIX, SOCK_SEQPACKET) end in tests
//    (PLATFORM.md: no AF_CAN on CI).
// Threads: a sink is used by one publishing thread; counters() may be read
// by another (health export). Errors are returned per call and counted; the
// caller decides whether to retry (the frames are values it still holds).

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/io/line_file.hpp"
#include "sitepose/output/can_frame.hpp"

namespace sitepose::output {

struct CanSinkCounters {
  std::uint64_t frames_sent = 0;
  std::uint64_t send_errors = 0;
};

class CanSink {
 public:
  virtual ~CanSink() = default;
  // Sends one frame stamped t_ns (ns since the Unix epoch). Counts success
  // and failure.
  Status send(std::int64_t t_ns, const CanFrame& frame) {
    Status st = do_send(t_ns, frame);
    (st ? frames_sent_ : send_errors_).fetch_add(1, std::memory_order_relaxed);
    return st;
  }
  // Pushes buffered frames out (call once per published pose, so a stop
  // loses no complete line).
  virtual Status flush() = 0;
  CanSinkCounters counters() const {
    return {frames_sent_.load(std::memory_order_relaxed),
            send_errors_.load(std::memory_order_relaxed)};
  }

 protected:
  virtual Status do_send(std::int64_t t_ns, const CanFrame& frame) = 0;

 private:
  std::atomic<std::uint64_t> frames_sent_{0};
  std::atomic<std::uint64_t> send_errors_{0};
};

// candump log lines, one write() a frame (io::LineFile): a frame counts as
// sent only once its whole line is with the OS; a failed write leaves no
// partial line, so a resend never duplicates or splices a frame.
class CandumpSink final : public CanSink {
 public:
  // Creates `path` or appends to it (a log is never truncated: a restart
  // keeps the frames before it). Fails (kIoError) naming the path and errno.
  static Expected<std::unique_ptr<CandumpSink>> open_file(const std::string& path,
                                                          const std::string& interface);
  // Lines on stdout (not closed on destruction).
  static std::unique_ptr<CandumpSink> make_stdout(const std::string& interface);

  // Lines are unbuffered: nothing to flush.
  Status flush() override { return ok_status(); }

 protected:
  Status do_send(std::int64_t t_ns, const CanFrame& frame) override;

 private:
  CandumpSink(io::LineFile file, std::string interface);
  io::LineFile file_;
  std::string interface_;
};

// struct can_frame datagrams on a socket descriptor (SocketCAN frame layout:
// can_id with CAN_EFF_FLAG for 29-bit ids, can_dlc, 8 data bytes).
// Does not own `fd`: the caller closes it after the sink is gone.
class CanFrameFdSink final : public CanSink {
 public:
  explicit CanFrameFdSink(int fd) : fd_(fd) {}
  // Frames are unbuffered: nothing to flush.
  Status flush() override { return ok_status(); }

 protected:
  // One send() of sizeof(struct can_frame) (so `fd` must be a socket);
  // retried on EINTR only. EAGAIN / ENOBUFS (a full transmit queue), EPIPE (peer
  // gone, no SIGPIPE raised) and other errors return kIoError with the errno
  // text; a short write is an error too.
  Status do_send(std::int64_t t_ns, const CanFrame& frame) override;

 private:
  int fd_;
};

// Reads one struct can_frame datagram from `fd` (blocking per the fd's mode):
// the receiving side of CanFrameFdSink, for tests and monitors. Fails on
// EOF, a short datagram, or a frame with the error/RTR flag set.
Expected<CanFrame> read_can_frame_fd(int fd);

}  // namespace sitepose::output
