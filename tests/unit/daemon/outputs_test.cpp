// The daemon outputs, in-process with a fake clock (the process end to end
// is daemon_e2e_test): the one time base (a pose's capture time mapped to
// UTC once; pose_t, health_t, the CAN sink's stamps and 129029 date/time
// stamping it alike); the machine reference point through a lever arm on
// LCM and CAN, its covariance and velocity.

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "sitepose/daemon/outputs.hpp"

#include <cmath>
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

// An LCM publisher that keeps every encoded message in `sent` instead of
// sending it.
Expected<std::unique_ptr<output::LcmPublisher>> recording_publisher(
    std::vector<std::vector<std::uint8_t>>& sent) {
  return output::LcmPublisher::create_with_sender(
      output::LcmOptions{}, [&sent](const std::string&, const void* data, unsigned size) {
        const auto* b = static_cast<const std::uint8_t*>(data);
        sent.emplace_back(b, b + size);
        return 0;
      });
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
  auto publisher = recording_publisher(sent);
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

// The shipped example: camera at the site origin, level, looking east, the
// machine heading north (forward = camera -x).
GeoConfig shipped_geo() {
  GeoConfig g = fixed_geo();
  g.T_site_slam = SE3(Eigen::Quaterniond(0.5, -0.5, 0.5, -0.5), Eigen::Vector3d::Zero());
  g.anchor_std = {0.0, 0.0};
  return g;
}

struct Published {
  std::vector<sitepose::pose_t> lcm;
  std::vector<output::CanFrame> can;
};

// Publishes the packets on LCM and CAN through one Anchoring.
Published publish_all(const GeoConfig& geo, const PublishOptions& options,
                      const std::vector<pipeline::PosePacket>& packets) {
  Published out;
  auto anchoring = Anchoring::create(geo, options);
  EXPECT_TRUE(anchoring);
  if (!anchoring) return out;
  (*anchoring)->time_base() = TimeBase(fixed_clock());
  std::vector<std::vector<std::uint8_t>> sent;
  auto publisher = recording_publisher(sent);
  LcmOutput lcm(std::move(*publisher), **anchoring);
  auto sink = std::make_unique<RecordingSink>();
  RecordingSink* frames = sink.get();
  CanOutput can(output::CanOutputOptions{}, std::move(sink), **anchoring);
  for (const auto& p : packets) {
    EXPECT_TRUE(lcm.publish(p));
    EXPECT_TRUE(can.publish(p));
  }
  for (const auto& bytes : sent) {
    auto m = output::decode_lcm<sitepose::pose_t>(bytes.data(), bytes.size());
    EXPECT_TRUE(m);
    if (m) out.lcm.push_back(*m);
  }
  for (const auto& [t, f] : frames->frames) out.can.push_back(f);
  return out;
}

// Latitude / longitude of the last 129025 frame (int32 1e-7 deg each).
std::pair<double, double> last_rapid_position_deg(const std::vector<output::CanFrame>& frames) {
  for (auto it = frames.rbegin(); it != frames.rend(); ++it) {
    if (((it->id >> 8) & 0x3FFFF) != output::kPgnPositionRapidUpdate) continue;
    auto i32 = [&](int at) {
      std::uint32_t u = 0;
      for (int b = 3; b >= 0; --b) u = (u << 8) | it->data[at + b];
      return static_cast<std::int32_t>(u);
    };
    return {i32(0) * 1e-7, i32(4) * 1e-7};
  }
  return {NAN, NAN};
}

pipeline::PosePacket camera_at(const Eigen::Vector3d& p_slam, std::int64_t t_ns, std::int64_t seq,
                               const Matrix6d& covariance) {
  pipeline::PosePacket p = packet(t_ns, kSteadyNow, seq);
  p.pose.T_world_cam = SE3(Eigen::Quaterniond::Identity(), p_slam);
  p.pose.covariance = covariance;
  return p;
}

TEST(DaemonOutputs, ALeverArmMovesTheLcmAndCanPositionWhereGeometrySays) {
  const Matrix6d covariance = Matrix6d::Identity() * 1e-6;
  const std::vector<pipeline::PosePacket> packets = {camera_at({0, 0, 0}, 1'000'000'000, 0, covariance)};
  PublishOptions camera_only;
  PublishOptions lever;
  lever.lever_arm_m = {2.0, 1.0, 0.5};  // 2 m forward (north), 1 m left (west), 0.5 m up
  const Published at_camera = publish_all(shipped_geo(), camera_only, packets);
  const Published at_ref = publish_all(shipped_geo(), lever, packets);
  ASSERT_EQ(at_camera.lcm.size(), 1u);
  ASSERT_EQ(at_ref.lcm.size(), 1u);
  ASSERT_EQ(at_ref.lcm[0].frame, sitepose::pose_t::FRAME_SITE);
  const Eigen::Vector3d moved(at_ref.lcm[0].position[0] - at_camera.lcm[0].position[0],
                              at_ref.lcm[0].position[1] - at_camera.lcm[0].position[1],
                              at_ref.lcm[0].position[2] - at_camera.lcm[0].position[2]);
  EXPECT_TRUE(moved.isApprox(Eigen::Vector3d(-1.0, 2.0, 0.5), 1e-9)) << moved.transpose();
  // The orientation is the camera's.
  for (int i = 0; i < 4; ++i) EXPECT_DOUBLE_EQ(at_ref.lcm[0].orientation[i], at_camera.lcm[0].orientation[i]);

  // CAN 129025 carries the same point: WGS84 of ENU (-1, 2, 0.5) from the
  // origin, to the frame's 1e-7 deg.
  auto enu = geo::LocalEnu::create(fixed_geo().origin);
  ASSERT_TRUE(enu);
  const geo::Geodetic expected = enu->to_geodetic({-1.0, 2.0, 0.5});
  const auto [lat, lon] = last_rapid_position_deg(at_ref.can);
  EXPECT_NEAR(lat, expected.latitude_deg, 0.6e-7);
  EXPECT_NEAR(lon, expected.longitude_deg, 0.6e-7);
  EXPECT_NEAR(at_ref.lcm[0].latitude_deg, expected.latitude_deg, 1e-9);
  const auto [lat_camera, lon_camera] = last_rapid_position_deg(at_camera.can);
  EXPECT_GT(lat - lat_camera, 1.5e-5);  // 2 m north is 1.8e-5 deg

  // Attitude uncertainty through the 2.3 m arm: the position grows.
  double var_camera = 0.0, var_ref = 0.0;
  for (int i = 0; i < 3; ++i) {
    var_camera += at_camera.lcm[0].covariance[i * 7];
    var_ref += at_ref.lcm[0].covariance[i * 7];
  }
  EXPECT_GT(var_ref, var_camera + 1e-6);
}

TEST(DaemonOutputs, VelocityOfTheReferencePointInTheSiteFrameWithItsCovariance) {
  const Matrix6d covariance = Matrix6d::Identity() * 1e-6;
  // The camera moves 0.1 m along SLAM -x (= machine forward = north) in 0.1 s.
  const std::vector<pipeline::PosePacket> packets = {camera_at({0, 0, 0}, 1'000'000'000, 0, covariance),
                                                     camera_at({-0.1, 0, 0}, 1'100'000'000, 1, covariance)};
  PublishOptions lever;
  lever.lever_arm_m = {2.0, 0.0, 0.0};
  const Published out = publish_all(shipped_geo(), lever, packets);
  ASSERT_EQ(out.lcm.size(), 2u);
  EXPECT_TRUE(std::isnan(out.lcm[0].velocity[0]));  // no previous pose
  EXPECT_NEAR(out.lcm[1].velocity[0], 0.0, 1e-9);
  EXPECT_NEAR(out.lcm[1].velocity[1], 1.0, 1e-9);
  EXPECT_NEAR(out.lcm[1].velocity[2], 0.0, 1e-9);
  // Two positions with variance p each, 0.1 s apart: 2 p / 0.01 per axis.
  for (int i = 0; i < 3; ++i) {
    const double p0 = out.lcm[0].covariance[i * 7], p1 = out.lcm[1].covariance[i * 7];
    EXPECT_NEAR(out.lcm[1].velocity_covariance[i * 4], (p0 + p1) / 0.01, 1e-12);
  }
}

TEST(DaemonOutputs, TheFirstPoseIsNeverPublishedWithAZeroCovariance) {
  PublishOptions options;
  options.covariance = {1.0, 0.005, 0.02};
  GeoConfig geo = shipped_geo();
  geo.anchor_std = {0.02, 0.05};
  const Published out = publish_all(geo, options, {camera_at({0, 0, 0}, 0, 0, Matrix6d::Zero())});
  ASSERT_EQ(out.lcm.size(), 1u);
  // sqrt(0.005^2 + 0.02^2) per axis at the camera.
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(out.lcm[0].covariance[i * 7], 0.005 * 0.005 + 0.02 * 0.02, 1e-12);
  EXPECT_GT(out.lcm[0].covariance[3 * 7], 0.0);
  EXPECT_NEAR(out.lcm[0].position_std_m, std::sqrt(3 * (0.005 * 0.005 + 0.02 * 0.02)), 1e-9);
}

TEST(DaemonOutputs, J1939AltitudeIsAboveMeanSeaLevelAnd129029CarriesTheGeoidalSeparation) {
  // EGM96 at the shipped origin (48.137 N, 11.575 E): 45.534 m (PROJ's
  // vgridshift on the same grid, geo/geoid_test.cpp); the camera sits at
  // the origin, 520 m above the ellipsoid.
  const Published out = publish_all(shipped_geo(), PublishOptions{},
                                    {camera_at({0, 0, 0}, 1'000'000'000, 0, Matrix6d::Identity() * 1e-6)});
  std::vector<std::uint8_t> payload;
  double msl_m = NAN;
  for (const output::CanFrame& f : out.can) {
    const std::uint32_t pgn = (f.id >> 8) & 0x3FFFF;
    if (pgn == output::kPgnGnssPositionData) {
      payload.insert(payload.end(), f.data.begin() + ((f.data[0] & 0x1F) == 0 ? 2 : 1), f.data.end());
    }
    if (pgn == output::kPgnVehicleDirectionSpeed) msl_m = (f.data[6] | (f.data[7] << 8)) * 0.125 - 2500.0;
  }
  ASSERT_GE(payload.size(), 42u);
  const std::int32_t separation_cm =
      static_cast<std::int32_t>(payload[38] | (payload[39] << 8) | (payload[40] << 16) |
                                (static_cast<std::uint32_t>(payload[41]) << 24));
  EXPECT_NEAR(separation_cm * 0.01, 45.534, 0.01);
  EXPECT_NEAR(msl_m, 520.0 - 45.534, 0.0625 + 0.01);

  GeoConfig no_geoid = shipped_geo();
  no_geoid.geoid.clear();
  const Published without = publish_all(
      no_geoid, PublishOptions{}, {camera_at({0, 0, 0}, 1'000'000'000, 0, Matrix6d::Identity() * 1e-6)});
  for (const output::CanFrame& f : without.can) {
    if (((f.id >> 8) & 0x3FFFF) == output::kPgnVehicleDirectionSpeed) {
      EXPECT_EQ(f.data[6], 0xFF);  // SPN 580 not available: no geoid, no MSL height
      EXPECT_EQ(f.data[7], 0xFF);
    }
  }
}

TEST(DaemonOutputs, AGeoidGridThatDoesNotLoadIsRefusedNamingTheKey) {
  GeoConfig geo = shipped_geo();
  geo.geoid = "/nonexistent/egm.gtx";
  auto anchoring = Anchoring::create(geo);
  ASSERT_FALSE(anchoring);
  EXPECT_NE(anchoring.error().message.find("geo.geoid"), std::string::npos) << anchoring.error().message;
}

TEST(DaemonOutputs, TheMapDriftTermGrowsWithTheMapTravelOfEachPose) {
  PublishOptions options;
  options.covariance = {1.0, 0.0, 0.0, 0.01, 0.0};  // variance 1e-4 m^2 per metre of map travel
  GeoConfig geo = shipped_geo();
  geo.anchor_std = {0.0, 0.0};
  // Attitude almost exact, so that the position variance is the tracker's
  // plus the drift's (an attitude variance moves a point away from the origin).
  Matrix6d covariance = Matrix6d::Identity() * 1e-14;
  covariance.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * 1e-6;
  std::vector<pipeline::PosePacket> packets = {
      camera_at({0, 0, 0}, 1'000'000'000, 0, covariance), camera_at({4, 0, 0}, 1'100'000'000, 1, covariance),
      camera_at({8, 0, 0}, 1'200'000'000, 2, covariance), camera_at({4, 0, 0}, 1'300'000'000, 3, covariance)};
  // Out along a lane and back: the pose back at 4 m works on the map built
  // there, so its map travel (the tracker's) is 4 m again, not the path's 12.
  const double map_travel_m[] = {0.0, 4.0, 8.0, 4.0};
  for (std::size_t k = 0; k < packets.size(); ++k) packets[k].pose.map_travel_m = map_travel_m[k];
  const Published out = publish_all(geo, options, packets);
  ASSERT_EQ(out.lcm.size(), 4u);
  for (std::size_t k = 0; k < packets.size(); ++k) {
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(out.lcm[k].covariance[i * 7], 1e-6 + 1e-4 * map_travel_m[k], 1e-10) << k;
    }
  }
}

TEST(DaemonOutputs, IntegrityAlertOnLcmAndCanWhenTheProtectionLevelExceedsTheLimit) {
  PublishOptions options;
  options.integrity = {0.10, 3.0};
  // Position std 1 cm (protection level 3 cm) and 5 cm (15 cm) per axis.
  for (const double std_m : {0.01, 0.05}) {
    Matrix6d covariance = Matrix6d::Identity() * 1e-8;
    covariance.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * std_m * std_m;
    const Published out =
        publish_all(shipped_geo(), options, {camera_at({0, 0, 0}, 1'000'000'000, 0, covariance)});
    ASSERT_EQ(out.lcm.size(), 1u);
    const bool alert = std_m > 0.03;
    EXPECT_NEAR(out.lcm[0].protection_level_m, 3 * std_m, 1e-6);
    EXPECT_EQ(out.lcm[0].integrity_alert != 0, alert) << std_m;
    std::vector<std::uint8_t> payload;
    int quality_frames = 0;
    for (const output::CanFrame& f : out.can) {
      const std::uint32_t pgn = (f.id >> 8) & 0x3FFFF;
      if (pgn == output::kPgnGnssPositionData) {
        payload.insert(payload.end(), f.data.begin() + ((f.data[0] & 0x1F) == 0 ? 2 : 1), f.data.end());
      }
      if (pgn == output::kPgnSiteposePoseQuality) {
        ++quality_frames;
        EXPECT_EQ((f.data[1] >> 6) & 1, alert ? 1 : 0) << std_m;  // IntegrityAlert
        EXPECT_EQ((f.data[1] >> 4) & 3, 0) << std_m;              // state OK all the same
      }
    }
    EXPECT_EQ(quality_frames, 1);
    ASSERT_GE(payload.size(), 33u);
    EXPECT_EQ(payload[32] & 0x3, alert ? 2 : 0) << std_m;  // 129029 integrity: caution / no checking
  }
}

}  // namespace
}  // namespace sitepose::daemon
