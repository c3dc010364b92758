#pragma once
// sd_notify(3) through libsystemd: READY=1, STATUS=..., WATCHDOG=1,
// STOPPING=1 to the socket named by $NOTIFY_SOCKET. Without systemd (no
// NOTIFY_SOCKET) every call is a no-op that succeeds. The watchdog interval
// comes from sd_watchdog_enabled(): $WATCHDOG_USEC, for this process only
// ($WATCHDOG_PID).
// Threads: the supervising thread only.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "sitepose/core/expected.hpp"

namespace sitepose::pipeline {

class SystemdNotifier {
 public:
  // Reads the environment once (NOTIFY_SOCKET, WATCHDOG_USEC, WATCHDOG_PID).
  SystemdNotifier();

  bool enabled() const { return enabled_; }
  // Interval within which systemd expects WATCHDOG=1; nullopt when off.
  std::optional<std::int64_t> watchdog_interval_ns() const { return watchdog_ns_; }

  // Sends newline-separated assignments ("READY=1\nSTATUS=tracking").
  // kIoError naming the errno text when the socket refused them.
  Status notify(std::string_view assignments);
  Status ready(std::string_view status);
  Status status(std::string_view status);
  Status watchdog();
  Status stopping(std::string_view status);

  std::uint64_t sent() const { return sent_; }
  std::uint64_t failures() const { return failures_; }

 private:
  bool enabled_ = false;
  std::optional<std::int64_t> watchdog_ns_;
  std::uint64_t sent_ = 0;
  std::uint64_t failures_ = 0;
};

}  // namespace sitepose::pipeline
