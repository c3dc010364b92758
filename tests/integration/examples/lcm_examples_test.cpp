// The subscriber examples of examples/lcm/ (C++, C, Python without the lcm
// module, Java) against a real publisher: siteposed's LcmPublisher sending
// a site-frame pose over udpm in a network namespace of the test's own
// (sitepose/testing/network_namespace.hpp; root only, skipped otherwise).
// Each example must print the pose that was sent, field by field.

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "sitepose/geo/site_frame.hpp"
#include "sitepose/output/lcm_messages.hpp"
#include "sitepose/output/lcm_publisher.hpp"
#include "sitepose/testing/network_namespace.hpp"
#include "sitepose/testing/wait.hpp"

namespace sitepose::output {
namespace {

using namespace std::chrono_literals;
using sitepose::testing::NetworkNamespace;
using sitepose::testing::TempDir;

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
constexpr int kCount = 3;  // poses each example prints before it exits

// A pose 12 m east, 5 m north of a Munich site origin, with a velocity.
struct SentPose {
  PoseEstimate pose;
  geo::SitePose site;
  Velocity velocity;
};

SentPose make_pose() {
  SentPose s;
  s.pose.t_ns = 1'780'000'000'123'456'000;  // UTC, 2026
  s.pose.T_world_cam =
      SE3(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized(), Eigen::Vector3d(5.0, -0.5, 12.0));
  s.pose.covariance = Matrix6d::Identity() * 1e-4;
  s.pose.state = TrackingState::kOk;
  geo::Geodetic origin{48.137, 11.575, 520.0};
  auto frame = geo::SiteFrame::create(origin, SE3(), geo::ForwardAxis::kMinusX);
  EXPECT_TRUE(frame.has_value());
  auto site = frame->to_site(s.pose);
  EXPECT_TRUE(site.has_value()) << site.error().message;
  s.site = *site;
  s.velocity.mps = Eigen::Vector3d(0.8, -0.25, 0.01);
  s.velocity.covariance = Eigen::Matrix3d::Identity() * 4e-4;
  return s;
}

// The line every example prints for a pose (examples/lcm/pose_subscriber.c).
std::string format_pose(const sitepose::pose_t& m) {
  char line[1024];
  std::snprintf(line, sizeof(line),
                "pose seq=%lld utime=%lld state=%d frame=%d position=%.6f,%.6f,%.6f "
                "orientation=%.6f,%.6f,%.6f,%.6f velocity=%.6f,%.6f,%.6f lat=%.9f lon=%.9f height=%.4f "
                "heading=%.4f position_std=%.6f",
                static_cast<long long>(m.seq), static_cast<long long>(m.utime), m.state, m.frame,
                m.position[0], m.position[1], m.position[2], m.orientation[0], m.orientation[1],
                m.orientation[2], m.orientation[3], m.velocity[0], m.velocity[1], m.velocity[2],
                m.latitude_deg, m.longitude_deg, m.height_m, m.heading_deg, m.position_std_m);
  return line;
}

// Child: publishes the pose with seq 0, 1, 2, ... every 20 ms until killed.
[[noreturn]] void publish_forever(const std::string& ns, const SentPose& s) {
  if (!sitepose::testing::enter_network_namespace(ns)) _exit(20);
  auto lcm = open_lcm(kUrl);
  if (!lcm) _exit(21);
  auto publisher = LcmPublisher::create(LcmOptions{}, *lcm);
  if (!publisher) _exit(22);
  PoseEstimate pose = s.pose;
  for (std::int64_t seq = 0;; ++seq) {
    pose.seq = seq;
    if (!(*publisher)->publish_pose(pose, &s.site, &s.velocity)) _exit(23);
    std::this_thread::sleep_for(20ms);
  }
}

struct Example {
  std::string name;
  std::vector<std::string> argv;
  std::string env;  // NAME=value or empty
};

// Child: the example inside the namespace, stdout into `out`, stderr into `err`.
pid_t start_example(const std::string& ns, const Example& e, const std::string& out, const std::string& err) {
  const pid_t pid = fork();
  if (pid != 0) return pid;
  if (!sitepose::testing::enter_network_namespace(ns)) _exit(30);
  if (!e.env.empty()) putenv(const_cast<char*>(e.env.c_str()));
  if (!freopen(out.c_str(), "w", stdout) || !freopen(err.c_str(), "w", stderr)) _exit(31);
  std::vector<char*> args;
  for (const std::string& a : e.argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  execv(args[0], args.data());
  _exit(127);
}

int wait_exit(pid_t pid, std::chrono::seconds timeout) {
  int status = 0;
  if (!sitepose::testing::wait_for([&] { return waitpid(pid, &status, WNOHANG) == pid; }, timeout, 20ms)) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
    return -1;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

TEST(LcmExamples, EverySubscriberExamplePrintsThePublishedPose) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to create a network namespace (ip netns add)";
  NetworkNamespace ns("sitepose_examples_" + std::to_string(getpid()));
  if (const std::string why = ns.create(true); !why.empty()) {
    GTEST_SKIP() << "cannot set up the network namespace: " << why;
  }
  const SentPose sent = make_pose();
  const std::string count = std::to_string(kCount);
  const std::vector<Example> examples{
      {"C++", {LCM_SUBSCRIBER_CPP, "--count", count, "--url", kUrl}, ""},
      {"C", {LCM_SUBSCRIBER_C, "--count", count, "--url", kUrl}, ""},
      {"Python",
       {"/usr/bin/python3", LCM_SUBSCRIBER_PY, "--count", count, "--url", kUrl},
       "PYTHONPATH=" LCM_BINDINGS_PYTHON},
      {"Java",
       {JAVA_EXE, "-cp", LCM_JAR ":" LCM_BINDINGS_JAR ":" LCM_SUBSCRIBER_JAR, "PoseSubscriber", "--count",
        count, "--url", kUrl},
       ""},
  };
  TempDir dir("lcm-examples");
  std::vector<pid_t> pids;
  for (const Example& e : examples) {
    pids.push_back(start_example(ns.name(), e, dir / (e.name + ".out"), dir / (e.name + ".err")));
  }
  const pid_t publisher = fork();
  ASSERT_GE(publisher, 0);
  if (publisher == 0) publish_forever(ns.name(), sent);
  std::vector<int> status;
  for (const pid_t pid : pids) status.push_back(wait_exit(pid, 30s));
  kill(publisher, SIGKILL);
  int publisher_status = 0;
  waitpid(publisher, &publisher_status, 0);
  EXPECT_TRUE(WIFSIGNALED(publisher_status))
      << "the publisher stopped early, exit " << WEXITSTATUS(publisher_status)
      << " (20..23: see publish_forever)";

  sitepose::pose_t expected = to_lcm_pose(sent.pose, &sent.site, &sent.velocity);
  EXPECT_EQ(expected.frame, sitepose::pose_t::FRAME_SITE);
  EXPECT_TRUE(std::isfinite(expected.velocity[0]) && std::isfinite(expected.latitude_deg));
  for (std::size_t i = 0; i < examples.size(); ++i) {
    const std::string& name = examples[i].name;
    const std::vector<std::string> lines = sitepose::testing::read_lines(dir / (name + ".out"));
    EXPECT_EQ(status[i], 0) << name << " example: " << sitepose::testing::read_text(dir / (name + ".err"));
    ASSERT_EQ(lines.size(), static_cast<std::size_t>(kCount)) << name;
    long long first_seq = -1;
    ASSERT_EQ(std::sscanf(lines[0].c_str(), "pose seq=%lld", &first_seq), 1) << name << ": " << lines[0];
    for (int k = 0; k < kCount; ++k) {
      expected.seq = first_seq + k;  // joined at some pose, then every one
      EXPECT_EQ(lines[k], format_pose(expected)) << name << " example, line " << k;
    }
  }
}

}  // namespace
}  // namespace sitepose::output
