#include "sitepose/drivers/v4l2/v4l2_source.hpp"

#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <thread>

#include "sitepose/testing/fake_v4l2.hpp"
#include "sitepose/testing/files.hpp"
#include "sitepose/testing/wait.hpp"

namespace sitepose::drivers::v4l2 {
namespace {

using pipeline::SourceEventKind;
using testing::FakeDeviceSpec;
using testing::FakeV4l2Io;
using namespace std::chrono_literals;

constexpr int kW = 80;  // one camera's image
constexpr int kH = 60;

// An ideal pair (no distortion, parallel): rectification is nearly the identity.
std::string write_calibration(const sitepose::testing::TempDir& dir) {
  const std::string path = dir / "stereo.yaml";
  EXPECT_TRUE(testing::write_ideal_calibration(path, {kW, kH}));
  return path;
}

std::shared_ptr<FakeV4l2Io> fake_devices(const std::vector<std::string>& paths, cv::Size size,
                                         std::uint32_t fourcc = V4L2_PIX_FMT_GREY) {
  auto io = std::make_shared<FakeV4l2Io>();
  for (const auto& p : paths) io->add_device(p, FakeDeviceSpec{{fourcc}, {size}, true, true, 30.0});
  return io;
}

V4l2SourceOptions pair_options(const std::string& calibration) {
  V4l2SourceOptions o;
  o.left_device = "/dev/video0";
  o.right_device = "/dev/video2";
  o.width = kW;
  o.height = kH;
  o.calibration_file = calibration;
  o.reconnect_min_s = 0.01;
  o.reconnect_max_s = 0.04;
  return o;
}

std::vector<std::uint8_t> flat(cv::Size size, int value, std::uint32_t fourcc = V4L2_PIX_FMT_GREY) {
  return testing::encode_frame(cv::Mat(size, CV_8UC1, cv::Scalar(value)), fourcc);
}

Expected<pipeline::SourceEvent> next_within(V4l2Source& source, std::chrono::milliseconds wait) {
  std::stop_source stop;
  return source.next(stop.get_token(), std::chrono::steady_clock::now() + wait);
}

double mean_of(const cv::Mat& m) { return cv::mean(m)[0]; }

TEST(V4l2Source, SplitsASideBySideFrameIntoARectifiedPair) {
  sitepose::testing::TempDir dir;
  auto io = fake_devices({"/dev/video0"}, {2 * kW, kH}, V4L2_PIX_FMT_YUYV);
  V4l2SourceOptions o = pair_options(write_calibration(dir));
  o.right_device.clear();
  o.width = 2 * kW;
  auto source = V4l2Source::open(o, io);
  ASSERT_TRUE(source) << source.error().message;
  EXPECT_EQ((*source)->camera().width, kW);
  EXPECT_NEAR((*source)->camera().baseline_m, 0.1, 1e-9);
  EXPECT_NE((*source)->describe().find("side-by-side /dev/video0 YUYV 160x60"), std::string::npos)
      << (*source)->describe();
  cv::Mat sbs(kH, 2 * kW, CV_8UC1, cv::Scalar(60));
  sbs(cv::Rect(kW, 0, kW, kH)) = 190;
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(io->push("/dev/video0", {testing::encode_frame(sbs, V4L2_PIX_FMT_YUYV),
                                         1'000'000'000 + i * 33'000'000, false}));
  }
  for (std::int64_t i = 0; i < 2; ++i) {
    auto event = next_within(**source, 2s);
    ASSERT_TRUE(event) << event.error().message;
    ASSERT_EQ(event->kind, SourceEventKind::kFrame);
    const StereoFrame& f = event->frame;
    EXPECT_EQ(f.seq, i);
    EXPECT_EQ(f.t_left_ns, 1'000'000'000 + i * 33'000'000);
    EXPECT_EQ(f.t_right_ns, f.t_left_ns);
    EXPECT_EQ(f.left.size(), cv::Size(kW, kH));
    EXPECT_NEAR(mean_of(f.left), 60.0, 1.0);
    EXPECT_NEAR(mean_of(f.right), 190.0, 1.0);
  }
  EXPECT_EQ((*source)->stats().frames, 2u);
  EXPECT_EQ((*source)->stats().unpaired_left, 0u);
}

TEST(V4l2Source, PairsTwoDevicesByTimeStampAndCountsTheUnpaired) {
  sitepose::testing::TempDir dir;
  auto io = fake_devices({"/dev/video0", "/dev/video2"}, {kW, kH});
  auto source = V4l2Source::open(pair_options(write_calibration(dir)), io);
  ASSERT_TRUE(source) << source.error().message;
  // Right 1.2 ms behind; its second frame and the left's third are lost.
  for (std::int64_t t : {0, 33, 67, 100})
    io->push("/dev/video0", {flat({kW, kH}, 50), (1000 + t) * 1'000'000, false});
  for (std::int64_t t : {1, 68, 101})
    io->push("/dev/video2", {flat({kW, kH}, 200), (1000 + t) * 1'000'000 + 200'000, false});
  std::vector<std::int64_t> left_ms;
  for (int i = 0; i < 3; ++i) {
    auto event = next_within(**source, 2s);
    ASSERT_TRUE(event) << event.error().message;
    ASSERT_EQ(event->kind, SourceEventKind::kFrame);
    EXPECT_LE(std::abs(event->frame.t_right_ns - event->frame.t_left_ns), 5'000'000);
    EXPECT_NEAR(mean_of(event->frame.left), 50.0, 1.0);
    EXPECT_NEAR(mean_of(event->frame.right), 200.0, 1.0);
    left_ms.push_back(event->frame.t_left_ns / 1'000'000 - 1000);
  }
  EXPECT_EQ(left_ms, (std::vector<std::int64_t>{0, 67, 100}));
  const V4l2SourceStats stats = (*source)->stats();
  EXPECT_EQ(stats.pairs, 3u);
  EXPECT_EQ(stats.unpaired_left, 1u);  // 33 ms
  EXPECT_EQ(stats.unpaired_right, 0u);
  auto idle = next_within(**source, 30ms);
  ASSERT_TRUE(idle);
  EXPECT_EQ(idle->kind, SourceEventKind::kTimeout);
}

TEST(V4l2Source, ReconnectsWithBackOffWhenADeviceVanishes) {
  sitepose::testing::TempDir dir;
  auto io = fake_devices({"/dev/video0", "/dev/video2"}, {kW, kH});
  auto opened = V4l2Source::open(pair_options(write_calibration(dir)), io);
  ASSERT_TRUE(opened) << opened.error().message;
  V4l2Source& source = **opened;
  io->push("/dev/video0", {flat({kW, kH}, 50), 1'000'000'000, false});
  io->push("/dev/video2", {flat({kW, kH}, 50), 1'000'000'000, false});
  ASSERT_EQ(next_within(source, 2s)->kind, SourceEventKind::kFrame);

  io->unplug("/dev/video2");
  auto lost = next_within(source, 100ms);
  ASSERT_TRUE(lost) << "a vanished camera is not an error of the source";
  EXPECT_EQ(lost->kind, SourceEventKind::kTimeout);
  EXPECT_EQ(source.stats().disconnects, 1u);
  EXPECT_FALSE(source.stats().connected);
  EXPECT_NE(source.stats().last_error.find("/dev/video2"), std::string::npos) << source.stats().last_error;
  EXPECT_EQ(io->open_descriptors(), 0) << "both devices closed while one is away";
  // Still away: retries fail, the source keeps timing out.
  EXPECT_EQ(next_within(source, 100ms)->kind, SourceEventKind::kTimeout);
  EXPECT_EQ(source.stats().reconnects, 0u);

  io->plug("/dev/video2");
  ASSERT_TRUE(sitepose::testing::wait_for(
      [&] {
        (void)next_within(source, 10ms);
        return source.stats().connected;
      },
      5s));
  EXPECT_EQ(source.stats().reconnects, 1u);
  EXPECT_EQ(io->streamon_count("/dev/video2"), 2);
  io->push("/dev/video0", {flat({kW, kH}, 80), 2'000'000'000, false});
  io->push("/dev/video2", {flat({kW, kH}, 80), 2'000'000'000, false});
  auto back = next_within(source, 2s);
  ASSERT_TRUE(back);
  ASSERT_EQ(back->kind, SourceEventKind::kFrame);
  EXPECT_EQ(back->frame.seq, 1);
  EXPECT_EQ(back->frame.t_left_ns, 2'000'000'000);
}

TEST(V4l2Source, AStopRequestEndsAWaitPromptly) {
  sitepose::testing::TempDir dir;
  auto io = fake_devices({"/dev/video0", "/dev/video2"}, {kW, kH});
  auto source = V4l2Source::open(pair_options(write_calibration(dir)), io);
  ASSERT_TRUE(source) << source.error().message;
  std::stop_source stop;
  std::thread stopper([&] {
    std::this_thread::sleep_for(50ms);
    stop.request_stop();
  });
  const auto start = std::chrono::steady_clock::now();
  auto event = (*source)->next(stop.get_token(), start + 30s);
  stopper.join();
  ASSERT_TRUE(event);
  EXPECT_EQ(event->kind, SourceEventKind::kEnd);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 5s);
}

TEST(V4l2Source, AnAbsentCameraFailsAtOnceOrIsWaitedFor) {
  sitepose::testing::TempDir dir;
  auto io = fake_devices({"/dev/video0", "/dev/video2"}, {kW, kH});
  io->unplug("/dev/video2");
  V4l2SourceOptions o = pair_options(write_calibration(dir));
  auto absent = V4l2Source::open(o, io);
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().code, ErrorCode::kNotFound);
  EXPECT_NE(absent.error().message.find("/dev/video2"), std::string::npos) << absent.error().message;
  EXPECT_EQ(io->open_descriptors(), 0);

  o.wait_for_camera_s = 10.0;
  std::thread plugger([&] {
    std::this_thread::sleep_for(100ms);
    io->plug("/dev/video2");
  });
  auto waited = V4l2Source::open(o, io);
  plugger.join();
  ASSERT_TRUE(waited) << waited.error().message;
}

TEST(V4l2Source, ChecksTheCalibrationAgainstTheCameras) {
  sitepose::testing::TempDir dir;
  auto io = fake_devices({"/dev/video0"}, {2 * kW, kH});
  V4l2SourceOptions o = pair_options(write_calibration(dir));
  o.right_device.clear();
  o.width = 4 * kW;  // half is 160 wide, the calibration is for 80
  auto wrong = V4l2Source::open(o, io);
  ASSERT_FALSE(wrong);
  EXPECT_NE(wrong.error().message.find("half of the side-by-side frame"), std::string::npos)
      << wrong.error().message;
  o.calibration_file = dir / "absent.yaml";
  auto missing = V4l2Source::open(o, io);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().exit_status(), 2);
  o = pair_options(write_calibration(dir));
  o.pixel_format = "RGB3";
  EXPECT_FALSE(V4l2Source::open(o, io));
}

}  // namespace
}  // namespace sitepose::drivers::v4l2
