#include "sitepose/pipeline/supervisor.hpp"

#include <algorithm>

namespace sitepose::pipeline {
namespace {
std::chrono::nanoseconds from_s(double s) {
  return std::chrono::nanoseconds(static_cast<std::int64_t>(s * 1e9));
}
}  // namespace

Supervisor::Supervisor(const SupervisorOptions& options, std::optional<std::int64_t> watchdog_interval_ns)
    : options_(options), watchdog_ns_(watchdog_interval_ns) {}

std::chrono::nanoseconds Supervisor::tick_interval() const {
  std::chrono::nanoseconds t = std::min(from_s(options_.status_interval_s), std::chrono::nanoseconds(250'000'000));
  if (watchdog_ns_) t = std::min(t, std::chrono::nanoseconds(*watchdog_ns_ / 4));
  return std::max(t, std::chrono::nanoseconds(1'000'000));
}

SupervisorActions Supervisor::tick(const PipelineHealth& h, SteadyTime now) {
  SupervisorActions a;
  const bool state_changed = !last_state_ || *last_state_ != h.state;
  if (!ready_sent_ && h.frames_captured > 0) {
    ready_sent_ = true;
    a.ready = true;
  }
  if (watchdog_ns_ && h.frames_captured > captured_at_ping_ && h.frames_tracked > tracked_at_ping_) {
    a.watchdog = true;
    captured_at_ping_ = h.frames_captured;
    tracked_at_ping_ = h.frames_tracked;
  }
  if (a.ready || state_changed || !last_status_ ||
      now - *last_status_ >= from_s(options_.status_interval_s)) {
    a.status = format_status(h);
    last_status_ = now;
    last_state_ = h.state;
  }
  if (!last_log_ || now - *last_log_ >= from_s(options_.log_interval_s) || state_changed) {
    a.log = true;
    last_log_ = now;
  }
  return a;
}

}  // namespace sitepose::pipeline
