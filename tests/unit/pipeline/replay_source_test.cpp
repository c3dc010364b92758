#include "sitepose/pipeline/replay_source.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "sitepose/testing/files.hpp"

namespace sitepose::pipeline {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// A 3-frame sitepose-layout sequence with frames 50 ms apart.
class ReplaySourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(dir_ / "image_0");
    fs::create_directories(dir_ / "image_1");
    for (int i = 0; i < 3; ++i) {
      char name[16];
      std::snprintf(name, sizeof(name), "%06d.png", i);
      cv::Mat img(24, 32, CV_8UC1, cv::Scalar(10 * i));
      ASSERT_TRUE(cv::imwrite((dir_ / "image_0" / name).string(), img));
      ASSERT_TRUE(cv::imwrite((dir_ / "image_1" / name).string(), img));
    }
    std::ofstream(dir_ / "calib.txt") << "P0: 20 0 16 0 0 20 12 0 0 0 1 0\n"
                                         "P1: 20 0 16 -10 0 20 12 0 0 0 1 0\n";
    std::ofstream(dir_ / "times.txt") << "10.0\n10.05\n10.1\n";
  }

  std::unique_ptr<ReplaySource> open(ReplayRate rate, bool loop) {
    ReplayOptions o;
    o.sequence_dir = dir_.string();
    o.rate = rate;
    o.loop = loop;
    auto s = ReplaySource::open(o);
    EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().message);
    return s ? std::move(s).value() : nullptr;
  }

  testing::TempDir tmp_;
  const fs::path dir_ = tmp_.path();
};

SteadyTime far_future() { return SteadyClock::now() + 10s; }

TEST_F(ReplaySourceTest, MaxRateDeliversEveryFrameThenEnds) {
  auto src = open(ReplayRate::kMax, false);
  ASSERT_TRUE(src);
  EXPECT_FALSE(src->live());
  EXPECT_EQ(src->camera().width, 32);
  std::stop_source stop;
  for (int i = 0; i < 3; ++i) {
    auto ev = src->next(stop.get_token(), far_future());
    ASSERT_TRUE(ev);
    ASSERT_EQ(ev->kind, SourceEventKind::kFrame);
    EXPECT_EQ(ev->frame.seq, i);
    EXPECT_EQ(ev->frame.t_ns(), 10'000'000'000 + i * 50'000'000LL);
    EXPECT_EQ(ev->frame.left.type(), CV_8UC1);
  }
  auto end = src->next(stop.get_token(), far_future());
  ASSERT_TRUE(end);
  EXPECT_EQ(end->kind, SourceEventKind::kEnd);
}

TEST_F(ReplaySourceTest, LoopKeepsTimeAndSeqMonotonic) {
  auto src = open(ReplayRate::kMax, true);
  ASSERT_TRUE(src);
  std::stop_source stop;
  std::int64_t last_t = -1;
  for (int i = 0; i < 7; ++i) {
    auto ev = src->next(stop.get_token(), far_future());
    ASSERT_TRUE(ev);
    ASSERT_EQ(ev->kind, SourceEventKind::kFrame);
    EXPECT_EQ(ev->frame.seq, i);
    EXPECT_GT(ev->frame.t_ns(), last_t);
    last_t = ev->frame.t_ns();
  }
  // Pass 2, frame 0: shifted by 2 * (0.1 s duration + 0.05 s interval).
  EXPECT_EQ(last_t, 10'000'000'000 + 2 * 150'000'000LL);
}

TEST_F(ReplaySourceTest, RecordedRatePacesFramesAndHonoursDeadlineAndStop) {
  auto src = open(ReplayRate::kRecorded, false);
  ASSERT_TRUE(src);
  EXPECT_TRUE(src->live());
  std::stop_source stop;
  const auto t0 = SteadyClock::now();
  ASSERT_EQ(src->next(stop.get_token(), far_future())->kind, SourceEventKind::kFrame);
  // Frame 1 is due 50 ms after frame 0: a 10 ms deadline times out first.
  auto early = src->next(stop.get_token(), SteadyClock::now() + 10ms);
  ASSERT_TRUE(early);
  EXPECT_EQ(early->kind, SourceEventKind::kTimeout);
  auto f1 = src->next(stop.get_token(), far_future());
  ASSERT_EQ(f1->kind, SourceEventKind::kFrame);
  EXPECT_EQ(f1->frame.seq, 1);
  EXPECT_GE(SteadyClock::now() - t0, 45ms);
  // A stop request ends the wait for frame 2 at once.
  std::jthread stopper([&] {
    std::this_thread::sleep_for(5ms);
    stop.request_stop();
  });
  const auto t1 = SteadyClock::now();
  auto ended = src->next(stop.get_token(), far_future());
  ASSERT_TRUE(ended);
  EXPECT_EQ(ended->kind, SourceEventKind::kEnd);
  EXPECT_LT(SteadyClock::now() - t1, 45ms);
}

TEST_F(ReplaySourceTest, MissingImageMidRunIsAnErrorNamingTheFile) {
  auto src = open(ReplayRate::kMax, false);
  ASSERT_TRUE(src);
  fs::remove(dir_ / "image_1" / "000001.png");
  std::stop_source stop;
  ASSERT_TRUE(src->next(stop.get_token(), far_future()));
  auto ev = src->next(stop.get_token(), far_future());
  ASSERT_FALSE(ev);
  EXPECT_NE(ev.error().message.find("000001.png"), std::string::npos) << ev.error().message;
}

TEST(ReplaySource, BadDirectoryAndRateNamesAreErrors) {
  ReplayOptions o;
  o.sequence_dir = "/nonexistent/sitepose-seq";
  EXPECT_FALSE(ReplaySource::open(o));
  EXPECT_FALSE(parse_replay_rate("fast"));
  EXPECT_EQ(*parse_replay_rate("max"), ReplayRate::kMax);
}

}  // namespace
}  // namespace sitepose::pipeline
