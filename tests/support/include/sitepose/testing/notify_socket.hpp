#pragma once
// A systemd notify socket for tests: binds a datagram socket at a path and
// records every datagram that arrives (with its arrival time) on a reader
// thread, as systemd would receive sd_notify messages.

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <mutex>
#include <stop_token>
#include <string>
#include <thread>
#include <vector>

#include "sitepose/testing/wait.hpp"

namespace sitepose::testing {

class NotifySocket {
 public:
  struct Message {
    WaitClock::time_point t;
    std::string text;
  };

  explicit NotifySocket(const std::string& path) : path_(path) {
    fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    const bool fits = path.size() < sizeof(addr.sun_path);
    std::snprintf(addr.sun_path, sizeof(addr.sun_path), "%s", path.c_str());
    unlink(path.c_str());
    ok_ = fits && fd_ >= 0 && bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0;
    // recv returns every 100 ms so the reader sees a stop request.
    timeval tv{0, 100'000};
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
    reader_ = std::jthread([this](std::stop_token stop) {
      char buf[4096];
      while (!stop.stop_requested()) {
        const ssize_t n = recv(fd_, buf, sizeof(buf), 0);
        if (n <= 0) continue;
        std::lock_guard lock(mutex_);
        messages_.push_back({WaitClock::now(), std::string(buf, static_cast<std::size_t>(n))});
      }
    });
  }
  ~NotifySocket() {
    reader_ = {};
    if (fd_ >= 0) close(fd_);
    unlink(path_.c_str());
  }
  NotifySocket(const NotifySocket&) = delete;
  NotifySocket& operator=(const NotifySocket&) = delete;

  bool ok() const { return ok_; }
  const std::string& path() const { return path_; }

  // Every message so far, in arrival order.
  std::vector<Message> messages() {
    std::lock_guard lock(mutex_);
    return messages_;
  }
  // The messages so far containing `needle`.
  std::vector<Message> with(const std::string& needle) {
    std::vector<Message> out;
    for (auto& m : messages()) {
      if (m.text.find(needle) != std::string::npos) out.push_back(m);
    }
    return out;
  }
  // Waits up to `timeout` for a message containing `needle`.
  bool wait_for_message(const std::string& needle, WaitClock::duration timeout) {
    return wait_for([&] { return !with(needle).empty(); }, timeout);
  }
  // The oldest message that next() has not returned yet, waiting up to
  // `timeout` for it; empty when none came.
  std::string next(WaitClock::duration timeout = std::chrono::seconds(1)) {
    const auto arrived = [&] {
      std::lock_guard lock(mutex_);
      return messages_.size() > next_;
    };
    if (!wait_for(arrived, timeout)) return {};
    std::lock_guard lock(mutex_);
    return messages_[next_++].text;
  }

 private:
  std::string path_;
  int fd_ = -1;
  bool ok_ = false;
  std::mutex mutex_;
  std::vector<Message> messages_;
  std::size_t next_ = 0;
  std::jthread reader_;
};

}  // namespace sitepose::testing
