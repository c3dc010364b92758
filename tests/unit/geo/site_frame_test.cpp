#include "sitepose/geo/site_frame.hpp"

#include <cmath>
#include <random>

#include <GeographicLib/LocalCartesian.hpp>
#include <GeographicLib/UTMUPS.hpp>
#include <gtest/gtest.h>

namespace sitepose::geo {
namespace {

const Geodetic kOrigin{35.681236, 139.767125, 40.0};

Eigen::Quaterniond rpy(double roll_rad, double pitch_rad, double yaw_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()));
}

// Left camera looking to the machine's right (the simulator's `side: right`)
// for a machine at yaw (math convention, from East counter-clockwise) on flat
// ground: z = machine right, y = down, x = y cross z = machine backwards.
Eigen::Matrix3d R_site_cam_right_looking(double machine_yaw_rad) {
  const Eigen::Vector3d forward(std::cos(machine_yaw_rad), std::sin(machine_yaw_rad), 0.0);
  const Eigen::Vector3d right(std::sin(machine_yaw_rad), -std::cos(machine_yaw_rad), 0.0);
  Eigen::Matrix3d R;
  R.col(2) = right;
  R.col(1) = -Eigen::Vector3d::UnitZ();
  R.col(0) = R.col(1).cross(R.col(2));
  EXPECT_LT((R.col(0) + forward).norm(), 1e-12);
  return R;
}

TEST(SiteFrame, ForwardAxisParsing) {
  EXPECT_EQ(*parse_forward_axis("-x"), ForwardAxis::kMinusX);
  EXPECT_EQ(*parse_forward_axis("+x"), ForwardAxis::kPlusX);
  EXPECT_EQ(*parse_forward_axis("z"), ForwardAxis::kPlusZ);
  auto bad = parse_forward_axis("forward");
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("'forward'"), std::string::npos);
  for (ForwardAxis a : {ForwardAxis::kPlusX, ForwardAxis::kMinusX, ForwardAxis::kPlusY,
                        ForwardAxis::kMinusY, ForwardAxis::kPlusZ, ForwardAxis::kMinusZ}) {
    EXPECT_EQ(*parse_forward_axis(to_string(a)), a);
  }
}

TEST(SiteFrame, LlaAndUtmMatchGeographicLibDirectly) {
  const SE3 T_site_slam(rpy(0.02, -0.01, 0.7), Eigen::Vector3d(12.0, -5.0, 1.5));
  auto frame = SiteFrame::create(kOrigin, T_site_slam, ForwardAxis::kMinusX);
  ASSERT_TRUE(frame.has_value());
  const GeographicLib::LocalCartesian reference(kOrigin.latitude_deg, kOrigin.longitude_deg,
                                                kOrigin.height_m);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-300.0, 300.0);
  for (int i = 0; i < 20; ++i) {
    const SE3 T_slam_cam(rpy(0.1 * i, 0.05, -0.2 * i), Eigen::Vector3d(u(rng), u(rng), 0.01 * u(rng)));
    auto site = frame->to_site(1000 + i, T_slam_cam, Matrix6d::Identity() * 1e-4);
    ASSERT_TRUE(site.has_value());
    const Eigen::Vector3d p_site = T_site_slam.rotation() * T_slam_cam.translation() +
                                   T_site_slam.translation();
    EXPECT_LT((site->T_site_cam.translation() - p_site).norm(), 1e-9);
    double lat = 0, lon = 0, h = 0;
    reference.Reverse(p_site.x(), p_site.y(), p_site.z(), lat, lon, h);
    // 1e-9 deg is 0.1 mm: far inside cm level.
    EXPECT_NEAR(site->geodetic.latitude_deg, lat, 1e-9);
    EXPECT_NEAR(site->geodetic.longitude_deg, lon, 1e-9);
    EXPECT_NEAR(site->geodetic.height_m, h, 1e-4);
    int zone = 0;
    bool north = false;
    double x = 0, y = 0;
    GeographicLib::UTMUPS::Forward(lat, lon, zone, north, x, y);
    EXPECT_EQ(site->utm.zone, zone);
    EXPECT_EQ(site->utm.north, north);
    EXPECT_NEAR(site->utm.easting_m, x, 0.005);
    EXPECT_NEAR(site->utm.northing_m, y, 0.005);
    // And back: LLA to ENU gives the site position again.
    double e = 0, n = 0, up = 0;
    reference.Forward(site->geodetic.latitude_deg, site->geodetic.longitude_deg,
                      site->geodetic.height_m, e, n, up);
    EXPECT_LT((Eigen::Vector3d(e, n, up) - p_site).norm(), 0.005);
  }
  EXPECT_FALSE(frame->to_site(0, SE3(Eigen::Quaterniond::Identity(),
                                     Eigen::Vector3d(std::nan(""), 0, 0)),
                              Matrix6d::Identity())
                   .has_value());
}

TEST(SiteFrame, HeadingIsClockwiseFromNorthOfTheConfiguredAxis) {
  auto frame = SiteFrame::create(kOrigin, SE3::identity(), ForwardAxis::kMinusX);
  ASSERT_TRUE(frame.has_value());
  // Machine yaw (from East, counter-clockwise) -> heading (from North, clockwise).
  const std::vector<std::pair<double, double>> cases = {
      {90.0, 0.0}, {0.0, 90.0}, {-90.0, 180.0}, {180.0, 270.0}, {45.0, 45.0}, {120.0, 330.0}};
  for (const auto& [yaw_deg, heading_deg] : cases) {
    const SE3 T(Eigen::Matrix3d(R_site_cam_right_looking(yaw_deg * M_PI / 180.0)),
                Eigen::Vector3d(1, 2, 3));
    auto site = frame->to_site(0, T, Matrix6d::Identity() * 1e-6);
    ASSERT_TRUE(site.has_value());
    EXPECT_NEAR(site->heading_deg, heading_deg, 1e-9) << "yaw " << yaw_deg;
    EXPECT_GE(site->heading_deg, 0.0);
    EXPECT_LT(site->heading_deg, 360.0);
  }
  // The same camera read with +x as forward (camera looking left) points backwards.
  auto left = SiteFrame::create(kOrigin, SE3::identity(), ForwardAxis::kPlusX);
  ASSERT_TRUE(left.has_value());
  const SE3 T_north(Eigen::Matrix3d(R_site_cam_right_looking(M_PI / 2)), Eigen::Vector3d::Zero());
  EXPECT_NEAR(left->to_site(0, T_north, Matrix6d::Identity())->heading_deg, 180.0, 1e-9);
  // Forward along the optical axis pitched straight down: no heading.
  auto down = SiteFrame::create(kOrigin, SE3::identity(), ForwardAxis::kPlusY);
  ASSERT_TRUE(down.has_value());
  EXPECT_TRUE(std::isnan(down->to_site(0, T_north, Matrix6d::Identity())->heading_deg));
  // Site rotation is applied: a SLAM frame rotated 90 deg about Up turns headings.
  auto rotated = SiteFrame::create(kOrigin, SE3(rpy(0, 0, M_PI / 2), Eigen::Vector3d::Zero()),
                                   ForwardAxis::kMinusX);
  ASSERT_TRUE(rotated.has_value());
  EXPECT_NEAR(rotated->to_site(0, T_north, Matrix6d::Identity())->heading_deg, 270.0, 1e-9);
}

TEST(SiteFrame, CovarianceIsRotatedIntoTheSiteFrame) {
  // Camera at the SLAM origin, only position variance: a 90 deg yaw of the
  // site frame swaps the East and North variances.
  const SE3 T_site_slam(rpy(0, 0, M_PI / 2), Eigen::Vector3d(5, 5, 0));
  Matrix6d cov = Matrix6d::Zero();
  cov.diagonal() << 0.04, 0.01, 0.09, 1e-6, 4e-6, 9e-6;
  const Matrix6d site = site_covariance(T_site_slam, SE3::identity(), cov);
  EXPECT_NEAR(site(0, 0), 0.01, 1e-12);
  EXPECT_NEAR(site(1, 1), 0.04, 1e-12);
  EXPECT_NEAR(site(2, 2), 0.09, 1e-12);
  EXPECT_NEAR(site(3, 3), 4e-6, 1e-15);
  EXPECT_NEAR(site(4, 4), 1e-6, 1e-15);
  auto frame = SiteFrame::create(kOrigin, T_site_slam, ForwardAxis::kMinusX);
  ASSERT_TRUE(frame.has_value());
  auto pose = frame->to_site(0, SE3::identity(), cov);
  ASSERT_TRUE(pose.has_value());
  EXPECT_NEAR(pose->position_std_m, std::sqrt(0.04 + 0.01 + 0.09), 1e-12);
}

TEST(SiteFrame, CovarianceAndHeadingStdMatchMonteCarlo) {
  const SE3 T_site_slam(rpy(0.03, -0.02, 1.1), Eigen::Vector3d(-20, 7, 2));
  const SE3 T_slam_cam(Eigen::Matrix3d(R_site_cam_right_looking(0.4)), Eigen::Vector3d(30, -12, 1));
  Eigen::Matrix<double, 6, 6> L = Eigen::Matrix<double, 6, 6>::Zero();
  L.diagonal() << 0.03, 0.02, 0.05, 0.004, 0.006, 0.01;
  L(1, 0) = 0.01;
  L(5, 0) = 0.002;
  L(4, 3) = 0.001;
  const Matrix6d cov = L * L.transpose();
  auto frame = SiteFrame::create(kOrigin, T_site_slam, ForwardAxis::kMinusX);
  ASSERT_TRUE(frame.has_value());
  auto nominal = frame->to_site(0, T_slam_cam, cov);
  ASSERT_TRUE(nominal.has_value());

  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01(0.0, 1.0);
  constexpr int kSamples = 40000;
  Matrix6d empirical = Matrix6d::Zero();
  double heading_sq = 0.0;
  for (int i = 0; i < kSamples; ++i) {
    Vector6d z;
    for (int k = 0; k < 6; ++k) z(k) = n01(rng);
    const SE3 perturbed = SE3::exp(L * z) * T_slam_cam;  // left twist, as PoseEstimate
    const SE3 T_site_cam = T_site_slam * perturbed;
    Vector6d d;
    d.head<3>() = T_site_cam.translation() - nominal->T_site_cam.translation();
    d.tail<3>() = so3_log(T_site_cam.rotation() * nominal->T_site_cam.rotation().inverse());
    empirical += d * d.transpose();
    double dh = heading_deg_of(T_site_cam.rotation() * Eigen::Vector3d(-1, 0, 0)) -
                nominal->heading_deg;
    if (dh > 180) dh -= 360;
    if (dh < -180) dh += 360;
    heading_sq += dh * dh;
  }
  empirical /= kSamples;
  // First-order propagation vs sampling: a few percent of the largest entry.
  const double scale = nominal->covariance_site.diagonal().maxCoeff();
  EXPECT_LT((empirical - nominal->covariance_site).cwiseAbs().maxCoeff(), 0.05 * scale)
      << "empirical\n" << empirical << "\npropagated\n" << nominal->covariance_site;
  const double heading_std_mc = std::sqrt(heading_sq / kSamples);
  EXPECT_NEAR(nominal->heading_std_deg, heading_std_mc, 0.05 * heading_std_mc);
  EXPECT_GT(nominal->heading_std_deg, 0.1);  // the yaw variance is not negligible here
}

}  // namespace
}  // namespace sitepose::geo
