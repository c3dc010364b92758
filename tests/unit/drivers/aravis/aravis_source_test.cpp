// AravisSource through its CameraDevice seam: scripted cameras that deliver
// frames, vanish and come back, or expose on action commands, without Aravis.
#include "sitepose/drivers/aravis/aravis_source.hpp"

#include <gtest/gtest.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "sitepose/testing/files.hpp"

namespace sitepose::drivers::aravis {
namespace {

using pipeline::SourceEventKind;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;
using testing::TempDir;

constexpr int kW = 64, kH = 48;
constexpr std::int64_t kMs = 1'000'000;

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

AravisSourceOptions options(const TempDir& dir) {
  AravisSourceOptions o;
  o.left_id = "L";
  o.right_id = "R";
  o.calibration = dir.write("calib.txt",
                            "P0: 50 0 32 0 0 50 24 0 0 0 1 0\n"
                            "P1: 50 0 32 -10 0 50 24 0 0 0 1 0\n");
  o.camera.frame_rate_hz = 20.0;
  o.pair_tolerance_ms = 2.0;
  o.lost_timeout_s = 0.2;
  o.reconnect_min_s = 0.01;
  o.reconnect_max_s = 0.04;
  return o;
}

Expected<pipeline::SourceEvent> next_within(AravisSource& source, std::chrono::milliseconds timeout) {
  return source.next({}, Clock::now() + timeout);
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

// ---- trigger action -----------------------------------------------------
// Scripted cameras on one fake PTP clock that expose when an action command
// they match comes due. The commands go through the real codec over a
// DatagramPort that hands each datagram to the cameras (as a broadcast
// would) and returns their acks.

// PTP time (TAI ns) is far from the host's steady clock.
constexpr std::int64_t kPtpEpochNs = 1'700'000'000'000'000'000;

std::int64_t steady_ns(Clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

struct ActionRig {
  struct Camera {
    ActionSettings keys;             // as the source configured the camera
    std::int64_t clock_skew_ns = 0;  // its PTP clock minus the grandmaster's
    std::string host_address;
    std::deque<std::int64_t> scheduled_ns;  // action times it will expose at
    int latches = 0;
    std::uint8_t value = 0;
  };
  std::map<std::string, Camera> cameras;
  std::vector<gvcp::ActionPacket> commands;
  std::vector<std::int64_t> lead_at_send_ns;  // action time minus PTP time when it was sent
  std::string destination;
  std::uint16_t port = 0;
  std::uint32_t mask_override = 0;  // non-zero: the cameras' group mask, whatever the source set

  static std::int64_t ptp_now_ns() { return kPtpEpochNs + steady_ns(Clock::now()); }
};

class ActionCamera final : public CameraDevice {
 public:
  ActionCamera(ActionRig::Camera& camera, std::string id) : camera_(camera), id_(std::move(id)) {}
  int width() const override { return kW; }
  int height() const override { return kH; }
  std::string describe() const override { return id_; }
  Expected<Poll> poll(std::chrono::microseconds /*timeout*/) override {
    Poll p;
    const std::int64_t now_ns = ActionRig::ptp_now_ns() + camera_.clock_skew_ns;
    if (camera_.scheduled_ns.empty() || camera_.scheduled_ns.front() > now_ns) return p;
    const std::int64_t exposed_ns = camera_.scheduled_ns.front();
    camera_.scheduled_ns.pop_front();
    p.kind = PollKind::kFrame;
    p.frame.gray = cv::Mat(kH, kW, CV_8UC1, cv::Scalar(camera_.value));
    p.frame.camera_t_ns = exposed_ns;
    p.frame.host_t_ns = exposed_ns - kPtpEpochNs + 2 * kMs;  // arrives 2 ms after the exposure
    return p;
  }
  Status trigger() override { return make_error(ErrorCode::kUnsupported, "no software trigger here"); }
  std::uint64_t failed_buffers() const override { return 0; }
  std::uint64_t underruns() const override { return 0; }
  Expected<ClockLatch> latch_clock() override {
    ++camera_.latches;
    return ClockLatch{ActionRig::ptp_now_ns() + camera_.clock_skew_ns, Clock::now()};
  }
  std::string host_address_ipv4() const override { return camera_.host_address; }

 private:
  ActionRig::Camera& camera_;
  std::string id_;
};

// Every datagram reaches every camera, which acts as a GigE Vision device
// does: only on its own keys and a common group mask bit.
class BroadcastPort final : public DatagramPort {
 public:
  explicit BroadcastPort(ActionRig& rig) : rig_(rig) {}
  Status send(std::span<const std::uint8_t> datagram) override {
    const auto packet = gvcp::decode_action_command(datagram);
    if (!packet) return make_error(ErrorCode::kIoError, "the test's cameras got: " + packet.error().message);
    rig_.commands.push_back(*packet);
    const gvcp::ActionCommand& c = packet->command;
    if (c.action_time_ns) {
      rig_.lead_at_send_ns.push_back(static_cast<std::int64_t>(*c.action_time_ns) - ActionRig::ptp_now_ns());
    }
    for (auto& [id, camera] : rig_.cameras) {
      const std::uint32_t mask = rig_.mask_override != 0 ? rig_.mask_override : camera.keys.group_mask;
      if (!gvcp::action_matches(c, camera.keys.device_key, camera.keys.group_key, mask)) continue;
      camera.scheduled_ns.push_back(static_cast<std::int64_t>(c.action_time_ns.value_or(0)));
      if (packet->ack_required)
        acks_.push_back(gvcp::encode_action_ack({gvcp::kStatusSuccess, packet->request_id}));
    }
    return ok_status();
  }
  Expected<std::optional<std::vector<std::uint8_t>>> receive(std::chrono::microseconds timeout) override {
    if (acks_.empty()) {
      std::this_thread::sleep_for(timeout);  // nothing will come: as a socket waits out its timeout
      return std::optional<std::vector<std::uint8_t>>{};
    }
    auto ack = std::move(acks_.front());
    acks_.pop_front();
    return std::optional<std::vector<std::uint8_t>>{std::move(ack)};
  }

 private:
  ActionRig& rig_;
  std::deque<std::vector<std::uint8_t>> acks_;
};

CameraOpener action_opener(ActionRig& rig) {
  return [&rig](const std::string& id, const CameraSettings& s) -> Expected<std::unique_ptr<CameraDevice>> {
    if (s.trigger != TriggerMode::kAction) return make_error(ErrorCode::kInvalidArgument, "expected kAction");
    ActionRig::Camera& c = rig.cameras[id];
    c.keys = s.action;
    return std::unique_ptr<CameraDevice>(new ActionCamera(c, id));
  };
}

DatagramPortOpener ports(ActionRig& rig) {
  return [&rig](const std::string& address, std::uint16_t port) -> Expected<std::unique_ptr<DatagramPort>> {
    rig.destination = address;
    rig.port = port;
    return std::unique_ptr<DatagramPort>(new BroadcastPort(rig));
  };
}

AravisSourceOptions action_options(const TempDir& dir) {
  AravisSourceOptions o = options(dir);
  o.camera.trigger = TriggerMode::kAction;
  o.camera.action = {0x5EC0, 0x24, 0x2, "192.0.2.255", 10.0};
  o.pair_clock = PairClock::kCamera;
  o.pair_tolerance_ms = 1.0;
  o.lost_timeout_s = 0.5;
  return o;
}

ActionRig two_cameras() {
  ActionRig rig;
  rig.cameras["L"].value = 10;
  rig.cameras["R"].value = 11;
  return rig;
}

TEST(AravisSourceAction, BothCamerasExposeAtTheScheduledPtpTimeAndPair) {
  TempDir dir;
  ActionRig rig = two_cameras();
  auto source = AravisSource::open(action_options(dir), action_opener(rig), {}, ports(rig));
  ASSERT_TRUE(source) << source.error().message;
  EXPECT_EQ(rig.destination, "192.0.2.255");
  EXPECT_EQ(rig.port, gvcp::kGvcpPort);
  EXPECT_EQ(rig.cameras["L"].keys.device_key, 0x5EC0u);
  EXPECT_EQ(rig.cameras["R"].keys.group_mask, 0x2u);

  constexpr int kFrames = 8;
  for (int i = 0; i < kFrames; ++i) {
    auto event = (*source)->next({}, Clock::now() + 1s);
    ASSERT_TRUE(event) << event.error().message;
    ASSERT_EQ(event->kind, SourceEventKind::kFrame) << i;
    const StereoFrame& f = event->frame;
    EXPECT_EQ(f.left.at<std::uint8_t>(0, 0), 10);
    EXPECT_EQ(f.right.at<std::uint8_t>(0, 0), 11);
    EXPECT_EQ(f.t_right_ns, f.t_left_ns) << "both exposed at one action time";
  }
  // One command per frame, each for both cameras at its own PTP time, a
  // frame period apart at least, scheduled the lead time ahead.
  ASSERT_GE(rig.commands.size(), static_cast<std::size_t>(kFrames));
  for (std::size_t i = 0; i < rig.commands.size(); ++i) {
    const gvcp::ActionCommand& c = rig.commands[i].command;
    EXPECT_EQ(c.device_key, 0x5EC0u);
    EXPECT_EQ(c.group_key, 0x24u);
    ASSERT_TRUE(c.action_time_ns.has_value());
    EXPECT_LE(rig.lead_at_send_ns[i], 10 * kMs);
    EXPECT_GT(rig.lead_at_send_ns[i], 5 * kMs) << "the PTP time extrapolated from the latch ran late";
    if (i > 0) {
      EXPECT_GE(*c.action_time_ns - *rig.commands[i - 1].command.action_time_ns, 50u * kMs - kMs);
    }
  }
  const AravisSourceStats stats = (*source)->stats();
  EXPECT_EQ(stats.pairing.pairs, static_cast<std::uint64_t>(kFrames));
  EXPECT_EQ(stats.action_acks_missing, 0u);
  EXPECT_EQ(stats.action_acks_refused, 0u);
  EXPECT_GE(stats.actions_sent, static_cast<std::uint64_t>(kFrames));
  EXPECT_LT(std::abs(stats.ptp_skew_ns), kMs);
  // Latched once a second, not per frame: 8 frames at 20 Hz take under 1 s.
  EXPECT_EQ(rig.cameras["L"].latches, 1);
  EXPECT_EQ(rig.cameras["R"].latches, 1);
}

TEST(AravisSourceAction, CamerasOutsideTheGroupMaskNeitherExposeNorAcknowledge) {
  TempDir dir;
  ActionRig rig = two_cameras();
  rig.mask_override = 0x1;  // the source sends mask 0x2
  auto source = AravisSource::open(action_options(dir), action_opener(rig), {}, ports(rig));
  ASSERT_TRUE(source) << source.error().message;
  auto event = (*source)->next({}, Clock::now() + 300ms);
  ASSERT_TRUE(event) << event.error().message;
  EXPECT_EQ(event->kind, SourceEventKind::kTimeout);
  const AravisSourceStats stats = (*source)->stats();
  EXPECT_GE(stats.actions_sent, 2u);
  EXPECT_EQ(stats.action_acks_missing, 2 * stats.actions_sent);
  EXPECT_EQ(stats.pairing.pairs, 0u);
}

// A camera on another clock would expose 20 ms apart from its partner yet
// stamp the same action time: such frames must not come out as a pair.
TEST(AravisSourceAction, CamerasOnDifferentClocksGetNoActions) {
  TempDir dir;
  ActionRig rig = two_cameras();
  rig.cameras["R"].clock_skew_ns = 20 * kMs;  // the right camera follows another master
  auto source = AravisSource::open(action_options(dir), action_opener(rig), {}, ports(rig));
  ASSERT_TRUE(source) << source.error().message;
  auto event = (*source)->next({}, Clock::now() + 200ms);
  ASSERT_TRUE(event) << event.error().message;
  EXPECT_EQ(event->kind, SourceEventKind::kTimeout);
  EXPECT_NEAR(static_cast<double>((*source)->stats().ptp_skew_ns), 20.0 * kMs, 1.0 * kMs);
  EXPECT_EQ((*source)->stats().actions_sent, 0u);
  EXPECT_TRUE(rig.commands.empty());
}

TEST(AravisSourceAction, WithoutADestinationTheLeftCamerasNicIsNeeded) {
  TempDir dir;
  AravisSourceOptions o = action_options(dir);
  o.camera.action.destination = "";
  ActionRig rig = two_cameras();  // not reached over IP
  auto source = AravisSource::open(o, action_opener(rig), {}, ports(rig));
  ASSERT_FALSE(source);
  EXPECT_NE(source.error().message.find(
                "action.destination: empty, and the left camera (L) is not reached over IPv4"),
            std::string::npos)
      << source.error().message;

  ActionRig on_lo = two_cameras();
  on_lo.cameras["L"].host_address = "127.0.0.1";  // lo: no broadcast address
  source = AravisSource::open(o, action_opener(on_lo), {}, ports(on_lo));
  ASSERT_FALSE(source);
  EXPECT_NE(
      source.error().message.find("action.destination: interface lo (127.0.0.1) has no broadcast address"),
      std::string::npos)
      << source.error().message;
}

TEST(AravisSourceAction, OptionsThatCannotWorkAreNamed) {
  TempDir dir;
  AravisSourceOptions o = action_options(dir);
  o.pair_clock = PairClock::kHost;
  o.camera.action.group_mask = 0;
  o.camera.action.lead_time_ms = 60.0;  // a period is 50 ms
  o.camera.action.destination = "cameras";
  const Status st = check_aravis_source_options(o);
  ASSERT_FALSE(st);
  for (const char* key : {"pair_clock: trigger action needs camera", "action.group_mask: must not be 0",
                          "action.lead_time_ms = 60.000000: must be in (0, 50.000000)",
                          "action.destination = \"cameras\": expected a dotted IPv4 address"}) {
    EXPECT_NE(st.error().message.find(key), std::string::npos) << key << " in: " << st.error().message;
  }
}

}  // namespace
}  // namespace sitepose::drivers::aravis
