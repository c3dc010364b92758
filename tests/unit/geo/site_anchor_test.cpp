#include "sitepose/geo/site_anchor.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include <GeographicLib/LocalCartesian.hpp>
#include <gtest/gtest.h>

namespace sitepose::geo {
namespace {

constexpr std::int64_t kMs = 1'000'000;
const Geodetic kOrigin{35.681236, 139.767125, 40.0};

// A roller mowing lanes in the site frame: 40 m straight at 1 m/s, then a
// half turn (alternately left and right) onto the next lane 1.9 m over.
// The left camera looks to the machine's right (forward = camera -x).
class LanePath {
 public:
  static constexpr double kSpeedMps = 1.0;
  static constexpr double kStraightS = 40.0;
  static constexpr double kTurnS = 3.0;

  SE3 T_site_cam(double t_s) const {
    double x = 0.0, y = 0.0, yaw = 0.0;
    double t = std::max(t_s, 0.0);
    int lane = 0;
    while (true) {
      const double straight = std::min(t, kStraightS);
      x += kSpeedMps * straight * std::cos(yaw);
      y += kSpeedMps * straight * std::sin(yaw);
      t -= straight;
      if (t <= 0.0) break;
      const double w = (lane % 2 == 0 ? 1.0 : -1.0) * M_PI / kTurnS;
      const double turn = std::min(t, kTurnS);
      x += kSpeedMps / w * (std::sin(yaw + w * turn) - std::sin(yaw));
      y += -kSpeedMps / w * (std::cos(yaw + w * turn) - std::cos(yaw));
      yaw += w * turn;
      t -= turn;
      ++lane;
      if (t <= 0.0) break;
    }
    const double z = 2.0 + 0.3 * std::sin(0.05 * t_s);
    const Eigen::Vector3d right(std::sin(yaw), -std::cos(yaw), 0.0);
    Eigen::Matrix3d R;
    R.col(2) = right;
    R.col(1) = -Eigen::Vector3d::UnitZ();
    R.col(0) = R.col(1).cross(R.col(2));
    // Slow roll/pitch of the ground.
    const Eigen::Matrix3d tilt =
        Eigen::AngleAxisd(0.02 * std::sin(0.1 * t_s), Eigen::Vector3d::UnitX()).toRotationMatrix() *
        Eigen::AngleAxisd(0.015 * std::cos(0.07 * t_s), Eigen::Vector3d::UnitY()).toRotationMatrix();
    return SE3(Eigen::Matrix3d(tilt * R), Eigen::Vector3d(x, y, z));
  }
};

struct Event {
  std::int64_t arrival_ns;
  bool is_fix;
  std::int64_t t_ns;
  SE3 T_slam_cam;
  GnssFix fix;
};

struct Scenario {
  SE3 T_site_slam{Eigen::Quaterniond(Eigen::AngleAxisd(0.9, Eigen::Vector3d::UnitZ()) *
                                     Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitX())),
                  Eigen::Vector3d(15.0, -8.0, 1.2)};
  Eigen::Vector3d p_cam_antenna_m{0.4, -1.3, 0.6};
  std::int64_t clock_offset_ns = 37'000 * kMs;  // camera clock = UTC + 37 s
  LanePath path;

  // Camera at 10 Hz, GNSS at 5 Hz shifted by 30 ms; arrival order like the
  // daemon sees it (poses 50 ms late, fixes 20 ms late).
  std::vector<Event> events(double duration_s, double outlier_fraction, std::uint64_t seed,
                            GnssQuality quality = GnssQuality::kRtkFixed) const {
    const GeographicLib::LocalCartesian enu(kOrigin.latitude_deg, kOrigin.longitude_deg,
                                            kOrigin.height_m);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.01);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    std::vector<Event> out;
    const SE3 T_slam_site = T_site_slam.inverse();
    for (std::int64_t t = 0; t <= static_cast<std::int64_t>(duration_s * 1000) * kMs; t += 100 * kMs) {
      out.push_back({t + 50 * kMs, false, t, T_slam_site * path.T_site_cam(t * 1e-9), {}});
    }
    for (std::int64_t t = 30 * kMs; t <= static_cast<std::int64_t>(duration_s * 1000) * kMs; t += 200 * kMs) {
      Eigen::Vector3d p = path.T_site_cam(t * 1e-9) * p_cam_antenna_m;
      p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      if (u01(rng) < outlier_fraction) {  // multipath: 0.3 .. 3 m off
        const Eigen::Vector3d dir =
            Eigen::Vector3d(u01(rng) - 0.5, u01(rng) - 0.5, u01(rng) - 0.5).normalized();
        p += dir * (0.3 + 2.7 * u01(rng));
      }
      GnssFix fix;
      fix.t_ns = t - clock_offset_ns;
      enu.Reverse(p.x(), p.y(), p.z(), fix.position.latitude_deg, fix.position.longitude_deg,
                  fix.position.height_m);
      fix.quality = quality;
      fix.num_satellites = 18;
      fix.hdop = 0.7;
      out.push_back({t + 20 * kMs, true, t, SE3(), fix});
    }
    std::stable_sort(out.begin(), out.end(),
                     [](const Event& a, const Event& b) { return a.arrival_ns < b.arrival_ns; });
    return out;
  }

  SiteAnchorOptions options() const {
    SiteAnchorOptions o;
    o.origin = kOrigin;
    o.p_cam_antenna_m = p_cam_antenna_m;
    o.gnss_clock_offset_ns = clock_offset_ns;
    o.freeze_inliers = 300;
    o.freeze_lateral_spread_m = 1.5;
    return o;
  }

  // Largest distance between anchored and true camera positions.
  double max_position_error_m(const SiteFrame& frame, double duration_s) const {
    double worst = 0.0;
    for (double t = 0.0; t <= duration_s; t += 0.5) {
      const SE3 T_site_cam = path.T_site_cam(t);
      auto site = frame.to_site(0, T_site_slam.inverse() * T_site_cam, Matrix6d::Identity());
      EXPECT_TRUE(site.has_value());
      worst = std::max(worst, (site->T_site_cam.translation() - T_site_cam.translation()).norm());
    }
    return worst;
  }
};

void feed(SiteAnchor& anchor, const std::vector<Event>& events) {
  for (const Event& e : events) {
    if (e.is_fix) {
      anchor.add_fix(e.fix);
    } else {
      anchor.add_slam_pose(e.t_ns, e.T_slam_cam);
    }
  }
}

TEST(SiteAnchor, OptionsAreValidated) {
  SiteAnchorOptions o;
  o.origin = kOrigin;
  EXPECT_TRUE(o.validate().has_value());
  o.min_inliers = 2;
  auto bad = SiteAnchor::create(o);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("min_inliers = 2"), std::string::npos);
  o = SiteAnchorOptions{};
  o.origin = {0.0, 200.0, 0.0};
  EXPECT_FALSE(SiteAnchor::create(o).has_value());
}

TEST(SiteAnchor, RecoversKnownTransformFromNoisyFixesWithOutliers) {
  const Scenario s;
  auto anchor = SiteAnchor::create(s.options());
  ASSERT_TRUE(anchor.has_value()) << anchor.error().message;
  const double duration_s = 172.0;  // four lanes
  feed(*anchor, s.events(duration_s, 0.2, 1));
  const AnchorStatus& st = anchor->status();
  ASSERT_EQ(anchor->state(), AnchorState::kFrozen) << st.pairs << " pairs " << st.inliers << " inliers";
  EXPECT_NE(st.freeze_reason.find("inliers"), std::string::npos) << st.freeze_reason;
  EXPECT_GE(st.inliers, 300);
  EXPECT_LT(st.inlier_rms_m, 0.03);
  EXPECT_GT(st.fixes_after_freeze, 0);
  ASSERT_TRUE(anchor->site_frame().has_value());
  const SE3 error = anchor->site_frame()->T_site_slam() * s.T_site_slam.inverse();
  EXPECT_LT(rotation_angle_rad(error.rotation()), 2e-3);
  const double worst_m = s.max_position_error_m(*anchor->site_frame(), duration_s);
  EXPECT_LT(worst_m, 0.02) << "worst anchored position error over the run";
  RecordProperty("max_position_error_mm", static_cast<int>(worst_m * 1000));
}

TEST(SiteAnchor, WithoutLeverArmTheFitIsWrong) {
  // Guards the lever arm: ignoring it moves the anchored positions by
  // decimetres, so the test above really exercises it.
  const Scenario s;
  SiteAnchorOptions o = s.options();
  o.p_cam_antenna_m = Eigen::Vector3d::Zero();
  o.alignment.inlier_threshold_m = 5.0;
  auto anchor = SiteAnchor::create(o);
  ASSERT_TRUE(anchor.has_value());
  feed(*anchor, s.events(172.0, 0.0, 2));
  ASSERT_TRUE(anchor->site_frame().has_value());
  EXPECT_GT(s.max_position_error_m(*anchor->site_frame(), 172.0), 0.2);
}

TEST(SiteAnchor, FreezesWhenRtkDrops) {
  const Scenario s;
  SiteAnchorOptions o = s.options();
  o.freeze_inliers = 100000;  // only RTK loss can freeze here
  auto anchor = SiteAnchor::create(o);
  ASSERT_TRUE(anchor.has_value());
  const std::vector<Event> events = s.events(120.0, 0.2, 3);
  const auto split = std::find_if(events.begin(), events.end(),
                                  [](const Event& e) { return e.t_ns >= 90'000 * kMs; });
  feed(*anchor, {events.begin(), split});
  ASSERT_EQ(anchor->state(), AnchorState::kEstimating);
  const SE3 before = anchor->site_frame()->T_site_slam();

  GnssFix float_fix;  // the last fix fed, then 200 ms later as RTK float
  for (auto it = split; it != events.begin(); --it) {
    if (std::prev(it)->is_fix) {
      float_fix = std::prev(it)->fix;
      break;
    }
  }
  float_fix.t_ns += 200 * kMs;
  float_fix.quality = GnssQuality::kRtkFloat;
  anchor->add_fix(float_fix);
  EXPECT_EQ(anchor->state(), AnchorState::kFrozen);
  EXPECT_NE(anchor->status().freeze_reason.find("rtk-float"), std::string::npos)
      << anchor->status().freeze_reason;
  const SE3 at_freeze = anchor->site_frame()->T_site_slam();
  // The last pairs were fitted before freezing: it may have moved a little.
  EXPECT_LT((at_freeze.translation() - before.translation()).norm(), 0.02);

  // Later fixes, even RTK-fixed and 1 m off, change nothing.
  std::vector<Event> later(split, events.end());
  for (Event& e : later) {
    if (e.is_fix) e.fix.position.latitude_deg += 1e-5;
  }
  feed(*anchor, later);
  EXPECT_EQ(anchor->state(), AnchorState::kFrozen);
  EXPECT_TRUE(anchor->site_frame()->T_site_slam().translation() == at_freeze.translation());
  EXPECT_GT(anchor->status().fixes_after_freeze, 100);
  EXPECT_LT(s.max_position_error_m(*anchor->site_frame(), 120.0), 0.02);

  anchor->reset();
  EXPECT_EQ(anchor->state(), AnchorState::kCollecting);
  EXPECT_FALSE(anchor->site_frame().has_value());
}

TEST(SiteAnchor, RtkLossBeforeAnEstimateDoesNotFreeze) {
  const Scenario s;
  auto anchor = SiteAnchor::create(s.options());
  ASSERT_TRUE(anchor.has_value());
  std::vector<Event> events = s.events(100.0, 0.0, 4);
  int fix_index = 0;
  for (Event& e : events) {
    if (!e.is_fix) continue;
    // Fixes 5..14 are float (RTK lost for 2 s near the start).
    if (fix_index >= 5 && fix_index < 15) e.fix.quality = GnssQuality::kRtkFloat;
    ++fix_index;
  }
  feed(*anchor, events);
  EXPECT_EQ(anchor->status().fixes_low_quality, 10);
  EXPECT_NE(anchor->state(), AnchorState::kCollecting);
  ASSERT_TRUE(anchor->site_frame().has_value());
  EXPECT_LT(s.max_position_error_m(*anchor->site_frame(), 100.0), 0.02);
}

TEST(SiteAnchor, StraightLineOnlyKeepsCollecting) {
  // 30 s on the first lane: points on a line, roll about it unobservable.
  const Scenario s;
  auto anchor = SiteAnchor::create(s.options());
  ASSERT_TRUE(anchor.has_value());
  feed(*anchor, s.events(30.0, 0.0, 5));
  EXPECT_EQ(anchor->state(), AnchorState::kCollecting);
  EXPECT_GT(anchor->status().pairs, 100);
  EXPECT_FALSE(anchor->site_frame().has_value());
}

TEST(SiteAnchor, FixesWithoutSlamPosesAreUnmatchedNotUsed) {
  const Scenario s;
  auto anchor = SiteAnchor::create(s.options());
  ASSERT_TRUE(anchor.has_value());
  std::vector<Event> events = s.events(60.0, 0.0, 6);
  // Tracking lost between 20 s and 30 s: no SLAM poses there.
  std::erase_if(events, [](const Event& e) {
    return !e.is_fix && e.t_ns > 20'000 * kMs && e.t_ns < 30'000 * kMs;
  });
  feed(*anchor, events);
  EXPECT_GE(anchor->status().fixes_unmatched, 45);
  EXPECT_LE(anchor->status().fixes_unmatched, 52);
}

}  // namespace
}  // namespace sitepose::geo
