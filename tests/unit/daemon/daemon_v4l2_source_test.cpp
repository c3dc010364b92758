// siteposed with source.type v4l2: the keys as read and checked, and the
// source the daemon's factory opens on a fake V4L2 kernel.
#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <chrono>
#include <string>
#include <thread>

#include "sitepose/daemon/daemon.hpp"
#include "sitepose/daemon/daemon_config.hpp"
#include "sitepose/testing/fake_v4l2.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::daemon {
namespace {

using drivers::v4l2::testing::encode_frame;
using drivers::v4l2::testing::FakeDeviceSpec;
using drivers::v4l2::testing::FakeV4l2Io;
using namespace std::chrono_literals;

constexpr int kW = 80;  // one camera's image
constexpr int kH = 60;

const std::string kV4l2Base =
    "outputs:\n  can: {enabled: false}\n  trajectory: {path: t.tum}\n"
    "dynamic: {mode: none}\nsource:\n  type: v4l2\n";

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

std::string load_error(const std::string& text) {
  const auto config = load_daemon_config_from_string(text, "d.yaml", "/etc/sitepose");
  EXPECT_FALSE(config.has_value()) << "loaded without error:\n" << text;
  return config ? "" : config.error().message;
}

// An ideal pair of kW x kH cameras, as `sitepose calibrate` writes it.
void write_calibration(const std::string& path) {
  ASSERT_TRUE(drivers::v4l2::testing::write_ideal_calibration(path, {kW, kH}));
}

// A side-by-side device at /dev/video4 offering `fourcc` at 2kW x kH.
std::shared_ptr<FakeV4l2Io> side_by_side_device(std::uint32_t fourcc = V4L2_PIX_FMT_YUYV) {
  auto io = std::make_shared<FakeV4l2Io>();
  io->add_device("/dev/video4", FakeDeviceSpec{{fourcc}, {cv::Size(2 * kW, kH)}, true, true, 30.0});
  return io;
}

// `more`: further keys of source.v4l2 (", key: value"); `source_keys`: of source.
std::string side_by_side_config(const std::string& more = "", const std::string& source_keys = "") {
  return kV4l2Base + source_keys +
         "  v4l2: {side_by_side: true, left_device: /dev/video4, width: 160, height: 60,\n"
         "         calibration: stereo.yaml, reconnect_min_s: 0.02" +
         more + "}\n";
}

TEST(DaemonV4l2Source, ReadsItsKeysAndResolvesTheCalibration) {
  const auto config = load_daemon_config_from_string(
      kV4l2Base +
          "  wait_for_camera_s: 3\n"
          "  v4l2: {left_device: /dev/v4l/by-id/left, right_device: /dev/v4l/by-id/right, width: 1280,\n"
          "         height: 720, fps: 15, pixel_format: MJPG, buffers: 6, calibration: rig/stereo.yaml,\n"
          "         pair_tolerance_ms: 3, reconnect_max_s: 4}\n",
      "d.yaml", "/etc/sitepose");
  ASSERT_TRUE(config) << config.error().message;
  EXPECT_EQ(config->source_type, "v4l2");
  const drivers::v4l2::V4l2SourceOptions o = v4l2_source_options(*config);
  EXPECT_EQ(o.left_device, "/dev/v4l/by-id/left");
  EXPECT_EQ(o.right_device, "/dev/v4l/by-id/right");
  EXPECT_EQ(o.width, 1280);
  EXPECT_EQ(o.fps, 15.0);
  EXPECT_EQ(o.pixel_format, "MJPG");
  EXPECT_EQ(o.buffers, 6);
  EXPECT_EQ(o.calibration_file, "/etc/sitepose/rig/stereo.yaml");
  EXPECT_EQ(o.pair_tolerance_ns, 3'000'000);
  EXPECT_EQ(o.reconnect_max_s, 4.0);
  EXPECT_EQ(o.wait_for_camera_s, 3.0);
  // Written and read back the same.
  const auto again = load_daemon_config_from_string(to_yaml(*config), "resolved.yaml", "");
  ASSERT_TRUE(again) << again.error().message;
  const drivers::v4l2::V4l2SourceOptions back = v4l2_source_options(*again);
  EXPECT_EQ(back.calibration_file, o.calibration_file);
  EXPECT_EQ(back.pair_tolerance_ns, o.pair_tolerance_ns);
  EXPECT_EQ(back.right_device, o.right_device);
  EXPECT_FALSE(again->v4l2.side_by_side);
}

TEST(DaemonV4l2Source, ErrorsNameTheKeys) {
  const std::string missing = load_error(kV4l2Base + "  v4l2: {left_device: /dev/video0}\n");
  for (const char* key :
       {"source.v4l2.right_device", "source.v4l2.width", "source.v4l2.height", "source.v4l2.calibration"}) {
    EXPECT_TRUE(contains(missing, key)) << key << " in: " << missing;
  }
  const std::string format = load_error(side_by_side_config(", pixel_format: RGB3"));
  EXPECT_TRUE(contains(format, "source.v4l2.pixel_format")) << format;
  EXPECT_TRUE(contains(format, "auto, GREY, YUYV, MJPG")) << format;
  const std::string both = load_error(kV4l2Base +
                                      "  v4l2: {side_by_side: true, left_device: /dev/video0, right_device: "
                                      "/dev/video2, width: 160, height: 60, calibration: c.yaml}\n");
  EXPECT_TRUE(contains(both, "source.v4l2.right_device")) << both;
  const std::string odd = load_error(kV4l2Base +
                                     "  v4l2: {side_by_side: true, left_device: /dev/video0, width: 161, "
                                     "height: 60, calibration: c.yaml}\n");
  EXPECT_TRUE(contains(odd, "width/height")) << odd;
  const std::string buffers = load_error(side_by_side_config(", buffers: 64"));
  EXPECT_TRUE(contains(buffers, "source.v4l2.buffers")) << buffers;
  const std::string type = load_error("source: {type: usb}\n");
  EXPECT_TRUE(contains(type, "source.type")) << type;
}

TEST(DaemonV4l2Source, TheFactoryOpensASideBySideDeviceAndDeliversPairs) {
  testing::TempDir dir;
  write_calibration(dir / "stereo.yaml");
  auto config = load_daemon_config_from_string(side_by_side_config(), "d.yaml", dir.path());
  ASSERT_TRUE(config) << config.error().message;
  auto io = side_by_side_device();
  auto source = open_source(*config, CameraAccess{{}, io});
  ASSERT_TRUE(source) << source.error().message;
  EXPECT_TRUE(contains((*source)->describe(), "v4l2 side-by-side")) << (*source)->describe();
  EXPECT_EQ((*source)->camera().width, kW);
  EXPECT_TRUE((*source)->live());
  cv::Mat frame(kH, 2 * kW, CV_8UC1, cv::Scalar(40));
  frame(cv::Rect(kW, 0, kW, kH)).setTo(200);
  ASSERT_TRUE(io->push("/dev/video4", {encode_frame(frame, V4L2_PIX_FMT_YUYV), 5'000'000'000, false}));
  std::stop_source stop;
  auto event = (*source)->next(stop.get_token(), std::chrono::steady_clock::now() + 2s);
  ASSERT_TRUE(event) << event.error().message;
  ASSERT_EQ(event->kind, pipeline::SourceEventKind::kFrame);
  EXPECT_EQ(event->frame.t_left_ns, 5'000'000'000);
  EXPECT_NEAR(cv::mean(event->frame.left)[0], 40.0, 1.0);
  EXPECT_NEAR(cv::mean(event->frame.right)[0], 200.0, 1.0);
}

TEST(DaemonV4l2Source, AnAbsentDeviceOrAnImpossibleFormatIsExitTwoNamingTheKey) {
  testing::TempDir dir;
  write_calibration(dir / "stereo.yaml");
  auto config =
      load_daemon_config_from_string(side_by_side_config(", pixel_format: YUYV"), "d.yaml", dir.path());
  ASSERT_TRUE(config) << config.error().message;

  auto io = side_by_side_device();
  io->unplug("/dev/video4");
  auto absent = open_source(*config, CameraAccess{{}, io});
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().exit_status(), 2);
  EXPECT_TRUE(contains(absent.error().message, "source.v4l2.left_device: ")) << absent.error().message;
  EXPECT_TRUE(contains(absent.error().message, "/dev/video4")) << absent.error().message;

  auto grey_only = side_by_side_device(V4L2_PIX_FMT_GREY);
  auto format = open_source(*config, CameraAccess{{}, grey_only});
  ASSERT_FALSE(format);
  EXPECT_EQ(format.error().exit_status(), 2);
  EXPECT_TRUE(contains(format.error().message, "source.v4l2.left_device: ")) << format.error().message;

  config->v4l2.options.calibration_file = dir / "absent.yaml";
  auto calibration = open_source(*config, CameraAccess{{}, side_by_side_device()});
  ASSERT_FALSE(calibration);
  EXPECT_EQ(calibration.error().exit_status(), 2);
  EXPECT_TRUE(contains(calibration.error().message, "source.v4l2.calibration: "))
      << calibration.error().message;
}

TEST(DaemonV4l2Source, WaitsForAnAbsentDeviceAsLongAsWaitForCameraS) {
  testing::TempDir dir;
  write_calibration(dir / "stereo.yaml");
  auto config = load_daemon_config_from_string(side_by_side_config("", "  wait_for_camera_s: 10\n"), "d.yaml",
                                               dir.path());
  ASSERT_TRUE(config) << config.error().message;
  auto io = side_by_side_device();
  io->unplug("/dev/video4");
  std::thread plugger([&] {
    std::this_thread::sleep_for(150ms);
    io->plug("/dev/video4");
  });
  const auto start = std::chrono::steady_clock::now();
  auto source = open_source(*config, CameraAccess{{}, io});
  plugger.join();
  ASSERT_TRUE(source) << source.error().message;
  EXPECT_GE(std::chrono::steady_clock::now() - start, 150ms);

  config->wait_for_camera_s = 0.2;
  auto never = side_by_side_device();
  never->unplug("/dev/video4");
  auto gave_up = open_source(*config, CameraAccess{{}, never});
  ASSERT_FALSE(gave_up);
  EXPECT_TRUE(contains(gave_up.error().message, "waited")) << gave_up.error().message;
}

}  // namespace
}  // namespace sitepose::daemon
