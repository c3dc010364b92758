#pragma once
// output::CanSink on a raw SocketCAN socket, with the J1939 / NMEA 2000 node
// (output::J1939Node: address claim, Requests, heartbeat) running on it.
//
// Threads: the publishing thread calls send() / flush() (one pose = the
// frames sent between two flushes); an I/O thread of the sink owns the
// socket and the node: it writes without blocking, reads Address Claimed,
// Requests and error frames, and keeps the timers. stats() may be read from
// any thread.
//
// Nothing is lost silently. flush() admits a pose whole into a bounded queue
// or refuses it with an error naming the reason (address claim in progress,
// lost address, bus-off, interface down or gone, queue full); the caller may
// flush again (a retry) or start the next pose, which abandons it. Every pose
// ends in exactly one counter:
//   poses_submitted = poses_sent + poses_refused + poses_dropped (+ queued)
// where poses_dropped were admitted and then discarded whole (the link
// failed, or the sink closed before they went out) - partially_sent of them
// had frames on the bus already.
//
// Faults (each counted, logged once per event, and recovered from):
//  * transmit queue full (ENOBUFS from the qdisc, EAGAIN from the socket):
//    the frame stays queued and is retried after a back-off (doubling from
//    backoff_min to backoff_max) or when the socket is writable again;
//  * bus-off (error frame): the queue is dropped, poses are refused until the
//    controller reports it restarted (error frame), then the address is
//    claimed again;
//  * interface down (ENETDOWN): as bus-off, but probed with an Address
//    Claimed frame after each back-off until a write succeeds;
//  * interface gone (ENODEV, ENXIO, EPIPE, EBADF, end of stream): the socket
//    is closed and opened again after each back-off.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "sitepose/drivers/socketcan/can_socket.hpp"
#include "sitepose/drivers/socketcan/tx_queue.hpp"
#include "sitepose/output/can_sink.hpp"
#include "sitepose/output/j1939_node.hpp"

namespace sitepose::drivers::socketcan {

struct SocketCanSinkOptions {
  std::string interface = "can0";            // for messages (the ops open the socket)
  std::size_t queue_frames = 64;             // about 5 poses of the full frame set
  output::J1939NodeOptions node;
  std::int64_t backoff_min_ns = 1'000'000;      // 1 ms
  std::int64_t backoff_max_ns = 1'000'000'000;  // 1 s
  std::int64_t close_drain_ns = 200'000'000;    // close(): time to send what is queued
};

// Fails naming the field (queue size 13..65536, back-off ordered and
// positive, node options).
Status check_socketcan_sink_options(const SocketCanSinkOptions& options);

enum class CanLinkState {
  kClaiming,     // address claim settling: poses refused
  kUp,           // poses flow
  kCannotClaim,  // lost the address contest without a free address: silent
  kBusOff,       // controller bus-off: waiting for its restart
  kDown,         // interface down: probing
  kGone,         // no socket: reopening
  kClosed,       // close() was called
};
const char* to_string(CanLinkState state);

struct SocketCanStats {
  CanLinkState state = CanLinkState::kGone;
  std::uint8_t source_address = output::kJ1939NullAddress;  // claimed / claiming
  // Poses (flushes).
  std::uint64_t poses_submitted = 0;
  std::uint64_t poses_sent = 0;
  std::uint64_t poses_refused = 0;
  std::uint64_t poses_dropped = 0;
  std::uint64_t poses_partially_sent = 0;  // part of poses_dropped
  std::uint64_t poses_queued = 0;
  std::uint64_t flush_refusals = 0;  // refused flush() calls, retries included
  // Frames.
  std::uint64_t frames_written = 0;       // pose frames and the node's frames
  std::uint64_t frames_dropped = 0;       // pose frames never written
  std::uint64_t frames_received = 0;      // data frames handed to the node
  std::uint64_t error_frames = 0;
  // Faults and recoveries.
  std::uint64_t tx_full = 0;  // ENOBUFS / EAGAIN
  std::uint64_t write_errors = 0;  // any other errno
  std::uint64_t bus_off = 0;
  std::uint64_t error_passive = 0;
  std::uint64_t link_down = 0;
  std::uint64_t link_gone = 0;
  std::uint64_t reopen_failures = 0;
  std::uint64_t recoveries = 0;
  output::J1939NodeCounters node;
  std::string last_error;  // the most recent fault, for the health message
};
// One line for logs and the health report, e.g.
// "can0 up sa=28 poses sent=900 refused=3 dropped=1 queued=0 tx_full=12 bus_off=1 ...".
std::string format_stats(const std::string& interface, const SocketCanStats& stats);

class SocketCanSink final : public output::CanSink {
 public:
  // Opens the socket (ops.open) and starts the I/O thread, which claims the
  // address. Fails when the options are invalid or the first open fails
  // (the daemon then does not start: no CAN support, no such interface).
  static Expected<std::unique_ptr<SocketCanSink>> open(const SocketCanSinkOptions& options,
                                                       CanSocketOps ops);
  ~SocketCanSink() override;
  SocketCanSink(const SocketCanSink&) = delete;
  SocketCanSink& operator=(const SocketCanSink&) = delete;

  // Admits the frames sent since the last flush as one pose, or refuses it
  // (kIoError naming the interface and the reason).
  Status flush() override;
  // Sends what is queued for up to close_drain_ns, drops and counts the
  // rest, stops the I/O thread and closes the socket. Stats are final after
  // it. Idempotent; the destructor calls it.
  void close();

  SocketCanStats stats() const;

 protected:
  // Adds the frame to the pose being built (nothing is written yet).
  Status do_send(std::int64_t t_ns, const output::CanFrame& frame) override;

 private:
  class Io;
  explicit SocketCanSink(SocketCanSinkOptions options);

  SocketCanSinkOptions options_;
  std::unique_ptr<Io> io_;
  // The pose being built by the publishing thread.
  std::vector<output::CanFrame> pending_;
  bool pending_refused_ = false;  // flushed and refused at least once
  bool closed_ = false;
};

}  // namespace sitepose::drivers::socketcan
