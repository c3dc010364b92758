#include "sitepose/drivers/v4l2/v4l2_camera.hpp"

#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include "sitepose/testing/fake_v4l2.hpp"
#include "sitepose/testing/images.hpp"

namespace sitepose::drivers::v4l2 {
namespace {

using testing::FakeDeviceSpec;
using testing::FakeV4l2Io;

constexpr const char* kDev = "/dev/video0";

std::shared_ptr<FakeV4l2Io> fake_with(std::vector<std::uint32_t> formats, cv::Size size = {64, 48},
                                      bool monotonic = true) {
  auto io = std::make_shared<FakeV4l2Io>();
  FakeDeviceSpec spec;
  spec.formats = std::move(formats);
  spec.sizes = {size};
  spec.monotonic_timestamps = monotonic;
  io->add_device(kDev, spec);
  return io;
}

CameraOptions options_for(const std::string& preference = "auto", cv::Size size = {64, 48}) {
  CameraOptions o;
  o.device = kDev;
  o.width = size.width;
  o.height = size.height;
  o.formats = *parse_pixel_preference(preference);
  return o;
}

// Pushes `gray` in the device's format and dequeues it.
RawFrame round_trip(FakeV4l2Io& io, V4l2Camera& camera, const cv::Mat& gray, std::int64_t t_ns) {
  EXPECT_TRUE(io.push(kDev, {testing::encode_frame(gray, io.format(kDev)), t_ns, false}));
  auto frame = camera.dequeue();
  EXPECT_TRUE(frame) << frame.error().message;
  EXPECT_TRUE(frame && *frame);
  return frame && *frame ? std::move(**frame) : RawFrame{};
}

struct NegotiationCase {
  std::vector<std::uint32_t> offered;
  PixelFormat expected;
};

class Negotiation : public ::testing::TestWithParam<NegotiationCase> {};

TEST_P(Negotiation, PicksTheBestOfferedFormatAndConvertsItsFrames) {
  auto io = fake_with(GetParam().offered);
  auto camera = V4l2Camera::open(io, options_for());
  ASSERT_TRUE(camera) << camera.error().message;
  EXPECT_EQ((*camera)->format(), GetParam().expected);
  EXPECT_TRUE(io->streaming(kDev));
  EXPECT_DOUBLE_EQ((*camera)->fps(), 30.0);
  const cv::Mat gray = sitepose::testing::make_texture({64, 48}, 11, 8, 1.0);
  const RawFrame frame = round_trip(*io, **camera, gray, 5'000'000'123);
  ASSERT_EQ(frame.gray.size(), gray.size());
  const double tolerance = GetParam().expected == PixelFormat::kMjpeg ? 3.0 : 0.0;
  EXPECT_LE(cv::norm(frame.gray, gray, cv::NORM_L1) / gray.total(), tolerance);
  EXPECT_EQ(frame.t_ns, 5'000'000'000);  // the kernel's microseconds
  EXPECT_TRUE(frame.kernel_time);
}

INSTANTIATE_TEST_SUITE_P(
    V4l2Camera, Negotiation,
    ::testing::Values(NegotiationCase{{V4L2_PIX_FMT_YUYV}, PixelFormat::kYuyv},
                      NegotiationCase{{V4L2_PIX_FMT_MJPEG}, PixelFormat::kMjpeg},
                      NegotiationCase{{V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_GREY},
                                      PixelFormat::kGrey},
                      NegotiationCase{{V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_YUYV}, PixelFormat::kYuyv}));

TEST(V4l2Camera, RefusesWhatTheDeviceCannotDoAndSaysWhatItOffers) {
  auto io = fake_with({V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_MJPEG});
  auto grey = V4l2Camera::open(io, options_for("GREY"));
  ASSERT_FALSE(grey);
  EXPECT_EQ(grey.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(grey.error().message.find("wanted GREY at 64x48, the device offers YUYV, MJPG"),
            std::string::npos)
      << grey.error().message;
  auto big = V4l2Camera::open(io, options_for("auto", {1280, 720}));
  ASSERT_FALSE(big);
  EXPECT_NE(big.error().message.find("YUYV at 1280x720 became YUYV 64x48"), std::string::npos)
      << big.error().message;
  EXPECT_EQ(io->open_descriptors(), 0) << "failed opens close their descriptor";
  EXPECT_EQ(io->mapped_buffers(), 0u);

  auto absent = V4l2Camera::open(io, [] {
    CameraOptions o = options_for();
    o.device = "/dev/video9";
    return o;
  }());
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().code, ErrorCode::kNotFound);
  EXPECT_NE(absent.error().message.find("/dev/video9"), std::string::npos);

  FakeDeviceSpec meta;
  meta.formats = {V4L2_PIX_FMT_GREY};
  meta.sizes = {{64, 48}};
  meta.capture = false;
  io->add_device("/dev/video1", meta);
  CameraOptions o = options_for();
  o.device = "/dev/video1";
  auto metadata = V4l2Camera::open(io, o);
  ASSERT_FALSE(metadata);
  EXPECT_NE(metadata.error().message.find("not a streaming video capture device"), std::string::npos);
}

TEST(V4l2Camera, FallsBackToHostTimeAndSkipsCorruptBuffers) {
  auto io = fake_with({V4L2_PIX_FMT_GREY}, {64, 48}, /*monotonic=*/false);
  auto camera = V4l2Camera::open(io, options_for());
  ASSERT_TRUE(camera) << camera.error().message;
  const cv::Mat gray(48, 64, CV_8UC1, cv::Scalar(77));
  const auto before = std::chrono::steady_clock::now().time_since_epoch().count();
  const RawFrame frame = round_trip(*io, **camera, gray, 123);
  EXPECT_FALSE(frame.kernel_time);
  EXPECT_GE(frame.t_ns, before);
  EXPECT_EQ((*camera)->counts().host_timestamps, 1u);

  ASSERT_TRUE(io->push(kDev, {testing::encode_frame(gray, V4L2_PIX_FMT_GREY), 0, /*error=*/true}));
  auto corrupt = (*camera)->dequeue();
  ASSERT_TRUE(corrupt);
  EXPECT_FALSE(*corrupt);
  EXPECT_EQ((*camera)->counts().corrupt, 1u);
  // Every buffer went back to the driver: four more frames fit.
  for (int i = 0; i < 4; ++i)
    EXPECT_TRUE(io->push(kDev, {testing::encode_frame(gray, V4L2_PIX_FMT_GREY), 0, false}));
  EXPECT_FALSE(io->push(kDev, {testing::encode_frame(gray, V4L2_PIX_FMT_GREY), 0, false}));
  int got = 0;
  while (true) {
    auto f = (*camera)->dequeue();
    ASSERT_TRUE(f);
    if (!*f) break;
    ++got;
  }
  EXPECT_EQ(got, 4);
  EXPECT_EQ((*camera)->counts().sequence_gaps, 0u);
  ASSERT_TRUE(io->push(kDev, {testing::encode_frame(gray, V4L2_PIX_FMT_GREY), 0, false}));
  ASSERT_TRUE((*camera)->dequeue());
  EXPECT_EQ((*camera)->counts().sequence_gaps, 1u) << "the frame that found no buffer";
}

TEST(V4l2Camera, AnUnpluggedDeviceFailsDequeueAndCloseReleasesEverything) {
  auto io = fake_with({V4L2_PIX_FMT_GREY});
  auto camera = V4l2Camera::open(io, options_for());
  ASSERT_TRUE(camera) << camera.error().message;
  EXPECT_EQ(io->open_descriptors(), 1);
  EXPECT_EQ(io->mapped_buffers(), 4u);
  io->unplug(kDev);
  auto frame = (*camera)->dequeue();
  ASSERT_FALSE(frame);
  EXPECT_NE(frame.error().message.find("No such device"), std::string::npos) << frame.error().message;
  camera->reset();
  EXPECT_EQ(io->open_descriptors(), 0);
  EXPECT_EQ(io->mapped_buffers(), 0u);
}

}  // namespace
}  // namespace sitepose::drivers::v4l2
