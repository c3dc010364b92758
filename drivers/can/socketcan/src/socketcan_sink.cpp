#include "sitepose/drivers/socketcan/socketcan_sink.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>

#include <spdlog/spdlog.h>

namespace sitepose::drivers::socketcan {

namespace {

using output::CanFrame;

constexpr std::int64_t kNsPerMs = 1'000'000;
constexpr std::int64_t kMaxPollNs = 1'000'000'000;
constexpr int kMaxReadsPerStep = 256;
constexpr std::size_t kMinQueueFrames = 13;  // one pose of the full frame set
constexpr std::size_t kMaxQueueFrames = 65536;

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::string errno_text(int err) {
  return std::string(std::strerror(err)) + " (errno " + std::to_string(err) + ")";
}

enum class ErrnoKind { kTxFull, kDown, kGone, kOther };

ErrnoKind classify(int err) {
  switch (err) {
    case ENOBUFS:
    case EAGAIN:
#if EWOULDBLOCK != EAGAIN
    case EWOULDBLOCK:
#endif
      return ErrnoKind::kTxFull;
    case ENETDOWN:
    case ENETUNREACH: return ErrnoKind::kDown;
    case ENODEV:
    case ENXIO:
    case EPIPE:
    case EBADF:
    case ECONNRESET:
    case ENOTCONN: return ErrnoKind::kGone;
    default: return ErrnoKind::kOther;
  }
}

CanFrame with_source_address(CanFrame f, std::uint8_t source_address) {
  f.id = (f.id & ~std::uint32_t{0xFF}) | source_address;
  return f;
}

// Why a pose is refused in a state other than kUp.
const char* refusal_reason(CanLinkState state) {
  switch (state) {
    case CanLinkState::kClaiming: return "J1939 address claim in progress";
    case CanLinkState::kCannotClaim: return "no J1939 address (lost the claim, Cannot Claim sent)";
    case CanLinkState::kBusOff: return "controller bus-off";
    case CanLinkState::kDown: return "interface down";
    case CanLinkState::kGone: return "interface gone";
    case CanLinkState::kClosed: return "sink closed";
    case CanLinkState::kUp: break;
  }
  return "up";
}

struct LogLine {
  spdlog::level::level_enum level;
  std::string text;
};

}  // namespace

const char* to_string(CanLinkState state) {
  switch (state) {
    case CanLinkState::kClaiming: return "claiming";
    case CanLinkState::kUp: return "up";
    case CanLinkState::kCannotClaim: return "cannot-claim";
    case CanLinkState::kBusOff: return "bus-off";
    case CanLinkState::kDown: return "down";
    case CanLinkState::kGone: return "gone";
    case CanLinkState::kClosed: return "closed";
  }
  return "?";
}

Status check_socketcan_sink_options(const SocketCanSinkOptions& o) {
  if (o.queue_frames < kMinQueueFrames || o.queue_frames > kMaxQueueFrames) {
    return make_error(ErrorCode::kInvalidArgument, "SocketCAN queue = " + std::to_string(o.queue_frames) +
                                                       " frames: must be 13..65536 (one pose has up to 13)");
  }
  if (o.backoff_min_ns <= 0 || o.backoff_max_ns < o.backoff_min_ns) {
    return make_error(ErrorCode::kInvalidArgument,
                      "SocketCAN back-off: minimum must be > 0 and at most the maximum");
  }
  if (o.close_drain_ns < 0) {
    return make_error(ErrorCode::kInvalidArgument, "SocketCAN close drain time must be >= 0");
  }
  return output::check_j1939_node_options(o.node);
}

std::string format_stats(const std::string& interface, const SocketCanStats& s) {
  return interface + " " + to_string(s.state) + " sa=" + std::to_string(s.source_address) +
         " poses submitted=" + std::to_string(s.poses_submitted) + " sent=" + std::to_string(s.poses_sent) +
         " refused=" + std::to_string(s.poses_refused) + " dropped=" + std::to_string(s.poses_dropped) +
         " (partial " + std::to_string(s.poses_partially_sent) + ")" +
         " queued=" + std::to_string(s.poses_queued) + " frames written=" + std::to_string(s.frames_written) +
         " tx_full=" + std::to_string(s.tx_full) + " write_errors=" + std::to_string(s.write_errors) +
         " bus_off=" + std::to_string(s.bus_off) + " error_passive=" + std::to_string(s.error_passive) +
         " down=" + std::to_string(s.link_down) + " gone=" + std::to_string(s.link_gone) +
         " recoveries=" + std::to_string(s.recoveries) +
         " claims lost=" + std::to_string(s.node.contests_lost) +
         " requests answered=" + std::to_string(s.node.requests_answered) +
         (s.last_error.empty() ? "" : " last error: " + s.last_error);
}

// The I/O thread and everything it shares with the publishing thread. One
// mutex guards all of it; the thread holds it for one service step (reads,
// timers, non-blocking writes) and never while it waits in poll().
class SocketCanSink::Io {
 public:
  Io(const SocketCanSinkOptions& options, CanSocketOps ops, int fd, int event_fd)
      : options_(options),
        ops_(std::move(ops)),
        queue_(options.queue_frames),
        node_(options.node),
        fd_(fd),
        event_fd_(event_fd),
        tx_backoff_ns_(options.backoff_min_ns),
        probe_backoff_ns_(options.backoff_min_ns) {
    node_.start(now_ns());
    thread_ = std::thread([this] { run(); });
  }

  ~Io() {
    stop();
    ::close(event_fd_);
  }

  Status admit(std::vector<CanFrame>& frames, bool first_attempt) {
    std::lock_guard lock(mutex_);
    if (first_attempt) ++stats_.poses_submitted;
    const CanLinkState state = state_locked();
    std::string reason;
    if (stopping_) {
      reason = refusal_reason(CanLinkState::kClosed);
    } else if (state != CanLinkState::kUp) {
      reason = refusal_reason(state);
    } else if (!queue_.fits(frames.size())) {
      reason = "transmit queue full (" + std::to_string(queue_.frames()) + " of " +
               std::to_string(queue_.capacity_frames()) + " frames waiting)";
    }
    if (!reason.empty()) {
      ++stats_.flush_refusals;
      return make_error(ErrorCode::kIoError,
                        "SocketCAN " + options_.interface + ": " + reason + "; pose not sent");
    }
    queue_.push(std::move(frames));
    wake();
    return ok_status();
  }

  void count_abandoned() {
    std::lock_guard lock(mutex_);
    ++stats_.poses_refused;
  }

  void stop() {
    {
      std::lock_guard lock(mutex_);
      if (!stopping_) {
        stopping_ = true;
        stop_deadline_ns_ = now_ns() + options_.close_drain_ns;
      }
      wake();
    }
    if (thread_.joinable()) thread_.join();
  }

  SocketCanStats stats() const {
    std::lock_guard lock(mutex_);
    SocketCanStats s = stats_;
    s.state = state_locked();
    s.source_address = node_.address();
    s.poses_queued = queue_.poses();
    s.node = node_.counters();
    return s;
  }

 private:
  enum class Fault { kNone, kBusOff, kDown, kGone };

  CanLinkState state_locked() const {
    if (closed_) return CanLinkState::kClosed;
    switch (fault_) {
      case Fault::kBusOff: return CanLinkState::kBusOff;
      case Fault::kDown: return CanLinkState::kDown;
      case Fault::kGone: return CanLinkState::kGone;
      case Fault::kNone: break;
    }
    switch (node_.state()) {
      case output::J1939AddressState::kClaimed: return CanLinkState::kUp;
      case output::J1939AddressState::kCannotClaim: return CanLinkState::kCannotClaim;
      default: return CanLinkState::kClaiming;
    }
  }

  void wake() {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = ::write(event_fd_, &one, sizeof(one));
  }

  void run() {
    for (;;) {
      std::vector<LogLine> logs;
      std::int64_t timeout_ns = 0;
      bool want_write = false;
      int fd = -1;
      {
        std::lock_guard lock(mutex_);
        const std::int64_t now = now_ns();
        if (stopping_ &&
            ((queue_.empty() && net_out_.empty()) || now >= stop_deadline_ns_ || fault_ != Fault::kNone)) {
          finish(logs);
          emit(logs);
          return;
        }
        service(now, logs);
        timeout_ns = next_wakeup_ns(now) - now;
        want_write = want_pollout_;
        fd = fd_;
      }
      emit(logs);
      wait(fd, want_write, timeout_ns);
    }
  }

  void wait(int fd, bool want_write, std::int64_t timeout_ns) {
    if (timeout_ns <= 0) return;
    struct pollfd fds[2] = {{fd, static_cast<short>(POLLIN | (want_write ? POLLOUT : 0)), 0},
                            {event_fd_, POLLIN, 0}};
    const auto timeout_ms = static_cast<int>((std::min(timeout_ns, kMaxPollNs) + kNsPerMs - 1) / kNsPerMs);
    if (::poll(fds, 2, timeout_ms) > 0 && (fds[1].revents & POLLIN) != 0) {
      std::uint64_t count;
      [[maybe_unused]] const ssize_t n = ::read(event_fd_, &count, sizeof(count));
    }
  }

  std::int64_t next_wakeup_ns(std::int64_t now) const {
    std::int64_t t = now + kMaxPollNs;
    if (fd_ >= 0) t = std::min(t, node_.next_deadline_ns());
    const bool pose_work = fault_ == Fault::kNone && node_.may_transmit() && !queue_.empty();
    if (!net_out_.empty() || pose_work) t = std::min(t, tx_retry_at_ns_);
    if (fault_ == Fault::kDown || fault_ == Fault::kGone) t = std::min(t, probe_at_ns_);
    if (stopping_) t = std::min(t, stop_deadline_ns_);
    return t;
  }

  // One step: reopen or probe a failed link, read, run the node's timers,
  // write what may be written.
  void service(std::int64_t now, std::vector<LogLine>& logs) {
    if (fd_ < 0) {
      if (now < probe_at_ns_) return;
      auto fd = ops_.open();
      if (!fd) {
        ++stats_.reopen_failures;
        stats_.last_error = fd.error().message;
        schedule_probe(now);
        return;
      }
      fd_ = *fd;
      recover(now, /*claim=*/true, logs);
    }
    read_all(now, logs);
    if (fd_ < 0) return;
    node_.on_time(now);
    for (CanFrame& f : node_.take_outgoing()) net_out_.push_back(f);
    if (fault_ == Fault::kDown && now >= probe_at_ns_) {
      // The probe is the claim the node makes anyway once the link is back
      // (a Cannot Claim when it has no address).
      node_.start(now);
      for (CanFrame& f : node_.take_outgoing()) net_out_.push_back(f);
      if (net_out_.empty()) {
        net_out_.push_back(output::encode_address_claimed(node_.name(), output::kJ1939NullAddress));
      }
    }
    write_all(now, logs);
  }

  void read_all(std::int64_t now, std::vector<LogLine>& logs) {
    for (int i = 0; i < kMaxReadsPerStep && fd_ >= 0; ++i) {
      struct can_frame cf;
      if (ops_.recv(fd_, cf) < 0) {
        const int err = errno;
        const ErrnoKind kind = classify(err);
        if (kind == ErrnoKind::kTxFull) return;  // EAGAIN: nothing more to read
        if (kind == ErrnoKind::kGone) {
          enter_fault(Fault::kGone, now, "receive: " + errno_text(err), logs);
        } else if (fault_ != Fault::kDown) {
          enter_fault(Fault::kDown, now, "receive: " + errno_text(err), logs);
        }
        return;
      }
      if (auto e = decode_error_frame(cf)) {
        on_error_frame(*e, now, logs);
      } else if (auto f = from_can_frame(cf)) {
        ++stats_.frames_received;
        if (fault_ == Fault::kNone) node_.on_frame(*f, now);
      }
    }
  }

  void on_error_frame(const ErrorFrameInfo& e, std::int64_t now, std::vector<LogLine>& logs) {
    ++stats_.error_frames;
    if (e.bus_off && fault_ != Fault::kBusOff) {
      enter_fault(Fault::kBusOff, now, "controller bus-off (error frame)", logs);
      return;
    }
    if ((e.restarted || e.back_to_active) && fault_ == Fault::kBusOff) {
      recover(now, /*claim=*/true, logs);
      return;
    }
    if (e.error_passive) {
      ++stats_.error_passive;
      node_.set_controller_state(output::N2kControllerState::kErrorPassive);
    } else if (e.back_to_active) {
      node_.set_controller_state(output::N2kControllerState::kErrorActive);
    }
  }

  void write_all(std::int64_t now, std::vector<LogLine>& logs) {
    while (fd_ >= 0 && now >= tx_retry_at_ns_) {
      const bool network = !net_out_.empty();
      if (!network && !(fault_ == Fault::kNone && node_.may_transmit() && !queue_.empty())) return;
      const CanFrame frame =
          network ? net_out_.front() : with_source_address(queue_.next_frame(), node_.address());
      if (ops_.send(fd_, to_can_frame(frame)) < 0) {
        on_write_error(errno, now, logs);
        return;
      }
      ++stats_.frames_written;
      tx_backoff_ns_ = options_.backoff_min_ns;
      want_pollout_ = false;
      if (network) {
        net_out_.pop_front();
        if (fault_ == Fault::kDown) recover(now, /*claim=*/false, logs);  // the probe went out
      } else if (auto done = queue_.frame_written()) {
        ++stats_.poses_sent;
        remember(*done);
      }
    }
  }

  void on_write_error(int err, std::int64_t now, std::vector<LogLine>& logs) {
    switch (classify(err)) {
      case ErrnoKind::kTxFull:
        ++stats_.tx_full;
        tx_retry_at_ns_ = now + tx_backoff_ns_;
        tx_backoff_ns_ = std::min(2 * tx_backoff_ns_, options_.backoff_max_ns);
        want_pollout_ = err != ENOBUFS;  // the qdisc does not report when it has room
        return;
      case ErrnoKind::kDown:
        if (fault_ == Fault::kDown) {  // a probe failed: still down
          net_out_.clear();
          node_.stop();
          schedule_probe(now);
        } else {
          enter_fault(Fault::kDown, now, "send: " + errno_text(err), logs);
        }
        return;
      case ErrnoKind::kGone: enter_fault(Fault::kGone, now, "send: " + errno_text(err), logs); return;
      case ErrnoKind::kOther:
        ++stats_.write_errors;
        enter_fault(Fault::kDown, now, "send: " + errno_text(err), logs);
        return;
    }
  }

  void schedule_probe(std::int64_t now) {
    probe_at_ns_ = now + probe_backoff_ns_;
    probe_backoff_ns_ = std::min(2 * probe_backoff_ns_, options_.backoff_max_ns);
  }

  // Drops what is queued (the link failed under it), silences the node.
  void enter_fault(Fault fault, std::int64_t now, const std::string& reason, std::vector<LogLine>& logs) {
    const PoseTxQueue::Dropped d = queue_.clear();
    stats_.poses_dropped += d.poses;
    stats_.poses_partially_sent += d.partially_sent;
    stats_.frames_dropped += d.frames;
    net_out_.clear();
    node_.stop();
    if (fault_ == Fault::kNone) fault_since_ns_ = now;
    fault_ = fault;
    probe_backoff_ns_ = options_.backoff_min_ns;
    schedule_probe(now);
    tx_retry_at_ns_ = 0;
    want_pollout_ = false;
    switch (fault) {
      case Fault::kBusOff:
        ++stats_.bus_off;
        node_.set_controller_state(output::N2kControllerState::kBusOff);
        break;
      case Fault::kDown: ++stats_.link_down; break;
      case Fault::kGone:
        ++stats_.link_gone;
        ops_.close(fd_);
        fd_ = -1;
        break;
      case Fault::kNone: break;
    }
    stats_.last_error = reason;
    logs.push_back({spdlog::level::warn, "SocketCAN " + options_.interface + ": " + reason + " -> " +
                                             to_string(state_locked()) + "; dropped " +
                                             std::to_string(d.poses) + " queued poses (" +
                                             std::to_string(d.partially_sent) +
                                             " partly sent); poses are refused until it recovers"});
  }

  void recover(std::int64_t now, bool claim, std::vector<LogLine>& logs) {
    const CanLinkState was = state_locked();
    fault_ = Fault::kNone;
    ++stats_.recoveries;
    probe_backoff_ns_ = options_.backoff_min_ns;
    node_.set_controller_state(output::N2kControllerState::kErrorActive);
    if (claim) node_.start(now);
    const double out_s = static_cast<double>(now - fault_since_ns_) * 1e-9;
    logs.push_back({spdlog::level::info, "SocketCAN " + options_.interface + ": recovered from " +
                                             to_string(was) + " after " + std::to_string(out_s) +
                                             " s; claiming address " + std::to_string(node_.address())});
  }

  // The pose's messages, by PGN, for answers to Requests.
  void remember(const std::vector<CanFrame>& frames) {
    std::size_t begin = 0;
    while (begin < frames.size()) {
      const std::uint32_t pgn = output::split_j1939_id(frames[begin].id).pgn;
      std::size_t end = begin + 1;
      while (end < frames.size() && output::split_j1939_id(frames[end].id).pgn == pgn) ++end;
      node_.remember_message(pgn, std::vector<CanFrame>(frames.begin() + begin, frames.begin() + end));
      begin = end;
    }
  }

  void finish(std::vector<LogLine>& logs) {
    const PoseTxQueue::Dropped d = queue_.clear();
    stats_.poses_dropped += d.poses;
    stats_.poses_partially_sent += d.partially_sent;
    stats_.frames_dropped += d.frames;
    if (d.poses > 0) {
      logs.push_back({spdlog::level::warn, "SocketCAN " + options_.interface + ": closed with " +
                                               std::to_string(d.poses) + " poses unsent"});
    }
    if (fd_ >= 0) ops_.close(fd_);
    fd_ = -1;
    node_.stop();
    closed_ = true;
  }

  static void emit(const std::vector<LogLine>& logs) {
    for (const LogLine& l : logs) spdlog::log(l.level, "{}", l.text);
  }

  const SocketCanSinkOptions options_;
  const CanSocketOps ops_;
  mutable std::mutex mutex_;
  // Guarded by mutex_.
  PoseTxQueue queue_;
  output::J1939Node node_;
  SocketCanStats stats_;
  Fault fault_ = Fault::kNone;
  bool stopping_ = false;
  bool closed_ = false;  // the thread has finished
  std::int64_t stop_deadline_ns_ = 0;
  int fd_;
  int event_fd_;
  std::deque<CanFrame> net_out_;  // the node's frames, sent before pose frames
  std::int64_t tx_retry_at_ns_ = 0;
  std::int64_t tx_backoff_ns_;
  std::int64_t probe_at_ns_ = 0;
  std::int64_t probe_backoff_ns_;
  std::int64_t fault_since_ns_ = 0;
  bool want_pollout_ = false;
  std::thread thread_;  // last: starts after everything above exists
};

Expected<std::unique_ptr<SocketCanSink>> SocketCanSink::open(const SocketCanSinkOptions& options,
                                                             CanSocketOps ops) {
  SITEPOSE_TRY_STATUS(check_socketcan_sink_options(options));
  SITEPOSE_TRY(const int fd, ops.open());
  const int event_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (event_fd < 0) {
    const int err = errno;
    ops.close(fd);
    return make_error(ErrorCode::kIoError,
                      "SocketCAN " + options.interface + ": eventfd: " + errno_text(err));
  }
  std::unique_ptr<SocketCanSink> sink(new SocketCanSink(options));
  sink->io_ = std::make_unique<Io>(options, std::move(ops), fd, event_fd);
  return sink;
}

SocketCanSink::SocketCanSink(SocketCanSinkOptions options) : options_(std::move(options)) {}

SocketCanSink::~SocketCanSink() { close(); }

Status SocketCanSink::do_send(std::int64_t /*t_ns: the kernel stamps frames*/, const CanFrame& frame) {
  if (pending_refused_) {  // the refused pose is abandoned for this new one
    io_->count_abandoned();
    pending_.clear();
    pending_refused_ = false;
  }
  if (frame.dlc > output::kCanMaxDataBytes) {
    return make_error(ErrorCode::kInvalidArgument,
                      "CAN frame dlc = " + std::to_string(frame.dlc) + ": must be 0..8");
  }
  pending_.push_back(frame);
  return ok_status();
}

Status SocketCanSink::flush() {
  if (pending_.empty()) return ok_status();
  if (closed_) {
    return make_error(ErrorCode::kIoError, "SocketCAN " + options_.interface + ": sink closed");
  }
  Status st = io_->admit(pending_, !pending_refused_);
  if (st) {
    pending_.clear();
    pending_refused_ = false;
  } else {
    pending_refused_ = true;
  }
  return st;
}

void SocketCanSink::close() {
  if (closed_) return;
  closed_ = true;
  if (pending_refused_) io_->count_abandoned();
  pending_.clear();
  pending_refused_ = false;
  io_->stop();
}

SocketCanStats SocketCanSink::stats() const { return io_->stats(); }

}  // namespace sitepose::drivers::socketcan
