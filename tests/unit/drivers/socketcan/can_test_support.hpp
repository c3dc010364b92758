#pragma once
// Test seams for the SocketCAN sink: socketpairs that carry struct
// can_frame datagrams, socket ops that inject errno values, a small virtual
// bus that joins several sinks, and waiting for a condition with a deadline.

#include <linux/can.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <random>
#include <thread>
#include <vector>

#include "sitepose/drivers/socketcan/can_socket.hpp"
#include "sitepose/output/j1939.hpp"
#include "sitepose/testing/wait.hpp"

namespace sitepose::drivers::socketcan::testing {

// sitepose::testing::wait_for with this suite's defaults: 5 s, polled
// every millisecond.
template <typename Pred>
bool wait_until(Pred pred, std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
  return sitepose::testing::wait_for(pred, timeout, std::chrono::milliseconds(1));
}

struct SocketPair {
  SocketPair() {
    if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0, fds) != 0) {
      fds[0] = fds[1] = -1;
    }
  }
  ~SocketPair() { close_all(); }
  void close_all() {
    for (int& fd : fds) {
      if (fd >= 0) ::close(fd);
      fd = -1;
    }
  }
  int sink() const { return fds[0]; }  // the sink's "CAN socket"
  int bus() const { return fds[1]; }   // the rest of the bus, as the test sees it
  int fds[2] = {-1, -1};
};

// One frame from `fd` within `timeout`, or nullopt.
inline std::optional<struct can_frame> read_frame(int fd, std::chrono::milliseconds timeout) {
  struct pollfd p = {fd, POLLIN, 0};
  if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return std::nullopt;
  struct can_frame cf;
  if (::recv(fd, &cf, sizeof(cf), MSG_DONTWAIT) != static_cast<ssize_t>(sizeof(cf))) {
    return std::nullopt;
  }
  return cf;
}

inline bool write_frame(int fd, const struct can_frame& cf) {
  return ::send(fd, &cf, sizeof(cf), MSG_NOSIGNAL) == static_cast<ssize_t>(sizeof(cf));
}

inline std::uint32_t pgn_of(const struct can_frame& cf) {
  return output::split_j1939_id(cf.can_id & CAN_EFF_MASK).pgn;
}

// Data frames from `fd` until `pred(frame)` holds for one (returned) or the
// timeout; every frame read is appended to `seen` when given.
inline std::optional<output::CanFrame> read_until(int fd,
                                                  const std::function<bool(const output::CanFrame&)>& pred,
                                                  std::chrono::milliseconds timeout = std::chrono::seconds(5),
                                                  std::vector<output::CanFrame>* seen = nullptr) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    auto cf = read_frame(fd, std::chrono::milliseconds(10));
    if (!cf) continue;
    auto f = from_can_frame(*cf);
    if (!f) continue;
    if (seen) seen->push_back(*f);
    if (pred(*f)) return f;
  }
  return std::nullopt;
}

// Reads every data frame arriving on `fd` on a thread of its own (as the
// rest of a bus would), so the sender's socket never fills.
class FrameCollector {
 public:
  explicit FrameCollector(int fd) : thread_([this, fd] { run(fd); }) {}
  ~FrameCollector() {
    stop_ = true;
    thread_.join();
  }
  std::vector<output::CanFrame> frames() const {
    std::lock_guard lock(mutex_);
    return frames_;
  }
  std::size_t count(const std::function<bool(const output::CanFrame&)>& pred) const {
    std::lock_guard lock(mutex_);
    return static_cast<std::size_t>(std::count_if(frames_.begin(), frames_.end(), pred));
  }

 private:
  void run(int fd) {
    while (!stop_) {
      auto cf = read_frame(fd, std::chrono::milliseconds(5));
      if (!cf) continue;
      if (auto f = from_can_frame(*cf)) {
        std::lock_guard lock(mutex_);
        frames_.push_back(*f);
      }
    }
  }
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::vector<output::CanFrame> frames_;
  std::thread thread_;  // last: starts after the members above exist
};

// errno values injected into the sink's send() calls: a persistent one
// (interface down, bus-off's full queue) and random transient ones.
class Faults {
 public:
  void set_persistent(int err) { persistent_.store(err); }
  void set_random(int err, double probability, unsigned seed) {
    std::lock_guard lock(mutex_);
    random_errno_ = err;
    probability_ = probability;
    rng_.seed(seed);
  }
  int next() {
    if (const int e = persistent_.load(); e != 0) {
      ++persistent_failures_;
      return e;
    }
    std::lock_guard lock(mutex_);
    if (probability_ > 0 && std::uniform_real_distribution<double>(0, 1)(rng_) < probability_) {
      ++injected_;
      return random_errno_;
    }
    return 0;
  }
  std::uint64_t injected() {
    std::lock_guard lock(mutex_);
    return injected_;
  }
  // Sends failed by set_persistent's errno so far.
  std::uint64_t persistent_failures() const { return persistent_failures_.load(); }

 private:
  std::atomic<int> persistent_{0};
  std::atomic<std::uint64_t> persistent_failures_{0};
  std::mutex mutex_;
  int random_errno_ = 0;
  double probability_ = 0;
  std::uint64_t injected_ = 0;
  std::mt19937 rng_;
};

// fd_socket_ops(fd) whose send() fails with what `faults` says first.
inline CanSocketOps faulty_ops(int fd, Faults& faults) {
  CanSocketOps ops = fd_socket_ops(fd);
  auto real_send = ops.send;
  ops.send = [&faults, real_send](int d, const struct can_frame& cf) -> ssize_t {
    if (const int e = faults.next(); e != 0) {
      errno = e;
      return -1;
    }
    return real_send(d, cf);
  };
  return ops;
}

// A CAN bus between sinks: each attach() returns the fd a sink uses; a
// thread forwards every frame to all other attached nodes and records it.
// inject() puts a frame on the bus from a test node that has no sink.
class VirtualBus {
 public:
  ~VirtualBus() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  int attach() {
    pairs_.emplace_back();
    return pairs_.back().sink();
  }
  void start() {
    thread_ = std::thread([this] { run(); });
  }
  void inject(const output::CanFrame& f) {
    std::lock_guard lock(mutex_);
    deliver(-1, to_can_frame(f));
  }
  // Frames on the bus so far, in bus order, with the index of the node that
  // sent each (-1: injected).
  std::vector<std::pair<int, output::CanFrame>> log() const {
    std::lock_guard lock(mutex_);
    return log_;
  }

 private:
  void run() {
    while (!stop_) {
      std::vector<struct pollfd> fds;
      for (const auto& p : pairs_) fds.push_back({p.bus(), POLLIN, 0});
      if (::poll(fds.data(), fds.size(), 5) <= 0) continue;
      for (std::size_t i = 0; i < fds.size(); ++i) {
        if ((fds[i].revents & POLLIN) == 0) continue;
        struct can_frame cf;
        while (::recv(pairs_[i].bus(), &cf, sizeof(cf), MSG_DONTWAIT) == static_cast<ssize_t>(sizeof(cf))) {
          std::lock_guard lock(mutex_);
          deliver(static_cast<int>(i), cf);
        }
      }
    }
  }
  void deliver(int from, const struct can_frame& cf) {
    if (auto f = from_can_frame(cf)) log_.emplace_back(from, *f);
    for (std::size_t j = 0; j < pairs_.size(); ++j) {
      if (static_cast<int>(j) != from) write_frame(pairs_[j].bus(), cf);
    }
  }

  std::deque<SocketPair> pairs_;  // deque: attach() keeps earlier ends in place
  std::thread thread_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::vector<std::pair<int, output::CanFrame>> log_;
};

}  // namespace sitepose::drivers::socketcan::testing
