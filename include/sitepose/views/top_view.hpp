#pragma once
// `sitepose top`: what a running siteposed says on its LCM health and pose
// channels, as a screen of plain text (ANSI colour optional; no curses, so
// it works over any SSH terminal).
//
// TopMonitor subscribes to both channels on an lcm::LCM it shares; handle()
// runs LCM's dispatch on the caller's thread, which is also the only thread
// that reads the state (snapshot()). One thread.

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "sitepose/core/expected.hpp"
#include "sitepose/health_t.hpp"
#include "sitepose/pose_t.hpp"

namespace sitepose::views {

using TopClock = std::chrono::steady_clock;

struct TopState {
  std::optional<sitepose::health_t> health;
  std::optional<sitepose::pose_t> pose;
  std::optional<TopClock::time_point> health_at;
  std::optional<TopClock::time_point> pose_at;
  std::int64_t poses_received = 0;
  std::int64_t healths_received = 0;
  std::int64_t undecodable = 0;
  double pose_rate_hz = 0.0;  // over the poses of the last 2 s
  std::string last_error;     // the latest reason a pose or health was not OK, or a bad message
};

// The screen for `state` at `now`: lines of at most ~100 columns. colour:
// ANSI colours for the tracking state.
std::string render_top(const TopState& state, TopClock::time_point now, bool colour);

class TopMonitor {
 public:
  // kIoError when a subscription fails.
  static Expected<std::unique_ptr<TopMonitor>> create(std::shared_ptr<lcm::LCM> lcm,
                                                      const std::string& pose_channel,
                                                      const std::string& health_channel);
  ~TopMonitor();
  TopMonitor(const TopMonitor&) = delete;
  TopMonitor& operator=(const TopMonitor&) = delete;

  // Dispatches the messages that arrive within timeout_ms; false on an LCM
  // failure (or the end of a log file).
  bool handle(int timeout_ms);
  const TopState& state() const { return state_; }

 private:
  explicit TopMonitor(std::shared_ptr<lcm::LCM> lcm) : lcm_(std::move(lcm)) {}
  void on_pose(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  void on_health(const lcm::ReceiveBuffer* buffer, const std::string& channel);

  std::shared_ptr<lcm::LCM> lcm_;
  lcm::Subscription* pose_subscription_ = nullptr;
  lcm::Subscription* health_subscription_ = nullptr;
  std::deque<TopClock::time_point> pose_times_;
  TopState state_;
};

}  // namespace sitepose::views
