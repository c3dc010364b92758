#include "sitepose/pipeline/supervisor.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "sitepose/pipeline/latency_histogram.hpp"
#include "sitepose/pipeline/systemd_notify.hpp"
#include "sitepose/testing/files.hpp"
#include "sitepose/testing/notify_socket.hpp"

namespace sitepose::pipeline {
namespace {

using namespace std::chrono_literals;

PipelineHealth health(std::uint64_t captured, std::uint64_t tracked,
                      TrackingState state = TrackingState::kOk) {
  PipelineHealth h;
  h.frames_captured = captured;
  h.frames_tracked = tracked;
  h.state = state;
  h.stages = {{"capture"}, {"detect"}, {"track"}, {"publish"}};
  return h;
}

TEST(Supervisor, ReadyOnlyAfterTheFirstFrame) {
  Supervisor s({}, std::nullopt);
  const SteadyTime t0{};
  EXPECT_FALSE(s.tick(health(0, 0), t0).ready);
  EXPECT_TRUE(s.tick(health(1, 0), t0 + 10ms).ready);
  EXPECT_FALSE(s.tick(health(2, 1), t0 + 20ms).ready);
  EXPECT_TRUE(s.ready_sent());
}

TEST(Supervisor, WatchdogOnlyWhileFramesFlowAndTrackingProgresses) {
  Supervisor s({}, 1'000'000'000);
  const SteadyTime t0{};
  EXPECT_FALSE(s.tick(health(0, 0), t0).watchdog);
  EXPECT_TRUE(s.tick(health(3, 2), t0 + 100ms).watchdog);
  EXPECT_FALSE(s.tick(health(3, 2), t0 + 200ms).watchdog) << "nothing moved";
  EXPECT_FALSE(s.tick(health(5, 2), t0 + 300ms).watchdog) << "frames flow, track stuck";
  EXPECT_FALSE(s.tick(health(5, 2), t0 + 400ms).watchdog);
  EXPECT_TRUE(s.tick(health(6, 4), t0 + 500ms).watchdog) << "both moved again";
  EXPECT_FALSE(s.tick(health(6, 5), t0 + 600ms).watchdog) << "source stalled, track drains";
  // Without a watchdog interval, never.
  Supervisor off({}, std::nullopt);
  EXPECT_FALSE(off.tick(health(3, 2), t0).watchdog);
}

TEST(Supervisor, StatusEveryIntervalAndOnStateChange) {
  SupervisorOptions o;
  o.status_interval_s = 1.0;
  o.log_interval_s = 5.0;
  Supervisor s(o, std::nullopt);
  const SteadyTime t0{};
  auto a = s.tick(health(1, 1), t0);
  ASSERT_TRUE(a.status);
  EXPECT_TRUE(a.log);
  EXPECT_EQ(a.status->rfind("OK ", 0), 0u) << *a.status;
  EXPECT_FALSE(s.tick(health(2, 2), t0 + 500ms).status);
  auto lost = s.tick(health(2, 2, TrackingState::kLost), t0 + 600ms);
  ASSERT_TRUE(lost.status);
  EXPECT_EQ(lost.status->rfind("LOST", 0), 0u) << *lost.status;
  EXPECT_TRUE(lost.log);
  EXPECT_FALSE(s.tick(health(2, 2, TrackingState::kLost), t0 + 1500ms).status);
  EXPECT_TRUE(s.tick(health(2, 2, TrackingState::kLost), t0 + 1700ms).status);
}

TEST(Supervisor, TickIntervalFollowsTheWatchdog) {
  EXPECT_EQ(Supervisor({}, 400'000'000).tick_interval(), 100ms);
  EXPECT_EQ(Supervisor({}, std::nullopt).tick_interval(), 250ms);
}

TEST(FormatStatus, NamesStateRateDropsAndErrors) {
  PipelineHealth h = health(10, 10, TrackingState::kRecovering);
  h.fps = 29.84;
  h.stages[1].drops = 1;
  h.stages[2].drops = 3;
  h.state_reason = "few inliers";
  h.outputs = {{"lcm", 0, 2}, {"can", 0, 0}};
  const std::string s = format_status(h);
  EXPECT_NE(s.find("RECOVERING 29.8 fps"), std::string::npos) << s;
  EXPECT_NE(s.find("drops 1/3/0"), std::string::npos) << s;
  EXPECT_NE(s.find("errors lcm 2 can 0"), std::string::npos) << s;
  EXPECT_NE(s.find("(few inliers)"), std::string::npos) << s;
  EXPECT_EQ(h.total_drops(), 4u);
}

TEST(LatencyHistogram, PercentilesWithinTheBucketResolution) {
  LatencyHistogram hist;
  EXPECT_EQ(hist.percentile_ms(0.5), 0.0);
  for (int i = 1; i <= 1000; ++i) hist.record_ms(i * 0.1);  // 0.1 .. 100 ms
  EXPECT_EQ(hist.count(), 1000u);
  EXPECT_NEAR(hist.percentile_ms(0.5), 50.0, 50.0 * 0.04);
  EXPECT_NEAR(hist.percentile_ms(0.99), 99.0, 99.0 * 0.04);
  EXPECT_NEAR(hist.percentile_ms(0.0), 0.1, 0.1 * 0.04);
  hist.record_ms(-5.0);
  hist.record_ms(1e12);  // clamps into the last bucket
  EXPECT_EQ(hist.count(), 1002u);
  EXPECT_GT(hist.percentile_ms(1.0), 1e5);
}

// sd_notify end to end through libsystemd to a datagram socket, as systemd
// would receive it.
TEST(SystemdNotifier, SendsToNotifySocketAndReadsTheWatchdog) {
  const testing::TempDir dir("notify");
  testing::NotifySocket sock(dir / "notify.sock");
  ASSERT_TRUE(sock.ok());
  setenv("NOTIFY_SOCKET", sock.path().c_str(), 1);
  setenv("WATCHDOG_USEC", "2000000", 1);
  setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  SystemdNotifier n;
  EXPECT_TRUE(n.enabled());
  ASSERT_TRUE(n.watchdog_interval_ns());
  EXPECT_EQ(*n.watchdog_interval_ns(), 2'000'000'000);
  ASSERT_TRUE(n.ready("tracking\nstarted"));
  EXPECT_EQ(sock.next(), "READY=1\nSTATUS=tracking started");
  ASSERT_TRUE(n.watchdog());
  EXPECT_EQ(sock.next(), "WATCHDOG=1");
  ASSERT_TRUE(n.stopping("bye"));
  EXPECT_EQ(sock.next(), "STOPPING=1\nSTATUS=bye");
  EXPECT_EQ(n.sent(), 3u);

  // Another process's watchdog is not ours.
  setenv("WATCHDOG_PID", "1", 1);
  SystemdNotifier other;
  EXPECT_FALSE(other.watchdog_interval_ns());

  // A socket that is gone: errors are returned and counted.
  setenv("NOTIFY_SOCKET", (dir / "no-such.sock").c_str(), 1);
  SystemdNotifier broken;
  EXPECT_FALSE(broken.status("x"));
  EXPECT_EQ(broken.failures(), 1u);

  unsetenv("NOTIFY_SOCKET");
  unsetenv("WATCHDOG_USEC");
  unsetenv("WATCHDOG_PID");
  SystemdNotifier none;
  EXPECT_FALSE(none.enabled());
  EXPECT_TRUE(none.status("nobody listens"));
}

}  // namespace
}  // namespace sitepose::pipeline
