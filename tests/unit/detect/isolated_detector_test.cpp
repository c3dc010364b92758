// A detector plugin in sitepose-detector-host (issue 20): the same results
// as in this process, and a crash (SIGSEGV, abort, exit) or hang of the
// plugin is a failed call, counted, followed by a restart after the
// back-off, after which boxes come back.
#include "sitepose/detect/isolated_detector.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "test_util.hpp"

namespace sitepose::detect {
namespace {

using namespace std::chrono_literals;

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

IsolationOptions isolated(std::shared_ptr<HostCounters> counters,
                          std::chrono::milliseconds call_timeout = 5s) {
  IsolationOptions o;
  o.in_child_process = true;
  o.counters = std::move(counters);
  o.call_timeout = call_timeout;
  o.backoff_min = 100ms;
  return o;
}

// A frame whose rows are a window into a wider image (stride != width) and
// whose pixels differ, so that a packing mistake would show.
StereoFrame strided_frame(std::int64_t seq) {
  StereoFrame f = test::gray_frame(80, 60, seq);
  static cv::Mat wide_left(60, 100, CV_8UC1);
  static cv::Mat wide_right(60, 100, CV_8UC1);
  cv::randu(wide_left, 0, 255);
  cv::randu(wide_right, 0, 255);
  f.left = wide_left(cv::Rect(7, 0, 80, 60));
  f.right = wide_right(cv::Rect(3, 0, 80, 60));
  return f;
}

// pid -> frames it answered, from the crash plugin's log.
std::map<int, std::set<long long>> answered_by(const std::string& log) {
  std::map<int, std::set<long long>> out;
  std::ifstream in(log);
  int pid = 0;
  long long seq = 0;
  while (in >> pid >> seq) out[pid].insert(seq);
  return out;
}

TEST(IsolatedDetector, GivesTheSameBoxesAndMaskAsInProcess) {
  auto in_process = load_detector_plugin(DETECT_TEST_CRASH_PLUGIN, "");
  auto counters = std::make_shared<HostCounters>();
  auto in_host = load_isolated_plugin(DETECT_TEST_CRASH_PLUGIN, "", {}, isolated(counters));
  ASSERT_TRUE(in_process) << in_process.error().message;
  ASSERT_TRUE(in_host) << in_host.error().message;
  EXPECT_TRUE((*in_host)->capabilities().has_segmentation);
  EXPECT_TRUE((*in_host)->capabilities().tracks_ids);
  for (std::int64_t seq = 0; seq < 3; ++seq) {
    const StereoFrame frame = strided_frame(seq);
    auto a = (*in_process)->detect(frame);
    auto b = (*in_host)->detect(frame);
    ASSERT_TRUE(a && b) << (a ? b.error().message : a.error().message);
    ASSERT_EQ(b->size(), 1u);
    EXPECT_EQ((*b)[0].box, (*a)[0].box);
    EXPECT_EQ((*b)[0].class_name, "truck");
    auto mask_a = (*in_process)->segment(frame, *a);
    auto mask_b = (*in_host)->segment(frame, *b);
    ASSERT_TRUE(mask_a && mask_b);
    EXPECT_EQ(cv::countNonZero(*mask_b), 40 * 30 / 2);
    EXPECT_EQ(cv::countNonZero(*mask_a != *mask_b), 0);
  }
  EXPECT_EQ(counters->crashes.load(), 0);
}

// Crashes at frame 3 in each way a process can end; the frame fails with
// the reason, the next one fails at once during the back-off, and a frame
// after the back-off is answered by a new host.
void crash_and_recover(const std::string& how, const std::string& reason) {
  const testing::TempDir dir;
  const std::string log = dir / "answers.txt";
  auto counters = std::make_shared<HostCounters>();
  auto d = load_isolated_plugin(DETECT_TEST_CRASH_PLUGIN, "crash_at=3 how=" + how + " log=" + log, {},
                                isolated(counters));
  ASSERT_TRUE(d) << d.error().message;
  for (std::int64_t seq = 0; seq < 3; ++seq) ASSERT_TRUE((*d)->detect(test::gray_frame(64, 48, seq)));
  auto crashed = (*d)->detect(test::gray_frame(64, 48, 3));
  ASSERT_FALSE(crashed);
  EXPECT_TRUE(contains(crashed.error().message, reason)) << crashed.error().message;
  EXPECT_TRUE(contains(crashed.error().message, "frame 3")) << crashed.error().message;
  EXPECT_EQ(counters->crashes.load(), 1);
  auto backing_off = (*d)->detect(test::gray_frame(64, 48, 4));
  ASSERT_FALSE(backing_off);
  EXPECT_TRUE(contains(backing_off.error().message, "restarting in")) << backing_off.error().message;
  std::this_thread::sleep_for(150ms);
  for (std::int64_t seq = 5; seq < 8; ++seq) {
    auto boxes = (*d)->detect(test::gray_frame(64, 48, seq));
    ASSERT_TRUE(boxes) << boxes.error().message;
    EXPECT_EQ(boxes->size(), 1u);
  }
  EXPECT_EQ(counters->restarts.load(), 1);
  EXPECT_EQ(counters->crashes.load(), 1);
  EXPECT_EQ((*d)->health().failed_calls, 2);
  const auto answers = answered_by(log);
  ASSERT_EQ(answers.size(), 2u) << "two hosts answered";
  EXPECT_EQ(answers.begin()->second.size() + std::next(answers.begin())->second.size(), 6u);
}

TEST(IsolatedDetector, SegfaultIsCountedAndTheRestartedHostAnswers) {
  crash_and_recover("segv", "killed by signal 11");
}
TEST(IsolatedDetector, AbortIsCountedAndTheRestartedHostAnswers) {
  crash_and_recover("abort", "killed by signal 6");
}
TEST(IsolatedDetector, ExitIsCountedAndTheRestartedHostAnswers) {
  crash_and_recover("exit", "exited with status 7");
}

TEST(IsolatedDetector, HangingHostIsKilledAtTheCallTimeoutAndRestarted) {
  auto counters = std::make_shared<HostCounters>();
  auto d = load_isolated_plugin(DETECT_TEST_SLOW_PLUGIN, "slow_from=2 slow_to=3 sleep_ms=-1", {},
                                isolated(counters, 300ms));
  ASSERT_TRUE(d) << d.error().message;
  ASSERT_TRUE((*d)->detect(test::gray_frame(64, 48, 1)));
  const auto t0 = std::chrono::steady_clock::now();
  auto hung = (*d)->detect(test::gray_frame(64, 48, 2));
  const auto waited = std::chrono::steady_clock::now() - t0;
  ASSERT_FALSE(hung);
  EXPECT_TRUE(contains(hung.error().message, "did not answer within 300 ms")) << hung.error().message;
  EXPECT_GE(waited, 300ms);
  EXPECT_LT(waited, 3s);  // the kill and reap, under load
  EXPECT_EQ(counters->hangs.load(), 1);
  EXPECT_EQ(counters->crashes.load(), 0);
  std::this_thread::sleep_for(150ms);
  auto again = (*d)->detect(test::gray_frame(64, 48, 3));
  EXPECT_TRUE(again) << again.error().message;
  EXPECT_EQ(counters->restarts.load(), 1);
}

TEST(IsolatedDetector, BackOffDoublesWhileTheHostKeepsCrashing) {
  auto counters = std::make_shared<HostCounters>();
  IsolationOptions o = isolated(counters);
  o.backoff_max = 400ms;
  // crash_at=0 crashes each new host on the first frame it is given.
  auto d = load_isolated_plugin(DETECT_TEST_CRASH_PLUGIN, "crash_at=0", {}, o);
  ASSERT_TRUE(d) << d.error().message;
  std::vector<std::string> delays;
  for (int i = 0; i < 4; ++i) {
    auto r = (*d)->detect(test::gray_frame(64, 48, 0));
    ASSERT_FALSE(r);
    const std::size_t at = r.error().message.rfind("restarting in ");
    ASSERT_NE(at, std::string::npos) << r.error().message;
    delays.push_back(r.error().message.substr(at));
    std::this_thread::sleep_for(450ms);
  }
  EXPECT_EQ(delays, (std::vector<std::string>{"restarting in 100 ms", "restarting in 200 ms",
                                              "restarting in 400 ms", "restarting in 400 ms"}));
  EXPECT_EQ(counters->crashes.load(), 4);
  EXPECT_EQ(counters->restarts.load(), 3);
}

TEST(IsolatedDetector, PluginThatCrashesInCreateFailsTheLoadNamingTheSignal) {
  auto d = load_isolated_plugin(DETECT_TEST_CRASH_PLUGIN, "create_crash=1", {}, isolated(nullptr));
  ASSERT_FALSE(d);
  EXPECT_TRUE(contains(d.error().message, DETECT_TEST_CRASH_PLUGIN)) << d.error().message;
  EXPECT_TRUE(contains(d.error().message, "killed by signal 11")) << d.error().message;
}

TEST(IsolatedDetector, MissingHostBinaryIsNotFoundNamingIt) {
  IsolationOptions o = isolated(nullptr);
  o.host_path = "/nonexistent/sitepose-detector-host";
  auto d = load_isolated_plugin(DETECT_TEST_CRASH_PLUGIN, "", {}, o);
  ASSERT_FALSE(d);
  EXPECT_TRUE(contains(d.error().message, "/nonexistent/sitepose-detector-host")) << d.error().message;
  auto found = detector_host_path();
  ASSERT_TRUE(found) << found.error().message;
  EXPECT_TRUE(contains(*found, "sitepose-detector-host")) << *found;
}

// The price of the child process per frame at 960x540: the frame copied
// into the memfd, two messages, two context switches. Measured with a
// plugin that does nothing (one box), so the difference is the overhead;
// frames alternate between the two paths so that the machine's load hits
// both alike. Medians, printed; the bound is loose (a loaded machine).
TEST(IsolatedDetector, OverheadPerFrameAt960x540IsSmall) {
  auto in_process = load_detector_plugin(DETECT_TEST_CRASH_PLUGIN, "");
  auto in_host = load_isolated_plugin(DETECT_TEST_CRASH_PLUGIN, "", {}, isolated(nullptr));
  ASSERT_TRUE(in_process && in_host);
  StereoFrame frame = test::gray_frame(960, 540);
  cv::randu(frame.left, 0, 255);
  cv::randu(frame.right, 0, 255);
  constexpr int kFrames = 200;
  std::vector<double> a_ms, b_ms, seg_a_ms, seg_b_ms;
  const auto time_ms = [](auto&& fn) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  };
  for (int i = 0; i < kFrames; ++i) {
    frame.seq = i;
    std::vector<Detection> da, db;
    a_ms.push_back(time_ms([&] { da = *(*in_process)->detect(frame); }));
    b_ms.push_back(time_ms([&] { db = *(*in_host)->detect(frame); }));
    seg_a_ms.push_back(time_ms([&] { ASSERT_TRUE((*in_process)->segment(frame, da)); }));
    seg_b_ms.push_back(time_ms([&] { ASSERT_TRUE((*in_host)->segment(frame, db)); }));
  }
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double a = median(a_ms), b = median(b_ms), sa = median(seg_a_ms), sb = median(seg_b_ms);
  std::printf(
      "960x540, %d frames, medians: detect in-process %.3f ms, in host %.3f ms (overhead %.3f ms); "
      "segment in-process %.3f ms, in host %.3f ms (overhead %.3f ms); detect+segment ratio %.2f\n",
      kFrames, a, b, b - a, sa, sb, sb - sa, (b + sb) / (a + sa));
  EXPECT_LT(b - a, 10.0);
  EXPECT_LT(sb - sa, 10.0);
}

}  // namespace
}  // namespace sitepose::detect
