// The daemon's Anchoring in online mode: GNSS fixes handed over from a
// receiving thread (push_fix, the SPSC ring) and SLAM poses from the
// publish stage reach geo::SiteAnchor in time order, and the outputs get
// poses in the site frame once an estimate exists. Fixed mode as a check.

#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "sitepose/daemon/outputs.hpp"
#include "sitepose/geo/geodetic.hpp"

namespace sitepose::daemon {
namespace {

const SE3 kTrueSiteSlam(Eigen::Quaterniond(0.5, -0.5, 0.5, -0.5) *
                            Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())),
                        Eigen::Vector3d(12.0, -4.0, 2.0));

// Left camera driving a circle of 6 m radius in the SLAM x-z plane (the
// camera frame's horizontal plane), looking outwards.
SE3 slam_pose_at(double t_s) {
  const double a = 0.15 * t_s;
  const Eigen::Vector3d p(6.0 * std::cos(a), 0.0, 6.0 * std::sin(a));
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitY())), p);
}

pipeline::PosePacket packet_at(std::int64_t seq, std::int64_t t_ns) {
  pipeline::PosePacket p;
  p.pose.seq = seq;
  p.pose.t_ns = t_ns;
  p.pose.T_world_cam = slam_pose_at(t_ns * 1e-9);
  p.pose.covariance = Matrix6d::Identity() * 1e-6;
  p.pose.state = TrackingState::kOk;
  return p;
}

GeoConfig geo_config(GeoMode mode) {
  GeoConfig g;
  g.mode = mode;
  g.origin = {48.137, 11.575, 520.0};
  g.anchor.origin = g.origin;
  g.T_site_slam = kTrueSiteSlam;
  return g;
}

TEST(Anchoring, OnlineEstimateFromFixesOfAnotherThread) {
  auto anchoring = Anchoring::create(geo_config(GeoMode::kOnline));
  ASSERT_TRUE(anchoring) << anchoring.error().message;
  auto enu = geo::LocalEnu::create(geo_config(GeoMode::kOnline).origin);
  ASSERT_TRUE(enu);
  const geo::SitePose* site = nullptr;
  int fixes = 0;
  for (int k = 0; k < 300; ++k) {  // 30 s at 10 Hz
    const std::int64_t t_ns = 1'000'000'000 + k * 100'000'000LL;
    if (k >= 1 && k % 2 == 1) {
      // A fix 50 ms before this pose, sent from a receiving thread.
      geo::GnssFix fix;
      fix.t_ns = t_ns - 50'000'000;
      const Eigen::Vector3d p_site = kTrueSiteSlam * slam_pose_at(fix.t_ns * 1e-9).translation();
      fix.position = enu->to_geodetic(p_site);
      fix.quality = geo::GnssQuality::kRtkFixed;
      fix.num_satellites = 20;
      fix.hdop = 0.8;
      std::thread([&] { (*anchoring)->push_fix(fix); }).join();
      ++fixes;
    }
    site = (*anchoring)->site_pose(packet_at(k, t_ns));
  }
  auto status = (*anchoring)->anchor_status();
  ASSERT_TRUE(status);
  EXPECT_EQ(status->fixes_received, fixes);
  EXPECT_NE(status->state, geo::AnchorState::kCollecting);
  ASSERT_NE(site, nullptr);
  const std::int64_t t_last = 1'000'000'000 + 299 * 100'000'000LL;
  const Eigen::Vector3d truth = kTrueSiteSlam * slam_pose_at(t_last * 1e-9).translation();
  EXPECT_LT((site->T_site_cam.translation() - truth).norm(), 0.01);
  EXPECT_NEAR(site->geodetic.latitude_deg, 48.137, 0.001);
}

TEST(Anchoring, FixedModeAnchorsEveryPoseOnceAndNoneModeNever) {
  auto fixed = Anchoring::create(geo_config(GeoMode::kFixed));
  ASSERT_TRUE(fixed);
  const auto packet = packet_at(3, 2'000'000'000);
  const geo::SitePose* a = (*fixed)->site_pose(packet);
  ASSERT_NE(a, nullptr);
  EXPECT_EQ((*fixed)->site_pose(packet), a) << "the second output shares the first one's answer";
  const Eigen::Vector3d truth = kTrueSiteSlam * packet.pose.T_world_cam.translation();
  EXPECT_LT((a->T_site_cam.translation() - truth).norm(), 1e-9);
  auto none = Anchoring::create(geo_config(GeoMode::kNone));
  ASSERT_TRUE(none);
  EXPECT_EQ((*none)->site_pose(packet), nullptr);
  EXPECT_FALSE((*none)->anchor_status());
}

}  // namespace
}  // namespace sitepose::daemon
