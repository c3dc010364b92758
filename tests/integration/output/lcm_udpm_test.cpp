// Real LCM over UDP multicast (udpm) between two processes.
//
// Set-up: a network namespace sitepose_lcm_<pid> with a multicast route on
// lo (sitepose/testing/network_namespace.hpp); a subscriber and a publisher
// are forked, each entering the namespace before opening
// udpm://239.255.76.67:7667?ttl=0. Without root, or where `ip netns add` is
// not permitted (e.g. an unprivileged container), the tests skip and say
// why. CI runs as root.

#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "sitepose/output/lcm_gnss_subscriber.hpp"
#include "sitepose/output/lcm_publisher.hpp"
#include "sitepose/testing/network_namespace.hpp"

namespace sitepose::output {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
constexpr int kPoses = 50;

using sitepose::testing::NetworkNamespace;

bool enter_namespace(const std::string& name) { return sitepose::testing::enter_network_namespace(name); }

struct PoseSeqs {
  std::vector<std::int64_t> seqs;
  void on_pose(const lcm::ReceiveBuffer*, const std::string&, const sitepose::pose_t* m) {
    seqs.push_back(m->seq);
  }
};

// Child: subscribes, says "ready", collects poses for up to 5 s, writes
// their seq numbers to result_fd. Exit status 0 when it ran.
int subscriber_main(const std::string& ns, int ready_fd, int result_fd) {
  if (!enter_namespace(ns)) return 10;
  auto lcm = open_lcm(kUrl);
  if (!lcm) return 11;
  PoseSeqs received;
  if ((*lcm)->subscribe("SITEPOSE_POSE", &PoseSeqs::on_pose, &received) == nullptr) return 12;
  // udpm joins the group on subscribe; one handle pass makes sure.
  (*lcm)->handleTimeout(10);
  if (write(ready_fd, "R", 1) != 1) return 13;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (static_cast<int>(received.seqs.size()) < kPoses && std::chrono::steady_clock::now() < deadline) {
    (*lcm)->handleTimeout(100);
  }
  const auto bytes = static_cast<ssize_t>(received.seqs.size() * sizeof(std::int64_t));
  if (bytes > 0 && write(result_fd, received.seqs.data(), bytes) != bytes) return 14;
  return 0;
}

// Child: publishes kPoses poses through LcmPublisher. Exit status 0 when
// every publish succeeded.
int publisher_main(const std::string& ns) {
  if (!enter_namespace(ns)) return 20;
  auto lcm = open_lcm(kUrl);
  if (!lcm) return 21;
  auto publisher = LcmPublisher::create(LcmOptions{}, *lcm);
  if (!publisher) return 22;
  for (int i = 0; i < kPoses; ++i) {
    PoseEstimate pose;
    pose.seq = i;
    pose.t_ns = 1'000'000'000LL * i;
    pose.state = TrackingState::kOk;
    if (!(*publisher)->publish_pose(pose, nullptr)) return 23;
    // Pace like a camera, well inside the socket buffer.
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return (*publisher)->stats().poses_published == kPoses ? 0 : 24;
}

int wait_exit_status(pid_t pid) {
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string skip_reason() {
  if (geteuid() != 0) return "needs root to create a network namespace (ip netns add)";
  return "";
}

TEST(LcmUdpm, PublisherAndSubscriberProcessesInANetworkNamespace) {
  if (const std::string why = skip_reason(); !why.empty()) GTEST_SKIP() << why;
  NetworkNamespace ns("sitepose_lcm_" + std::to_string(getpid()));
  if (const std::string why = ns.create(true); !why.empty()) {
    GTEST_SKIP() << "cannot set up the network namespace: " << why;
  }
  int ready[2], result[2];
  ASSERT_EQ(pipe(ready), 0);
  ASSERT_EQ(pipe(result), 0);
  const pid_t subscriber = fork();
  ASSERT_GE(subscriber, 0);
  if (subscriber == 0) {
    close(ready[0]);
    close(result[0]);
    _exit(subscriber_main(ns.name(), ready[1], result[1]));
  }
  close(ready[1]);
  close(result[1]);
  pollfd wait_ready{ready[0], POLLIN, 0};
  ASSERT_EQ(poll(&wait_ready, 1, 5000), 1) << "subscriber never became ready";
  char r = 0;
  ASSERT_EQ(read(ready[0], &r, 1), 1);

  const pid_t publisher = fork();
  ASSERT_GE(publisher, 0);
  if (publisher == 0) _exit(publisher_main(ns.name()));
  EXPECT_EQ(wait_exit_status(publisher), 0) << "publisher process failed (20..24: see publisher_main)";

  std::vector<std::int64_t> seqs;
  std::int64_t seq = 0;
  while (read(result[0], &seq, sizeof(seq)) == static_cast<ssize_t>(sizeof(seq))) seqs.push_back(seq);
  close(ready[0]);
  close(result[0]);
  EXPECT_EQ(wait_exit_status(subscriber), 0) << "subscriber process failed (10..14)";
  ASSERT_EQ(seqs.size(), static_cast<std::size_t>(kPoses));
  for (int i = 0; i < kPoses; ++i) EXPECT_EQ(seqs[i], i);
}

TEST(LcmUdpm, WithoutMulticastRouteOpenFailsWithAReason) {
  if (const std::string why = skip_reason(); !why.empty()) GTEST_SKIP() << why;
  NetworkNamespace ns("sitepose_lcm_noroute_" + std::to_string(getpid()));
  if (const std::string why = ns.create(false); !why.empty()) {
    GTEST_SKIP() << "cannot set up the network namespace: " << why;
  }
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (!enter_namespace(ns.name())) _exit(30);
    // LCM 1.3 tests the route when it opens udpm: refused, with a reason.
    auto lcm = open_lcm(kUrl);
    if (lcm) _exit(31);
    _exit(lcm.error().code == ErrorCode::kIoError && lcm.error().message.find(kUrl) != std::string::npos
              ? 0
              : 32);
  }
  EXPECT_EQ(wait_exit_status(child), 0) << "30: setns, 31: opened without a route, 32: wrong error";
}

TEST(LcmUdpm, SendFailuresWhenTheRouteGoesAreCountedAndRetried) {
  if (const std::string why = skip_reason(); !why.empty()) GTEST_SKIP() << why;
  NetworkNamespace ns("sitepose_lcm_fail_" + std::to_string(getpid()));
  if (const std::string why = ns.create(true); !why.empty()) {
    GTEST_SKIP() << "cannot set up the network namespace: " << why;
  }
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (!enter_namespace(ns.name())) _exit(40);
    auto lcm = open_lcm(kUrl);
    if (!lcm) _exit(41);
    auto publisher = LcmPublisher::create(LcmOptions{}, *lcm);
    if (!publisher) _exit(42);
    LcmPublisher& p = **publisher;
    PoseEstimate pose;
    if (!p.publish_pose(pose, nullptr)) _exit(43);
    // The route disappears (link down, misconfiguration): real sendmsg errors.
    if (std::system("ip route del 224.0.0.0/4 dev lo") != 0) _exit(44);
    pose.seq = 1;
    const Status failed = p.publish_pose(pose, nullptr);
    const LcmPublisherStats s = p.stats();
    if (failed || s.send_failures != 3 || s.retries != 2 || s.messages_failed != 1 || !p.has_pending_pose()) {
      _exit(45);
    }
    if (std::system("ip route add 224.0.0.0/4 dev lo") != 0) _exit(46);
    if (!p.retry_pose() || p.has_pending_pose() || p.stats().poses_published != 2) _exit(47);
    _exit(0);
  }
  EXPECT_EQ(wait_exit_status(child), 0) << "see the exit codes 40..47 in the test";
}

}  // namespace
}  // namespace sitepose::output
