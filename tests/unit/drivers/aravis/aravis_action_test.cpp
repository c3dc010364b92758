// AravisSource with trigger action: scripted cameras on one fake PTP clock
// that expose when an action command they match comes due. The commands go
// through the real codec over a DatagramPort that hands each datagram to
// the cameras (as a broadcast would) and returns their acks.
#include "sitepose/drivers/aravis/aravis_source.hpp"

#include <gtest/gtest.h>

#include <deque>
#include <map>
#include <thread>
#include <vector>

#include "aravis_source_test_support.hpp"

namespace sitepose::drivers::aravis {
namespace {

using namespace test;  // aravis_source_test_support.hpp: the names both files use

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
