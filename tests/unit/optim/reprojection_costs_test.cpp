// Jacobian checks (STYLE.md §8): each analytic cost Jacobian against central
// differences, the pose taken through Se3LeftManifold::Plus as Ceres does.

#include "sitepose/optim/reprojection_costs.hpp"

#include <gtest/gtest.h>

#include <random>

#include "sitepose/optim/pose_parameterization.hpp"
#include "sitepose/testing/pose_scene.hpp"

namespace sitepose::optim {
namespace {

using testing::hd_camera;

constexpr double kStep = 1e-6;

// Central-difference tangent Jacobian of `cost` w.r.t. the pose block
// (through Plus) and, when it has one, the point block; compares with the
// analytic Jacobian after the manifold's PlusJacobian.
void expect_jacobians_match(const ceres::CostFunction& cost, PoseBlock pose, Eigen::Vector3d point) {
  const int rows = cost.num_residuals();
  const bool has_point = cost.parameter_block_sizes().size() == 2;
  Se3LeftManifold manifold;

  std::vector<double> r(rows);
  std::vector<double> J_pose_ambient(rows * 7);
  std::vector<double> J_point(rows * 3);
  double* jacobians[2] = {J_pose_ambient.data(), J_point.data()};
  const double* params[2] = {pose.data(), point.data()};
  ASSERT_TRUE(cost.Evaluate(params, r.data(), jacobians));
  // Column 6 of the lifted Jacobian must be zero (pose_parameterization.hpp).
  for (int i = 0; i < rows; ++i) EXPECT_EQ(J_pose_ambient[i * 7 + 6], 0.0);
  std::vector<double> J_pose(rows * 6);
  ASSERT_TRUE(manifold.RightMultiplyByPlusJacobian(pose.data(), rows, J_pose_ambient.data(), J_pose.data()));

  auto eval = [&](const PoseBlock& p, const Eigen::Vector3d& x) {
    std::vector<double> out(rows);
    const double* ps[2] = {p.data(), x.data()};
    EXPECT_TRUE(cost.Evaluate(ps, out.data(), nullptr));
    return out;
  };
  for (int k = 0; k < 6; ++k) {
    Vector6d d = Vector6d::Zero();
    d(k) = kStep;
    PoseBlock plus;
    PoseBlock minus;
    manifold.Plus(pose.data(), d.data(), plus.data());
    d(k) = -kStep;
    manifold.Plus(pose.data(), d.data(), minus.data());
    const std::vector<double> rp = eval(plus, point);
    const std::vector<double> rm = eval(minus, point);
    for (int i = 0; i < rows; ++i) {
      const double numeric = (rp[i] - rm[i]) / (2.0 * kStep);
      const double analytic = J_pose[i * 6 + k];
      EXPECT_NEAR(analytic, numeric, 1e-5 * std::max(1.0, std::abs(numeric)))
          << "pose column " << k << " row " << i;
    }
  }
  if (!has_point) return;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d plus = point;
    Eigen::Vector3d minus = point;
    plus(k) += kStep;
    minus(k) -= kStep;
    const std::vector<double> rp = eval(pose, plus);
    const std::vector<double> rm = eval(pose, minus);
    for (int i = 0; i < rows; ++i) {
      const double numeric = (rp[i] - rm[i]) / (2.0 * kStep);
      EXPECT_NEAR(J_point[i * 3 + k], numeric, 1e-5 * std::max(1.0, std::abs(numeric)))
          << "point column " << k << " row " << i;
    }
  }
}

struct CostCase {
  PoseBlock pose;
  Eigen::Vector3d p_world;
  Eigen::Vector3d observed;  // (u_l, v_l, u_r) near, not at, the projection
  double sigma2;
};

std::vector<CostCase> random_cases(int count) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  const StereoCamera camera = hd_camera();
  std::vector<CostCase> cases;
  for (int i = 0; i < count; ++i) {
    Vector6d xi;
    xi << 2.0 * n(rng), 2.0 * n(rng), 2.0 * n(rng), 0.5 * n(rng), 0.5 * n(rng), 0.5 * n(rng);
    const SE3 T_cam_world = SE3::exp(xi);
    const Eigen::Vector3d p_cam = testing::random_point_cam(camera, 2.0, 30.0, rng);
    CostCase c;
    c.pose = to_pose_block(T_cam_world);
    c.p_world = T_cam_world.inverse() * p_cam;
    c.observed = camera.project_stereo(p_cam) + Eigen::Vector3d(3.0 * n(rng), 3.0 * n(rng), 3.0 * n(rng));
    c.sigma2 = level_sigma2_px2(1.2, i % 8);
    cases.push_back(c);
  }
  return cases;
}

TEST(ReprojectionCosts, StereoPoseCostJacobianMatchesNumeric) {
  for (const CostCase& c : random_cases(20)) {
    const StereoPoseCost cost(hd_camera(), c.p_world, c.observed, c.sigma2);
    expect_jacobians_match(cost, c.pose, c.p_world);
  }
}

TEST(ReprojectionCosts, MonoPoseCostJacobianMatchesNumeric) {
  for (const CostCase& c : random_cases(20)) {
    const MonoPoseCost cost(hd_camera(), c.p_world, c.observed.head<2>(), c.sigma2);
    expect_jacobians_match(cost, c.pose, c.p_world);
  }
}

TEST(ReprojectionCosts, StereoReprojectionCostJacobiansMatchNumeric) {
  for (const CostCase& c : random_cases(20)) {
    const StereoReprojectionCost cost(hd_camera(), c.observed, c.sigma2);
    expect_jacobians_match(cost, c.pose, c.p_world);
  }
}

TEST(ReprojectionCosts, MonoReprojectionCostJacobiansMatchNumeric) {
  for (const CostCase& c : random_cases(20)) {
    const MonoReprojectionCost cost(hd_camera(), c.observed.head<2>(), c.sigma2);
    expect_jacobians_match(cost, c.pose, c.p_world);
  }
}

TEST(ReprojectionCosts, ResidualIsWhitenedObservationMinusProjection) {
  const StereoCamera camera = hd_camera();
  const SE3 T_cam_world = testing::test_pose_world_cam().inverse();
  const Eigen::Vector3d p_cam(1.0, -0.5, 8.0);
  const Eigen::Vector3d p_world = T_cam_world.inverse() * p_cam;
  const Eigen::Vector3d predicted = camera.project_stereo(p_cam);
  const Eigen::Vector3d observed = predicted + Eigen::Vector3d(2.0, -1.0, 0.5);
  const double sigma2 = level_sigma2_px2(1.2, 2);  // 1.44^2 ... sigma = 1.44
  const StereoPoseCost cost(camera, p_world, observed, sigma2);
  const PoseBlock pose = to_pose_block(T_cam_world);
  const double* params[1] = {pose.data()};
  double r[3];
  ASSERT_TRUE(cost.Evaluate(params, r, nullptr));
  EXPECT_NEAR(r[0], 2.0 / 1.44, 1e-9);
  EXPECT_NEAR(r[1], -1.0 / 1.44, 1e-9);
  EXPECT_NEAR(r[2], 0.5 / 1.44, 1e-9);
  // u_r of Eq. 2: fx (X - b) / Z + cx.
  EXPECT_NEAR(predicted.z(), 700.0 * (1.0 - 0.5) / 8.0 + 640.0, 1e-12);
}

TEST(ReprojectionCosts, PointBehindCameraFailsEvaluation) {
  const StereoCamera camera = hd_camera();
  const PoseBlock pose = to_pose_block(SE3::identity());
  const Eigen::Vector3d p_world(0.0, 0.0, -2.0);
  const MonoPoseCost cost(camera, p_world, Eigen::Vector2d(640.0, 360.0), 1.0);
  const double* params[1] = {pose.data()};
  double r[2];
  EXPECT_FALSE(cost.Evaluate(params, r, nullptr));
}

TEST(ReprojectionCosts, LevelSigmaFollowsScaleFactor) {
  EXPECT_DOUBLE_EQ(level_sigma2_px2(1.2, 0), 1.0);
  EXPECT_NEAR(level_sigma2_px2(1.2, 1), 1.44, 1e-12);
  EXPECT_NEAR(level_sigma2_px2(1.2, 3), std::pow(1.2, 6), 1e-12);
}

}  // namespace
}  // namespace sitepose::optim
