// The daemon outputs' one time base: a pose's capture time on the source's
// clock mapped to UTC once, and every output (pose_t, health_t, the CAN
// sink's stamps, 129029 date/time) stamping it alike. In-process, with a
// fake clock; the process end to end is daemon_e2e_test.

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "sitepose/daemon/outputs.hpp"
#include "sitepose/output/lcm_messages.hpp"
#include "sitepose/output/nmea2000.hpp"

namespace sitepose::daemon {
namespace {

using namespace std::chrono_literals;

constexpr std::int64_t kUtcNow_ns = 1'764'660'000'123'456'000;  // 2025-12-02
const pipeline::SteadyTime kSteadyNow = pipeline::SteadyTime{} + 1000s;

TimeBase::Clock fixed_clock(std::int64_t system_ns = kUtcNow_ns) {
  return [system_ns] { return TimeBase::Now{system_ns, kSteadyNow}; };
}

pipeline::PosePacket packet(std::int64_t t_ns, pipeline::SteadyTime captured, std::int64_t seq = 0) {
  pipeline::PosePacket p;
  p.pose.t_ns = t_ns;
  p.pose.seq = seq;
  p.pose.state = TrackingState::kOk;
  p.pose.T_world_cam = SE3::identity();
  p.pose.covariance = Matrix6d::Identity() * 1e-6;
  p.captured = captured;
  return p;
}

TEST(TimeBase, ShiftsSourceStampsToTheSystemClockAtTheFirstCapture) {
  TimeBase time(fixed_clock());
  // Captured 40 ms ago on the steady clock, stamped 2.5 s by a replay.
  const std::int64_t first = time.capture_utc_ns(packet(2'500'000'000, kSteadyNow - 40ms));
  EXPECT_EQ(first, kUtcNow_ns - 40'000'000);
  // Later stamps keep the source's spacing, whenever they are published.
  EXPECT_EQ(time.capture_utc_ns(packet(2'600'000'000, kSteadyNow - 1ms)), first + 100'000'000);
  EXPECT_EQ(time.offset_ns(), kUtcNow_ns - 40'000'000 - 2'500'000'000);
  EXPECT_DOUBLE_EQ(time.latency_ms(packet(0, kSteadyNow - 25ms)), 25.0);
}

TEST(TimeBase, KeepsStampsThatAreAlreadyUtc) {
  TimeBase time(fixed_clock());
  const std::int64_t stamp = kUtcNow_ns - 300'000'000;  // a PTP camera, 0.3 s before "now"
  EXPECT_EQ(time.capture_utc_ns(packet(stamp, kSteadyNow)), stamp);
  EXPECT_EQ(time.offset_ns(), 0);
}

// A CanSink that keeps what it is given.
class RecordingSink final : public output::CanSink {
 public:
  std::vector<std::pair<std::int64_t, output::CanFrame>> frames;
  Status flush() override { return ok_status(); }

 protected:
  Status do_send(std::int64_t t_ns, const output::CanFrame& frame) override {
    frames.emplace_back(t_ns, frame);
    return ok_status();
  }
};

GeoConfig fixed_geo() {
  GeoConfig g;
  g.mode = GeoMode::kFixed;
  g.origin = {48.137, 11.575, 520.0};
  return g;
}

TEST(DaemonOutputs, PoseHealthCanStampsAndN2kDateTimeShareOneUtcClock) {
  auto anchoring = Anchoring::create(fixed_geo());
  ASSERT_TRUE(anchoring);
  Anchoring& a = **anchoring;
  a.time_base() = TimeBase(fixed_clock());

  std::vector<std::vector<std::uint8_t>> sent;
  auto publisher = output::LcmPublisher::create_with_sender(
      output::LcmOptions{}, [&](const std::string&, const void* data, unsigned size) {
        const auto* b = static_cast<const std::uint8_t*>(data);
        sent.emplace_back(b, b + size);
        return 0;
      });
  ASSERT_TRUE(publisher);
  LcmOutput lcm(std::move(*publisher), a);
  auto sink = std::make_unique<RecordingSink>();
  RecordingSink* can_frames = sink.get();
  CanOutput can(output::CanOutputOptions{}, std::move(sink), a);

  const auto p0 = packet(7'000'000'000, kSteadyNow - 30ms, 0);
  const auto p1 = packet(7'166'666'667, kSteadyNow - 10ms, 1);
  for (const auto& p : {p0, p1}) {
    ASSERT_TRUE(lcm.publish(p));
    ASSERT_TRUE(can.publish(p));
  }
  ASSERT_TRUE(lcm.publish_health(pipeline::PipelineHealth{}));
  ASSERT_EQ(sent.size(), 3u);
  auto pose1 = output::decode_lcm<sitepose::pose_t>(sent[1].data(), sent[1].size());
  auto health = output::decode_lcm<sitepose::health_t>(sent[2].data(), sent[2].size());
  ASSERT_TRUE(pose1 && health);

  const std::int64_t utc1_ns = kUtcNow_ns - 30'000'000 + 166'666'667;
  EXPECT_EQ(pose1->utime, utc1_ns / 1000);
  EXPECT_EQ(health->utime, kUtcNow_ns / 1000);
  EXPECT_EQ(health->last_pose_utime, pose1->utime);
  EXPECT_FLOAT_EQ(health->last_pose_latency_ms, 10.0f);

  // The second pose's frames: every stamp its UTC time; 129029's date and
  // time of day the same instant (1e-4 s resolution).
  const std::size_t per_pose = can_frames->frames.size() / 2;
  ASSERT_GT(per_pose, 0u);
  for (std::size_t i = per_pose; i < can_frames->frames.size(); ++i) {
    EXPECT_EQ(can_frames->frames[i].first, utc1_ns) << i;
  }
  // 129029 is a fast packet: frame 0 = [seq|0, length, payload 0..5],
  // frame 1 = [seq|1, payload 6..12]; date = bytes 1-2, time = bytes 3-6.
  std::vector<std::uint8_t> payload;
  for (std::size_t i = per_pose; i < can_frames->frames.size(); ++i) {
    const output::CanFrame& f = can_frames->frames[i].second;
    if (((f.id >> 8) & 0x3FFFF) != output::kPgnGnssPositionData) continue;
    payload.insert(payload.end(), f.data.begin() + ((f.data[0] & 0x1F) == 0 ? 2 : 1), f.data.end());
  }
  ASSERT_GE(payload.size(), 7u);
  const std::uint32_t days = payload[1] | (payload[2] << 8);
  const std::uint32_t time_1e4 =
      payload[3] | (payload[4] << 8) | (payload[5] << 16) | (static_cast<std::uint32_t>(payload[6]) << 24);
  EXPECT_NEAR(days * 86400.0 + time_1e4 * 1e-4, static_cast<double>(utc1_ns) * 1e-9, 1e-4);
}

}  // namespace
}  // namespace sitepose::daemon
