#pragma once
// The daemon supervisor's decisions, apart from the I/O so they can be
// tested: when to send READY=1 (after the first source frame), WATCHDOG=1
// (only while frames flow and the track stage progresses: both counters
// grew since the last ping), STATUS= (every status interval and whenever
// the tracking state changes) and when to log health.
// Threads: one (the supervising thread).

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "sitepose/pipeline/health.hpp"
#include "sitepose/pipeline/packets.hpp"

namespace sitepose::pipeline {

struct SupervisorOptions {
  double status_interval_s = 1.0;  // STATUS= lines at least this often
  double log_interval_s = 10.0;    // health to the log
};

struct SupervisorActions {
  bool ready = false;                 // send READY=1 (with the status)
  bool watchdog = false;              // send WATCHDOG=1
  std::optional<std::string> status;  // send STATUS=<text>
  bool log = false;                   // log the health now
};

class Supervisor {
 public:
  Supervisor(const SupervisorOptions& options, std::optional<std::int64_t> watchdog_interval_ns);

  SupervisorActions tick(const PipelineHealth& health, SteadyTime now);
  // How long to wait between ticks: at most a quarter of the watchdog
  // interval (pings arrive in time even when one tick sees no progress),
  // the status interval, and 250 ms (a stop is noticed promptly).
  std::chrono::nanoseconds tick_interval() const;
  bool ready_sent() const { return ready_sent_; }

 private:
  SupervisorOptions options_;
  std::optional<std::int64_t> watchdog_ns_;
  bool ready_sent_ = false;
  std::uint64_t captured_at_ping_ = 0;
  std::uint64_t tracked_at_ping_ = 0;
  std::optional<SteadyTime> last_status_;
  std::optional<SteadyTime> last_log_;
  std::optional<TrackingState> last_state_;
};

}  // namespace sitepose::pipeline
