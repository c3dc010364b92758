// The published pose: the machine reference point through a lever arm, its
// covariance (Jacobian checked against central differences of the pose
// through a left twist, STYLE.md §8), the floor, and the velocity.

#include "sitepose/output/published_pose.hpp"
#include "sitepose/output/travelled_distance.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include <Eigen/Eigenvalues>

namespace sitepose::output {
namespace {

constexpr double kStep = 1e-6;

SE3 some_pose() {
  const Eigen::Quaterniond q =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX());
  return SE3(q, Eigen::Vector3d(3.0, -1.5, 12.0));
}

Matrix6d random_covariance(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Matrix6d A;
  for (int i = 0; i < 36; ++i) A(i / 6, i % 6) = n(rng);
  A.topRows<3>() *= 0.01;      // cm
  A.bottomRows<3>() *= 0.002;  // mrad
  return A * A.transpose();
}

TEST(ReferencePoint, MachineFrameOfACameraLookingToTheRight) {
  auto R = rotation_cam_machine(geo::ForwardAxis::kMinusX);
  ASSERT_TRUE(R);
  // forward = -x, left = -z (the camera looks right), up = -y.
  EXPECT_TRUE(R->col(0).isApprox(-Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(R->col(1).isApprox(-Eigen::Vector3d::UnitZ()));
  EXPECT_TRUE(R->col(2).isApprox(-Eigen::Vector3d::UnitY()));
  EXPECT_NEAR(R->determinant(), 1.0, 1e-12);
  EXPECT_FALSE(rotation_cam_machine(geo::ForwardAxis::kPlusY).has_value());
}

TEST(ReferencePoint, MovesThePositionByTheRotatedLeverArmAndKeepsTheOrientation) {
  PoseEstimate camera;
  camera.T_world_cam = some_pose();
  const Eigen::Vector3d a(0.4, -1.2, 2.5);
  const PoseEstimate ref = reference_pose(camera, a);
  EXPECT_TRUE(ref.T_world_cam.translation().isApprox(camera.T_world_cam * a, 1e-12));
  EXPECT_TRUE(ref.T_world_cam.rotation().isApprox(camera.T_world_cam.rotation()));
}

// [dp; dtheta] of the reference point as a function of a left twist xi on
// the camera pose, by central differences; J Sigma J^T must equal what the
// published covariance says once converted (geo::site_covariance).
TEST(ReferencePoint, CovarianceMatchesTheNumericJacobianOfTheLeverArm) {
  PoseEstimate camera;
  camera.T_world_cam = some_pose();
  camera.covariance = random_covariance(7);
  const Eigen::Vector3d a(0.4, -1.2, 2.5);
  const PoseEstimate ref = published_pose(camera, a, CovarianceOptions{}, 0.0, 0.0);
  const Matrix6d analytic = geo::site_covariance(SE3::identity(), ref.T_world_cam, ref.covariance);

  const SE3 T_ref0 = reference_pose(camera, a).T_world_cam;
  auto moved = [&](const Vector6d& xi) {
    PoseEstimate p = camera;
    p.T_world_cam = SE3::exp(xi) * camera.T_world_cam;
    return reference_pose(p, a).T_world_cam;
  };
  Matrix6d J = Matrix6d::Zero();
  for (int k = 0; k < 6; ++k) {
    Vector6d d = Vector6d::Zero();
    d(k) = kStep;
    const SE3 plus = moved(d);
    const SE3 minus = moved(-d);
    J.block<3, 1>(0, k) = (plus.translation() - minus.translation()) / (2 * kStep);
    // Attitude error applied on the left: log(R R0^T).
    const Eigen::AngleAxisd dp(plus.rotation() * T_ref0.rotation().inverse());
    const Eigen::AngleAxisd dm(minus.rotation() * T_ref0.rotation().inverse());
    J.block<3, 1>(3, k) = (dp.angle() * dp.axis() - dm.angle() * dm.axis()) / (2 * kStep);
  }
  const Matrix6d numeric = J * camera.covariance * J.transpose();
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      EXPECT_NEAR(analytic(r, c), numeric(r, c), 1e-9 + 1e-6 * std::abs(numeric(r, c))) << r << "," << c;
    }
  }
  // The lever arm turns attitude uncertainty into position uncertainty:
  // the reference point is less certain than the camera.
  const Matrix6d at_camera = geo::site_covariance(SE3::identity(), camera.T_world_cam, camera.covariance);
  const Eigen::Matrix3d ref_position = analytic.topLeftCorner<3, 3>();
  const Eigen::Matrix3d cam_position = at_camera.topLeftCorner<3, 3>();
  EXPECT_GT(ref_position.trace(), cam_position.trace());
  const Eigen::Vector3d arm_world = camera.T_world_cam.rotation() * a;
  const Eigen::Matrix3d attitude = at_camera.bottomRightCorner<3, 3>();
  const Eigen::Matrix3d lever_term = hat(arm_world) * attitude * hat(arm_world).transpose();
  const Eigen::Matrix3d position_attitude = at_camera.topRightCorner<3, 3>();
  const Eigen::Matrix3d cross = -position_attitude * hat(arm_world).transpose();
  const Eigen::Matrix3d expected = cam_position + lever_term + cross + cross.transpose();
  EXPECT_TRUE(ref_position.isApprox(expected, 1e-9));
}

TEST(PublishedCovariance, ScaleAndIsotropicExtraAreWhatTheyClaim) {
  PoseEstimate camera;
  camera.T_world_cam = some_pose();
  camera.covariance = random_covariance(3);
  CovarianceOptions options{2.5, 0.01, 0.1};
  const PoseEstimate out = published_pose(camera, Eigen::Vector3d::Zero(), options, 0.02, 0.001);
  const Matrix6d published = geo::site_covariance(SE3::identity(), out.T_world_cam, out.covariance);
  const Matrix6d tracker = geo::site_covariance(SE3::identity(), camera.T_world_cam, camera.covariance);
  const double pos_var = 0.01 * 0.01 + 0.02 * 0.02;
  const double att_var = std::pow(0.1 * std::numbers::pi / 180.0, 2) + 0.001 * 0.001;
  Matrix6d expected = 2.5 * tracker;
  expected.topLeftCorner<3, 3>() += pos_var * Eigen::Matrix3d::Identity();
  expected.bottomRightCorner<3, 3>() += att_var * Eigen::Matrix3d::Identity();
  EXPECT_TRUE(published.isApprox(expected, 1e-9));
}

TEST(PublishedCovariance, MapDriftIsARandomWalkOverTheMapTravelOfThePose) {
  PoseEstimate camera;
  camera.T_world_cam = some_pose();
  camera.covariance = random_covariance(5);
  CovarianceOptions options{1.5, 0.005, 0.02, 0.002, 0.01};
  const Matrix6d tracker = geo::site_covariance(SE3::identity(), camera.T_world_cam, camera.covariance);
  for (const double travelled_m : {0.0, 10.0, 40.0}) {
    camera.map_travel_m = travelled_m;
    const PoseEstimate out = published_pose(camera, Eigen::Vector3d::Zero(), options, 0.02, 0.001);
    const Matrix6d published = geo::site_covariance(SE3::identity(), out.T_world_cam, out.covariance);
    // Variances grow linearly with the distance.
    const double pos_var = 0.005 * 0.005 + 0.02 * 0.02 + 0.002 * 0.002 * travelled_m;
    const double att_var = std::pow(0.02 * std::numbers::pi / 180.0, 2) + 0.001 * 0.001 +
                           std::pow(0.01 * std::numbers::pi / 180.0, 2) * travelled_m;
    Matrix6d expected = 1.5 * tracker;
    expected.topLeftCorner<3, 3>() += pos_var * Eigen::Matrix3d::Identity();
    expected.bottomRightCorner<3, 3>() += att_var * Eigen::Matrix3d::Identity();
    EXPECT_TRUE(published.isApprox(expected, 1e-9)) << travelled_m << " m";
  }
  // No drift configured, or no distance (negative, NaN): the term is 0.
  EXPECT_EQ(drift_std({1.0, 0.0, 0.0, 0.0, 0.0}, 100.0).position_m, 0.0);
  EXPECT_EQ(drift_std(options, -5.0).position_m, 0.0);
  EXPECT_EQ(drift_std(options, std::nan("")).attitude_rad, 0.0);
  EXPECT_DOUBLE_EQ(drift_std(options, 25.0).position_m, 0.01);
}

TEST(TravelledDistance, PathLengthOfTrackedPosesWithoutStandingJitterOrLostPoses) {
  TravelledDistance d;
  PoseEstimate pose;
  pose.state = TrackingState::kOk;
  const auto at = [&](double x, double y, TrackingState state = TrackingState::kOk) {
    pose.T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, y, 0.0));
    pose.state = state;
    return d.update(pose);
  };
  EXPECT_EQ(at(0.0, 0.0), 0.0);  // the first pose: the reference
  EXPECT_DOUBLE_EQ(at(1.0, 0.0), 1.0);
  // 1000 frames of 2 mm jitter while standing add nothing.
  for (int i = 0; i < 1000; ++i) at(1.0 + ((i % 2) != 0 ? 0.002 : -0.002), 0.0);
  EXPECT_DOUBLE_EQ(d.metres(), 1.0);
  // Slow driving, 1 cm a frame, is counted in steps of at least 5 cm (the
  // last one not yet counted).
  constexpr double kStepM = TravelledDistance::kMinStepM;
  for (int i = 1; i <= 100; ++i) at(1.0 + 0.01 * i, 0.0);
  EXPECT_NEAR(d.metres(), 2.0, kStepM);
  EXPECT_NEAR(at(2.5, 0.0), 2.5, 1e-9);
  // Back over the same 1.5 m: a path length, it grows (conservative).
  EXPECT_NEAR(at(1.0, 0.0), 4.0, 1e-9);
  // LOST poses (the last pose repeated, or anything) are skipped; the
  // relocalised pose counts as a straight step from the last tracked one.
  EXPECT_NEAR(at(50.0, 50.0, TrackingState::kLost), 4.0, 1e-9);
  EXPECT_NEAR(at(1.0, 3.0, TrackingState::kRecovering), 7.0, 1e-9);
  pose.T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(std::nan(""), 0.0, 0.0));
  EXPECT_NEAR(d.update(pose), 7.0, 1e-9);
}

TEST(PublishedCovariance, TheFirstPoseWithAZeroCovarianceIsNotPublishedWithOne) {
  PoseEstimate first;  // identity pose, zero covariance: it defines the SLAM frame
  first.covariance.setZero();
  const PoseEstimate out =
      published_pose(first, Eigen::Vector3d(1.0, 0.0, 0.0), {1.0, 0.005, 0.02}, 0.02, 0.0);
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(out.covariance);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
  const Matrix6d site = geo::site_covariance(SE3::identity(), out.T_world_cam, out.covariance);
  // Position: floor, anchor and the floor attitude through the 1 m arm.
  EXPECT_GT(std::sqrt(site(0, 0)), std::hypot(0.005, 0.02) - 1e-12);
}

TEST(Velocity, FromTwoPositionsWithTheirCovariances) {
  const Eigen::Matrix3d c = Eigen::Matrix3d::Identity() * 1e-4;
  const Velocity v =
      finite_difference_velocity({0, 0, 0}, c, 1'000'000'000, {0.1, -0.2, 0.0}, c, 1'100'000'000);
  ASSERT_TRUE(v.valid());
  EXPECT_TRUE(v.mps.isApprox(Eigen::Vector3d(1.0, -2.0, 0.0), 1e-9));
  EXPECT_TRUE(v.covariance.isApprox(Eigen::Matrix3d::Identity() * 2e-4 / 0.01, 1e-9));
  EXPECT_FALSE(finite_difference_velocity({0, 0, 0}, c, 5, {1, 0, 0}, c, 5).valid());
}

TEST(Integrity, ProtectionLevelIsSigmasTimesTheLargestAxisAgainstTheAlertLimit) {
  Eigen::Matrix3d c = Eigen::Vector3d(1e-4, 4e-4, 1e-4).asDiagonal();
  const double bound = protection_level_m(c, 3.0);
  EXPECT_NEAR(bound, 3 * 0.02, 1e-12);
  EXPECT_NEAR(protection_level_m(c, 4.5), 4.5 * 0.02, 1e-12);
  EXPECT_TRUE(integrity_alert(bound, 0.05));
  EXPECT_FALSE(integrity_alert(bound, 0.10));
  EXPECT_TRUE(integrity_alert(protection_level_m(c, 6.0), 0.10));
  EXPECT_FALSE(integrity_alert(bound, 0.0));  // no limit: never
  c(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(std::isinf(protection_level_m(c, 4.5)));
  EXPECT_TRUE(integrity_alert(protection_level_m(c, 4.5), 0.10));
}

}  // namespace
}  // namespace sitepose::output
