// The Aravis stereo source on two of Aravis's in-process fake cameras (no
// network), serving a simulated stereo sequence through the cameras' fill
// callbacks: every frame paired, every image intact, left and right of the
// same instant, no slot skipped.
#include <gtest/gtest.h>

#include <arv.h>

#include "fake_stereo_feed.hpp"
#include "sitepose/drivers/aravis/aravis_source.hpp"
#include "sitepose/testing/files.hpp"
#include "sitepose/testing/simulated.hpp"

namespace sitepose::drivers::aravis {
namespace {

using pipeline::SourceEventKind;
using testing::FakeStereoFeed;
using testing::TempDir;
using testing::write_calibration;
using Clock = std::chrono::steady_clock;

constexpr int kW = 320, kH = 180, kFrames = 8;
constexpr double kRateHz = 10.0;  // slack for a busy machine: a late wake-up skips a period

// Only Aravis's fake interface: no GigE discovery broadcast leaves the
// test, and an absent id is resolved at once.
void fake_interface_only() {
  arv_disable_interface("GigEVision");
  arv_disable_interface("USB3Vision");
}

struct Rendered {
  std::vector<cv::Mat> left, right;
  StereoCamera camera;
};

const Rendered& rendered() {
  static const Rendered r = [] {
    Rendered out;
    auto sim = testing::small_simulator("parallel", kW, kH, kFrames, SITEPOSE_SOURCE_DIR "/config/scenarios");
    EXPECT_TRUE(sim) << sim.error().message;
    out.camera = sim->camera();
    for (int i = 0; i < kFrames; ++i) {
      sim::SimFrame f = sim->render(i);
      out.left.push_back(f.left);
      out.right.push_back(f.right);
    }
    return out;
  }();
  return r;
}

AravisSourceOptions fake_pair_options(const std::string& calibration, PixelFormat format) {
  AravisSourceOptions o;
  o.left_id = "Fake_L";
  o.right_id = "Fake_R";
  o.calibration = calibration;
  o.camera.pixel_format = format;
  o.camera.roi = Roi{0, 0, kW, kH};
  o.camera.frame_rate_hz = kRateHz;
  o.camera.exposure_auto = false;
  o.camera.gain_auto = false;
  o.camera.buffer_count = 4;
  // The fake cameras stamp a frame when their thread wakes: allow for a
  // busy machine's scheduling delay, below half the 100 ms period.
  o.pair_tolerance_ms = 20.0;
  return o;
}

void expect_intact_pairs(PixelFormat format) {
  fake_interface_only();
  const Rendered& r = rendered();
  TempDir dir;
  FakeStereoFeed feed(r.left, r.right, kRateHz);
  auto source = AravisSource::open(fake_pair_options(write_calibration(dir, r.camera), format),
                                   aravis_camera_opener(feed.opener_options()));
  ASSERT_TRUE(source) << source.error().message;
  EXPECT_NEAR((*source)->camera().fx, r.camera.fx, 1e-3);
  const int wanted = 2 * kFrames;  // twice round the sequence
  int previous_slot = -1;
  int got = 0;
  const Clock::time_point give_up = Clock::now() + std::chrono::seconds(10);
  while (got < wanted && Clock::now() < give_up) {
    auto event = (*source)->next({}, Clock::now() + std::chrono::seconds(1));
    ASSERT_TRUE(event) << event.error().message;
    if (event->kind != SourceEventKind::kFrame) continue;
    const StereoFrame& f = event->frame;
    const int slot = feed.slot_of(0, f.left);
    ASSERT_GE(slot, 0) << "left image " << got << " is not one of the sequence's";
    EXPECT_EQ(feed.slot_of(1, f.right), slot) << "right image of another instant, pair " << got;
    if (previous_slot >= 0) {
      EXPECT_EQ(slot, (previous_slot + 1) % kFrames) << "a frame was lost, pair " << got;
    }
    EXPECT_LE(std::abs(f.t_left_ns - f.t_right_ns), 20'000'000);
    previous_slot = slot;
    ++got;
  }
  EXPECT_EQ(got, wanted);
  const AravisSourceStats stats = (*source)->stats();
  EXPECT_EQ(stats.pairing.unpaired_left, 0u);
  EXPECT_EQ(stats.pairing.unpaired_right, 0u);
  EXPECT_EQ(stats.failed_buffers, 0u);
  EXPECT_EQ(stats.disconnects, 0u);
  std::printf("fake pair %s: %d pairs, %llu skipped at start, clock offsets %lld / %lld ns\n",
              to_string(format), got, static_cast<unsigned long long>(stats.pairing.skipped_at_start),
              static_cast<long long>(stats.clock_offset_left_ns),
              static_cast<long long>(stats.clock_offset_right_ns));
}

TEST(AravisFakePair, Mono8FramesArrivePairedAndIntact) { expect_intact_pairs(PixelFormat::kMono8); }

TEST(AravisFakePair, Mono16FramesArriveConvertedAndIntact) { expect_intact_pairs(PixelFormat::kMono16); }

TEST(AravisFakePair, AbsentDeviceIsNotFound) {
  fake_interface_only();
  TempDir dir;
  AravisSourceOptions o = fake_pair_options(write_calibration(dir, rendered().camera), PixelFormat::kMono8);
  o.right_id = "No-Such-Camera-0";
  auto source = AravisSource::open(o, aravis_camera_opener());
  ASSERT_FALSE(source);
  EXPECT_EQ(source.error().code, ErrorCode::kNotFound);
  EXPECT_NE(source.error().message.find("right_id = \"No-Such-Camera-0\""), std::string::npos)
      << source.error().message;
}

// What a fake camera holds after the source opened it: read in the opener's
// on_open hook, which runs after the camera is configured.
struct OpenedFeatures {
  std::vector<long long> test_register;
  std::vector<std::string> trigger_mode;
};

AravisOpenerOptions recording(OpenedFeatures& seen) {
  AravisOpenerOptions o;
  o.on_open = [&seen](ArvCamera* camera, const std::string& /*id*/) {
    ArvDevice* device = arv_camera_get_device(camera);
    GError* error = nullptr;
    seen.test_register.push_back(arv_device_get_integer_feature_value(device, "TestRegister", &error));
    const char* mode = arv_device_get_string_feature_value(device, "TriggerMode", &error);
    seen.trigger_mode.emplace_back(mode != nullptr ? mode : "?");
    if (error != nullptr) g_error_free(error);
  };
  return o;
}

TEST(AravisFeatureFile, IsAppliedToBothCamerasBeforeTheSourcesOwnSettings) {
  fake_interface_only();
  TempDir dir;
  AravisSourceOptions o = fake_pair_options(write_calibration(dir, rendered().camera), PixelFormat::kMono8);
  // A trigger set up in the file: free_run clears it, hardware leaves it.
  o.feature_file = dir.write("fake.features",
                             "# the fake camera's own test register, and a trigger line\n"
                             "TestRegister=1234\n\n"
                             "TriggerSelector=FrameStart   # the exposure start\n"
                             "TriggerMode=On\nTriggerSource=Software\nAcquisitionStop\n");
  for (const TriggerMode trigger : {TriggerMode::kFreeRun, TriggerMode::kHardware}) {
    o.camera.trigger = trigger;
    OpenedFeatures seen;
    auto source = AravisSource::open(o, aravis_camera_opener(recording(seen)));
    ASSERT_TRUE(source) << source.error().message;
    EXPECT_EQ(seen.test_register, (std::vector<long long>{1234, 1234}));
    const std::string mode = trigger == TriggerMode::kHardware ? "On" : "Off";
    EXPECT_EQ(seen.trigger_mode, (std::vector<std::string>{mode, mode}));
  }
}

TEST(AravisFeatureFile, AStepTheCameraRefusesNamesTheFileAndLine) {
  fake_interface_only();
  TempDir dir;
  AravisSourceOptions o = fake_pair_options(write_calibration(dir, rendered().camera), PixelFormat::kMono8);
  o.feature_file = dir.write("fake.features", "TestRegister=7\nPtpEnable=true\n");
  auto refused = AravisSource::open(o, aravis_camera_opener());
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidArgument);
  const std::string& m = refused.error().message;
  EXPECT_NE(m.find("feature_file " + o.feature_file + ":2: PtpEnable=true"), std::string::npos) << m;
  o.feature_file = dir / "absent.features";
  auto absent = AravisSource::open(o, aravis_camera_opener());
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().code, ErrorCode::kNotFound);
  EXPECT_EQ(absent.error().message.rfind("feature_file: ", 0), 0u) << absent.error().message;
  o.feature_file.clear();
  o.camera.trigger = TriggerMode::kHardware;
  auto no_file = AravisSource::open(o, aravis_camera_opener());
  ASSERT_FALSE(no_file);
  EXPECT_NE(no_file.error().message.find("trigger: hardware needs a feature_file"), std::string::npos)
      << no_file.error().message;
}

// Aravis's fake camera has neither PTP nor action features: trigger action
// is refused at open, naming what the camera lacks, with no fallback to
// another trigger.
TEST(AravisActionTrigger, AFakeCameraWithoutPtpIsRefusedNamingTheFeature) {
  fake_interface_only();
  TempDir dir;
  AravisSourceOptions o = fake_pair_options(write_calibration(dir, rendered().camera), PixelFormat::kMono8);
  o.camera.trigger = TriggerMode::kAction;
  o.camera.action.destination = "127.0.0.1";
  o.pair_clock = PairClock::kCamera;
  const auto source = AravisSource::open(o, aravis_camera_opener());
  ASSERT_FALSE(source);
  EXPECT_EQ(source.error().code, ErrorCode::kUnsupported);
  EXPECT_EQ(source.error().exit_status(), 2);
  EXPECT_NE(
      source.error().message.find(
          "left_id = \"Fake_L\": Fake_L: trigger action needs PTP, and the camera has neither PtpEnable "
          "nor GevIEEE1588"),
      std::string::npos)
      << source.error().message;
}

}  // namespace
}  // namespace sitepose::drivers::aravis
