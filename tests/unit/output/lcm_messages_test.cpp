#include "sitepose/output/lcm_messages.hpp"

#include <cmath>
#include <cstring>

#include <limits>

#include <gtest/gtest.h>

namespace sitepose::output {
namespace {

PoseEstimate sample_pose() {
  PoseEstimate p;
  p.t_ns = 1'700'000'000'123'456'789;
  p.seq = 4242;
  p.T_world_cam = SE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                      Eigen::Vector3d(1.5, -2.25, 0.75));
  p.covariance = Matrix6d::Identity() * 1e-4;
  p.covariance(0, 1) = p.covariance(1, 0) = 2e-5;
  p.state = TrackingState::kRecovering;
  p.state_reason = "few static features";
  p.counters.features_used = 311;
  p.counters.features_used_pass1 = 250;
  p.counters.static_objects_unmasked = 2;
  p.counters.masked_area_ratio = 0.375;
  return p;
}

template <typename M>
M round_trip(const M& in) {
  auto bytes = encode_lcm(in);
  EXPECT_TRUE(bytes.has_value());
  auto out = decode_lcm<M>(bytes->data(), bytes->size());
  EXPECT_TRUE(out.has_value()) << out.error().message;
  return *out;
}

TEST(LcmMessages, PoseInSiteFrameRoundTrips) {
  const PoseEstimate pose = sample_pose();
  auto frame = geo::SiteFrame::create(
      {35.68, 139.76, 40.0},
      SE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ())), Eigen::Vector3d(10, 20, 1)),
      geo::ForwardAxis::kMinusX);
  ASSERT_TRUE(frame.has_value());
  auto site = frame->to_site(pose);
  ASSERT_TRUE(site.has_value());
  const sitepose::pose_t m = round_trip(to_lcm_pose(pose, &*site));
  EXPECT_EQ(m.utime, 1'700'000'000'123'456);
  EXPECT_EQ(m.seq, 4242);
  EXPECT_EQ(m.frame, sitepose::pose_t::FRAME_SITE);
  EXPECT_EQ(m.state, sitepose::pose_t::STATE_RECOVERING);
  EXPECT_EQ(m.state_reason, "few static features");
  EXPECT_EQ(m.features_used, 311);
  EXPECT_EQ(m.features_pass1, 250);
  EXPECT_EQ(m.static_objects_unmasked, 2);
  EXPECT_FLOAT_EQ(m.masked_area_ratio, 0.375f);
  for (int i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(m.position[i], site->T_site_cam.translation()(i));
  EXPECT_DOUBLE_EQ(m.orientation[0], site->T_site_cam.rotation().w());
  EXPECT_DOUBLE_EQ(m.orientation[3], site->T_site_cam.rotation().z());
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) EXPECT_DOUBLE_EQ(m.covariance[r * 6 + c], site->covariance_site(r, c));
  }
  EXPECT_DOUBLE_EQ(m.latitude_deg, site->geodetic.latitude_deg);
  EXPECT_DOUBLE_EQ(m.longitude_deg, site->geodetic.longitude_deg);
  EXPECT_DOUBLE_EQ(m.height_m, site->geodetic.height_m);
  EXPECT_DOUBLE_EQ(m.utm_easting_m, site->utm.easting_m);
  EXPECT_DOUBLE_EQ(m.utm_northing_m, site->utm.northing_m);
  EXPECT_EQ(m.utm_zone, 54);
  EXPECT_EQ(m.utm_north, 1);
  EXPECT_DOUBLE_EQ(m.heading_deg, site->heading_deg);
  EXPECT_DOUBLE_EQ(m.heading_std_deg, site->heading_std_deg);
  EXPECT_DOUBLE_EQ(m.position_std_m, site->position_std_m);
}

TEST(LcmMessages, PoseWithoutAnchorIsInSlamFrameWithNaNGeodesy) {
  PoseEstimate pose = sample_pose();
  pose.t_ns = -1500;  // floor division
  const sitepose::pose_t m = round_trip(to_lcm_pose(pose, nullptr));
  EXPECT_EQ(m.utime, -2);
  EXPECT_EQ(m.frame, sitepose::pose_t::FRAME_SLAM);
  EXPECT_DOUBLE_EQ(m.position[0], 1.5);
  EXPECT_DOUBLE_EQ(m.position[1], -2.25);
  EXPECT_TRUE(std::isnan(m.latitude_deg));
  EXPECT_TRUE(std::isnan(m.heading_deg));
  EXPECT_EQ(m.utm_zone, -1);
  // Covariance converted to [dp; dtheta]: position variance grows with the
  // rotation variance times the lever of the camera position.
  const double p2 = pose.T_world_cam.translation().squaredNorm();
  EXPECT_NEAR(m.position_std_m, std::sqrt(3e-4 + 2 * p2 * 1e-4), 1e-9);
}

TEST(LcmMessages, HealthRoundTripsWithVariableArrays) {
  LcmHealth h;
  h.t_ns = 5'000'000'000;
  h.fps = 29.5;
  h.latency_p50_ms = 31.0;
  h.latency_p99_ms = 52.5;
  h.state = TrackingState::kLost;
  h.state_reason = "source stalled";
  h.frames_captured = 1000;
  h.frames_tracked = 990;
  h.stalls = 1;
  h.stages = {{"capture", 0, 1, 2.5, 4.0},
              {"detect", 3, 0, 0.1, 0.2},
              {"track", 7, 2, 25.0, 48.0},
              {"publish", 0, 0, 0.3, 1.0}};
  h.outputs = {{"lcm", 2, 0}, {"can", 5, 1}};
  const sitepose::health_t m = round_trip(to_lcm_health(h));
  EXPECT_EQ(m.utime, 5'000'000);
  EXPECT_FLOAT_EQ(m.fps, 29.5f);
  EXPECT_FLOAT_EQ(m.latency_p99_ms, 52.5f);
  EXPECT_EQ(m.state, sitepose::pose_t::STATE_LOST);
  EXPECT_EQ(m.state_reason, "source stalled");
  EXPECT_EQ(m.frames_tracked, 990);
  ASSERT_EQ(m.num_stages, 4);
  EXPECT_EQ(m.stage_names[2], "track");
  EXPECT_EQ(m.drops[2], 7);
  EXPECT_EQ(m.queue_depths[2], 2);
  EXPECT_FLOAT_EQ(m.p50_ms[2], 25.0f);
  EXPECT_FLOAT_EQ(m.p99_ms[2], 48.0f);
  ASSERT_EQ(m.num_outputs, 2);
  EXPECT_EQ(m.output_names[1], "can");
  EXPECT_EQ(m.output_errors[1], 5);
  EXPECT_EQ(m.output_failed[1], 1);
}

TEST(LcmMessages, GnssFixRoundTripsAndIsValidated) {
  geo::GnssFix fix;
  fix.t_ns = 1'700'000'000'200'000'000;
  fix.position = {35.681236, 139.767125, 80.5};
  fix.quality = geo::GnssQuality::kRtkFixed;
  fix.num_satellites = 21;
  fix.hdop = 0.6;
  const sitepose::gnss_fix_t m = round_trip(to_lcm_gnss_fix(fix));
  auto back = from_lcm_gnss_fix(m);
  ASSERT_TRUE(back.has_value()) << back.error().message;
  EXPECT_EQ(back->t_ns, fix.t_ns);
  EXPECT_DOUBLE_EQ(back->position.latitude_deg, fix.position.latitude_deg);
  EXPECT_DOUBLE_EQ(back->position.longitude_deg, fix.position.longitude_deg);
  EXPECT_DOUBLE_EQ(back->position.height_m, fix.position.height_m);
  EXPECT_EQ(back->quality, geo::GnssQuality::kRtkFixed);
  EXPECT_EQ(back->num_satellites, 21);
  EXPECT_NEAR(back->hdop, 0.6, 1e-6);

  sitepose::gnss_fix_t bad = m;
  bad.quality = 12;
  auto q = from_lcm_gnss_fix(bad);
  ASSERT_FALSE(q.has_value());
  EXPECT_NE(q.error().message.find("fix quality = 12"), std::string::npos);
  bad = m;
  bad.latitude_deg = 95.0;
  EXPECT_FALSE(from_lcm_gnss_fix(bad).has_value());
  // No fix: NaN position is fine.
  bad = m;
  bad.quality = sitepose::gnss_fix_t::QUALITY_INVALID;
  bad.latitude_deg = bad.longitude_deg = bad.height_m = std::nan("");
  auto none = from_lcm_gnss_fix(bad);
  ASSERT_TRUE(none.has_value());
  EXPECT_FALSE(none->has_position());
  // A time whose nanoseconds do not fit 64 bits (fuzz_gnss_fix: signed
  // overflow, corpus gnss_fix/utime_overflow) is refused, the limit kept.
  bad = m;
  bad.utime = std::numeric_limits<std::int64_t>::max() / 1000 + 1;
  auto overflow = from_lcm_gnss_fix(bad);
  ASSERT_FALSE(overflow.has_value());
  EXPECT_NE(overflow.error().message.find("out of range"), std::string::npos) << overflow.error().message;
  bad.utime = -bad.utime;
  EXPECT_FALSE(from_lcm_gnss_fix(bad).has_value());
  bad.utime = std::numeric_limits<std::int64_t>::max() / 1000;
  auto largest = from_lcm_gnss_fix(bad);
  ASSERT_TRUE(largest.has_value());
  EXPECT_EQ(largest->t_ns, bad.utime * 1000);
}

TEST(LcmMessages, DecodeRejectsWrongTypeAndTruncation) {
  auto bytes = encode_lcm(to_lcm_gnss_fix(geo::GnssFix{}));
  ASSERT_TRUE(bytes.has_value());
  // A gnss_fix_t is not a pose_t: the fingerprint differs.
  EXPECT_FALSE(decode_lcm<sitepose::pose_t>(bytes->data(), bytes->size()).has_value());
  EXPECT_FALSE(decode_lcm<sitepose::gnss_fix_t>(bytes->data(), bytes->size() - 1).has_value());
  std::vector<std::uint8_t> longer = *bytes;
  longer.push_back(0);
  EXPECT_FALSE(decode_lcm<sitepose::gnss_fix_t>(longer.data(), longer.size()).has_value());
}

}  // namespace
}  // namespace sitepose::output
