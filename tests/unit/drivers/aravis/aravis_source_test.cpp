// AravisSource through its CameraDevice seam: scripted cameras that deliver
// frames, vanish, come back and take software triggers, without Aravis
// (action commands: aravis_action_test.cpp).
#include "sitepose/drivers/aravis/aravis_source.hpp"

#include <gtest/gtest.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "aravis_source_test_support.hpp"

namespace sitepose::drivers::aravis {
namespace {

using namespace test;  // aravis_source_test_support.hpp: the names both files use

// What the test scripts for each device id.
struct Rig {
  struct Camera {
    bool present = true;
    bool unplugged = false;  // an open device now fails its polls
    std::deque<CameraFrame> frames;
    int opens = 0;
    int triggers = 0;
    std::uint64_t underruns = 0;  // the open device's count
    std::vector<Clock::time_point> trigger_times;
    std::function<void()> on_trigger;  // runs inside trigger(), on the thread that sends it
  };
  std::map<std::string, Camera> cameras;

  // Captured at t_ms, arriving on the host latency_ms later.
  void feed(const std::string& id, std::int64_t t_ms, std::uint8_t value, std::int64_t latency_ms = 0) {
    CameraFrame f;
    f.gray = cv::Mat(kH, kW, CV_8UC1, cv::Scalar(value));
    f.camera_t_ns = t_ms * kMs;
    f.host_t_ns = (t_ms + latency_ms) * kMs;
    cameras[id].frames.push_back(std::move(f));
  }
  // A pair at t_ms: left value v, right value v + 1.
  void feed_pair(std::int64_t t_ms, std::uint8_t v) {
    feed("L", t_ms, v);
    feed("R", t_ms, static_cast<std::uint8_t>(v + 1));
  }
};

// Holds its rig entry (std::map references stay valid), so that a trigger
// sent from another thread looks nothing up in the map.
class ScriptedCamera final : public CameraDevice {
 public:
  ScriptedCamera(Rig& rig, std::string id) : rig_(rig), camera_(rig.cameras[id]), id_(std::move(id)) {}
  int width() const override { return kW; }
  int height() const override { return kH; }
  std::string describe() const override { return id_; }
  Expected<Poll> poll(std::chrono::microseconds /*timeout*/) override {
    Rig::Camera& c = rig_.cameras[id_];
    if (c.unplugged) return make_error(ErrorCode::kIoError, id_ + ": control channel lost");
    Poll p;
    if (!c.frames.empty()) {
      p.kind = PollKind::kFrame;
      p.frame = std::move(c.frames.front());
      c.frames.pop_front();
    }
    return p;
  }
  Status trigger() override {
    ++camera_.triggers;
    camera_.trigger_times.push_back(Clock::now());
    if (camera_.on_trigger) camera_.on_trigger();
    return ok_status();
  }
  std::uint64_t failed_buffers() const override { return 0; }
  std::uint64_t underruns() const override { return rig_.cameras[id_].underruns; }

 private:
  Rig& rig_;
  Rig::Camera& camera_;
  std::string id_;
};

CameraOpener opener(Rig& rig) {
  return [&rig](const std::string& id, const CameraSettings&) -> Expected<std::unique_ptr<CameraDevice>> {
    Rig::Camera& c = rig.cameras[id];
    ++c.opens;
    if (!c.present || c.unplugged) return make_error(ErrorCode::kNotFound, "camera " + id + ": not found");
    return std::unique_ptr<CameraDevice>(new ScriptedCamera(rig, id));
  };
}

TEST(AravisSource, AbsentCameraIsAnErrorNamingTheSideAndId) {
  TempDir dir;
  Rig rig;
  rig.cameras["R"].present = false;
  const auto source = AravisSource::open(options(dir), opener(rig));
  ASSERT_FALSE(source);
  EXPECT_EQ(source.error().code, ErrorCode::kNotFound);
  EXPECT_NE(source.error().message.find("right_id = \"R\": camera R: not found"), std::string::npos)
      << source.error().message;
}

TEST(AravisSource, BadOptionsNameTheirFields) {
  TempDir dir;
  Rig rig;
  AravisSourceOptions o = options(dir);
  o.right_id = "L";
  o.pair_tolerance_ms = 30.0;  // more than half of 50 ms
  const auto source = AravisSource::open(o, opener(rig));
  ASSERT_FALSE(source);
  EXPECT_NE(source.error().message.find("right_id: must differ"), std::string::npos)
      << source.error().message;
  EXPECT_NE(source.error().message.find("pair_tolerance_ms"), std::string::npos) << source.error().message;
}

TEST(AravisSource, WaitsForACameraThatAppearsLate) {
  TempDir dir;
  Rig rig;
  rig.cameras["L"].present = false;
  AravisSourceOptions o = options(dir);
  o.wait_for_camera_s = 5.0;
  // The opener makes the camera appear on its third attempt.
  CameraOpener base = opener(rig);
  CameraOpener appearing = [&](const std::string& id, const CameraSettings& s) {
    if (id == "L" && rig.cameras["L"].opens >= 2) rig.cameras["L"].present = true;
    return base(id, s);
  };
  const auto source = AravisSource::open(o, appearing);
  ASSERT_TRUE(source) << source.error().message;
  EXPECT_EQ(rig.cameras["L"].opens, 3);
}

TEST(AravisSource, DeliversPairedFramesInOrderOnTheHostClock) {
  TempDir dir;
  Rig rig;
  auto source = AravisSource::open(options(dir), opener(rig));
  ASSERT_TRUE(source) << source.error().message;
  EXPECT_EQ((*source)->camera().width, kW);
  for (int i = 0; i < 5; ++i) rig.feed_pair(1000 + 50 * i, static_cast<std::uint8_t>(10 * i));
  rig.feed("R", 1251, 0);  // a right frame without partner at the end
  std::int64_t last_t = 0;
  for (int i = 0; i < 5; ++i) {
    auto event = next_within(**source, 500ms);
    ASSERT_TRUE(event) << event.error().message;
    ASSERT_EQ(event->kind, SourceEventKind::kFrame) << i;
    const StereoFrame& f = event->frame;
    EXPECT_EQ(f.seq, i);
    EXPECT_EQ(f.left.at<std::uint8_t>(0, 0), 10 * i);
    EXPECT_EQ(f.right.at<std::uint8_t>(0, 0), 10 * i + 1);
    EXPECT_GT(f.t_ns(), last_t);
    last_t = f.t_ns();
  }
  EXPECT_EQ(last_t, 1200 * kMs);  // the scripted host arrival is the capture time: offset 0
  auto event = next_within(**source, 50ms);
  ASSERT_TRUE(event);
  EXPECT_EQ(event->kind, SourceEventKind::kTimeout);
  EXPECT_EQ((*source)->stats().pairing.pairs, 5u);
}

// A loaded host delays the first frames by tens of milliseconds: here the
// right camera's first frame arrives 30 ms after capture, every other frame
// 1 ms. Until a camera's clock mapping has settled, its frames' host times
// may still move earlier, so a frame that looks older than them is not
// dropped yet: the first pair is made once the right mapping has come down.
TEST(AravisSource, ALatencySpikeOnTheFirstFramesLosesNoPair) {
  TempDir dir;
  Rig rig;
  auto source = AravisSource::open(options(dir), opener(rig));
  ASSERT_TRUE(source) << source.error().message;
  for (int i = 0; i < 5; ++i) {
    const std::int64_t t_ms = 1000 + 50 * i;
    rig.feed("L", t_ms, static_cast<std::uint8_t>(10 * i), 1);
    rig.feed("R", t_ms, static_cast<std::uint8_t>(10 * i + 1), i == 0 ? 30 : 1);
  }
  for (int i = 0; i < 5; ++i) {
    auto event = next_within(**source, 500ms);
    ASSERT_TRUE(event) << event.error().message;
    ASSERT_EQ(event->kind, SourceEventKind::kFrame) << i;
    EXPECT_EQ(event->frame.left.at<std::uint8_t>(0, 0), 10 * i);
    EXPECT_EQ(event->frame.right.at<std::uint8_t>(0, 0), 10 * i + 1);
    EXPECT_EQ(event->frame.t_ns(), (1000 + 50 * i + 1) * kMs) << i;  // capture + the 1 ms minimum latency
  }
  const PairerCounts counts = (*source)->stats().pairing;
  EXPECT_EQ(counts.pairs, 5u);
  EXPECT_EQ(counts.unpaired_left + counts.unpaired_right + counts.skipped_at_start, 0u);
}

TEST(AravisSource, UnpluggedCameraStallsThenReconnectsWithBackoff) {
  TempDir dir;
  Rig rig;
  AravisSourceOptions o = options(dir);
  o.lost_timeout_s = 30.0;  // the left camera's silence here is the script's, not a fault
  auto opened = AravisSource::open(o, opener(rig));
  ASSERT_TRUE(opened) << opened.error().message;
  AravisSource& source = **opened;
  rig.feed_pair(1000, 1);
  auto first = next_within(source, 500ms);
  ASSERT_TRUE(first && first->kind == SourceEventKind::kFrame);

  rig.cameras["R"].unplugged = true;
  auto stalled = next_within(source, 150ms);
  ASSERT_TRUE(stalled) << "a lost camera is not a source failure";
  EXPECT_EQ(stalled->kind, SourceEventKind::kTimeout);
  EXPECT_EQ(source.stats().disconnects, 1u);
  EXPECT_GE(rig.cameras["R"].opens, 3) << "reconnect attempts while the camera is away";
  EXPECT_NE(source.describe().find("R (lost)"), std::string::npos);

  rig.cameras["R"].unplugged = false;
  rig.cameras["R"].frames.clear();
  rig.cameras["L"].frames.clear();
  rig.feed_pair(2000, 2);  // both cameras start again
  auto back = next_within(source, 500ms);
  ASSERT_TRUE(back) << back.error().message;
  ASSERT_EQ(back->kind, SourceEventKind::kFrame);
  EXPECT_EQ(back->frame.left.at<std::uint8_t>(0, 0), 2);
  EXPECT_EQ(back->frame.seq, 1);
  EXPECT_EQ(source.stats().reconnects, 1u);
}

TEST(AravisSource, FramesLostToAnEmptyBufferPoolWhileCapturingAreCountedAcrossAReconnect) {
  TempDir dir;
  Rig rig;
  AravisSourceOptions o = options(dir);
  o.lost_timeout_s = 30.0;
  auto opened = AravisSource::open(o, opener(rig));
  ASSERT_TRUE(opened) << opened.error().message;
  AravisSource& source = **opened;
  rig.cameras["R"].underruns = 5;  // before capture began: the daemon still starting
  rig.feed_pair(1000, 1);
  auto first = next_within(source, 500ms);
  ASSERT_TRUE(first && first->kind == SourceEventKind::kFrame);
  EXPECT_EQ(source.stats().underruns, 0u);
  rig.cameras["L"].underruns = 2;
  rig.feed_pair(1050, 3);
  auto second = next_within(source, 500ms);
  ASSERT_TRUE(second && second->kind == SourceEventKind::kFrame);
  EXPECT_EQ(source.stats().underruns, 2u);

  rig.cameras["L"].unplugged = true;
  auto stalled = next_within(source, 50ms);
  ASSERT_TRUE(stalled);
  EXPECT_EQ(source.stats().underruns, 2u) << "the lost connection's count is kept";
  rig.cameras["L"].underruns = 1;  // the new connection's own count
  rig.cameras["L"].unplugged = false;
  rig.cameras["L"].frames.clear();
  rig.cameras["R"].frames.clear();
  rig.feed_pair(2000, 2);
  auto back = next_within(source, 500ms);
  ASSERT_TRUE(back && back->kind == SourceEventKind::kFrame);
  EXPECT_EQ(source.stats().reconnects, 1u);
  EXPECT_EQ(source.stats().underruns, 3u);
}

TEST(AravisSource, SilentCameraIsLostAfterTheTimeout) {
  TempDir dir;
  Rig rig;
  auto opened = AravisSource::open(options(dir), opener(rig));
  ASSERT_TRUE(opened);
  AravisSource& source = **opened;
  const Clock::time_point t0 = Clock::now();
  // Left keeps sending, right says nothing: lost after lost_timeout_s (0.2 s).
  for (int i = 0; i < 40 && source.stats().disconnects == 0; ++i) {
    rig.feed("L", 1000 + 50 * i, 1);
    auto event = next_within(source, 20ms);
    ASSERT_TRUE(event);
    EXPECT_EQ(event->kind, SourceEventKind::kTimeout);
  }
  EXPECT_EQ(source.stats().disconnects, 1u);
  EXPECT_GE(Clock::now() - t0, 200ms);
}

TEST(AravisSource, SoftwareTriggerFiresBothCamerasAtTheFrameRate) {
  TempDir dir;
  Rig rig;
  AravisSourceOptions o = options(dir);
  o.camera.trigger = TriggerMode::kSoftware;
  o.camera.frame_rate_hz = 100.0;
  o.lost_timeout_s = 10.0;
  auto opened = AravisSource::open(o, opener(rig));
  ASSERT_TRUE(opened);
  const Clock::time_point t0 = Clock::now();
  while (Clock::now() - t0 < 105ms) (void)next_within(**opened, 5ms);
  // Both cameras every period (10 ms at 100 Hz), never faster; a busy
  // machine may stretch a period (a late trigger is not made up for).
  const auto& times = rig.cameras["L"].trigger_times;
  EXPECT_GE(times.size(), 3u);
  for (std::size_t i = 1; i < times.size(); ++i) EXPECT_GE(times[i] - times[i - 1], 9500us) << i;
  EXPECT_EQ(rig.cameras["L"].triggers, rig.cameras["R"].triggers);
}

// Sent one after the other, the second trigger would leave a full round trip
// of the first after it: the cameras would expose that far apart (and a whole
// frame apart where a camera serves triggers on its own clock's tick, as
// Aravis's fake GigE camera does every 40 ms). Here the left camera's
// trigger returns only once the right camera's has been sent, or after 2 s.
TEST(AravisSource, SoftwareTriggersGoToBothCamerasTogether) {
  TempDir dir;
  Rig rig;
  std::mutex mutex;
  std::condition_variable cv;
  bool right_sent = false;
  std::vector<bool> right_sent_during_left;
  rig.cameras["R"].on_trigger = [&] {
    std::lock_guard lock(mutex);
    right_sent = true;
    cv.notify_all();
  };
  rig.cameras["L"].on_trigger = [&] {
    std::unique_lock lock(mutex);
    right_sent_during_left.push_back(cv.wait_for(lock, 2s, [&] { return right_sent; }));
    right_sent = false;
  };
  AravisSourceOptions o = options(dir);
  o.camera.trigger = TriggerMode::kSoftware;
  o.camera.frame_rate_hz = 100.0;
  o.lost_timeout_s = 10.0;
  auto opened = AravisSource::open(o, opener(rig));
  ASSERT_TRUE(opened);
  const Clock::time_point give_up = Clock::now() + 5s;
  while (rig.cameras["L"].triggers < 3 && Clock::now() < give_up) (void)next_within(**opened, 5ms);
  ASSERT_GE(right_sent_during_left.size(), 3u);
  for (std::size_t i = 0; i < right_sent_during_left.size(); ++i) EXPECT_TRUE(right_sent_during_left[i]) << i;
  EXPECT_EQ(rig.cameras["L"].triggers, rig.cameras["R"].triggers);
}

TEST(AravisSource, StopRequestEndsAWaitPromptly) {
  TempDir dir;
  Rig rig;
  auto opened = AravisSource::open(options(dir), opener(rig));
  ASSERT_TRUE(opened);
  std::stop_source stop;
  stop.request_stop();
  auto event = (*opened)->next(stop.get_token(), Clock::now() + 10s);
  ASSERT_TRUE(event);
  EXPECT_EQ(event->kind, SourceEventKind::kEnd);
}

}  // namespace
}  // namespace sitepose::drivers::aravis
