#include "sitepose/optim/pose_parameterization.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <random>

namespace sitepose::optim {
namespace {

SE3 random_pose(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  for (int i = 0; i < 6; ++i) xi(i) = n(rng);
  return SE3::exp(xi);
}

TEST(Se3LeftManifold, PlusIsLeftExponential) {
  std::mt19937 rng(3);
  Se3LeftManifold m;
  for (int trial = 0; trial < 10; ++trial) {
    const SE3 T = random_pose(rng);
    const SE3 D = random_pose(rng);
    const Vector6d delta = 0.3 * D.log();
    const PoseBlock x = to_pose_block(T);
    PoseBlock y;
    ASSERT_TRUE(m.Plus(x.data(), delta.data(), y.data()));
    const SE3 expected = SE3::exp(delta) * T;
    const SE3 got = from_pose_block(y.data());
    EXPECT_LT((got.translation() - expected.translation()).norm(), 1e-12);
    EXPECT_LT(rotation_angle_rad(got.rotation() * expected.rotation().conjugate()), 1e-12);
  }
}

TEST(Se3LeftManifold, PlusZeroAndMinusInvertPlus) {
  std::mt19937 rng(4);
  Se3LeftManifold m;
  for (int trial = 0; trial < 10; ++trial) {
    const PoseBlock x = to_pose_block(random_pose(rng));
    const Vector6d zero = Vector6d::Zero();
    PoseBlock same;
    ASSERT_TRUE(m.Plus(x.data(), zero.data(), same.data()));
    for (int i = 0; i < 7; ++i) EXPECT_NEAR(same[i], x[i], 1e-14);

    std::normal_distribution<double> n(0.0, 0.5);
    Vector6d delta;
    for (int i = 0; i < 6; ++i) delta(i) = n(rng);
    PoseBlock y;
    ASSERT_TRUE(m.Plus(x.data(), delta.data(), y.data()));
    Vector6d back;
    ASSERT_TRUE(m.Minus(y.data(), x.data(), back.data()));
    EXPECT_LT((back - delta).norm(), 1e-10);
  }
}

TEST(Se3LeftManifold, MinusJacobianIsLeftInverseOfPlusJacobian) {
  Se3LeftManifold m;
  const PoseBlock x = to_pose_block(SE3::identity());
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P;
  Eigen::Matrix<double, 6, 7, Eigen::RowMajor> M;
  ASSERT_TRUE(m.PlusJacobian(x.data(), P.data()));
  ASSERT_TRUE(m.MinusJacobian(x.data(), M.data()));
  EXPECT_TRUE((M * P).isApprox(Matrix6d::Identity()));
}

TEST(Se3LeftManifold, JacobiansAreThePaddedIdentities) {
  // The lifting note of the header: PlusJacobian [I6; 0], MinusJacobian
  // [I6, 0], every entry written (the buffers start as NaN).
  Se3LeftManifold m;
  const PoseBlock x = to_pose_block(SE3::identity());
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P;
  Eigen::Matrix<double, 6, 7, Eigen::RowMajor> M;
  P.setConstant(std::numeric_limits<double>::quiet_NaN());
  M.setConstant(std::numeric_limits<double>::quiet_NaN());
  ASSERT_TRUE(m.PlusJacobian(x.data(), P.data()));
  ASSERT_TRUE(m.MinusJacobian(x.data(), M.data()));
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> expected_plus =
      Eigen::Matrix<double, 7, 6, Eigen::RowMajor>::Zero();
  expected_plus.topRows<6>().setIdentity();
  EXPECT_TRUE(P == expected_plus);
  EXPECT_TRUE(M == expected_plus.transpose());
}

TEST(PoseCovariance, InverseCarriesLeftPerturbationWithAdjoint) {
  // For small d: T_b_a' = inverse(exp(d) T_a_b) = exp(-Ad(T_b_a) d) T_b_a,
  // which is what left_covariance_of_inverse() relies on.
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1e-6);
  const SE3 T_a_b = random_pose(rng);
  const SE3 T_b_a = T_a_b.inverse();
  Vector6d d;
  for (int i = 0; i < 6; ++i) d(i) = n(rng);
  const Vector6d eps = ((SE3::exp(d) * T_a_b).inverse() * T_b_a.inverse()).log();
  const Vector6d predicted = -T_b_a.adjoint() * d;
  EXPECT_LT((eps - predicted).norm(), 1e-6 * d.norm());

  Matrix6d cov = Matrix6d::Zero();
  cov.diagonal() << 1.0, 2.0, 3.0, 0.1, 0.2, 0.3;
  const Matrix6d cov_inv = left_covariance_of_inverse(T_a_b, cov);
  const Matrix6d expected = T_b_a.adjoint() * cov * T_b_a.adjoint().transpose();
  EXPECT_TRUE(cov_inv.isApprox(expected, 1e-12));
  // Round trip through both inverses gives the input back.
  EXPECT_TRUE(left_covariance_of_inverse(T_b_a, cov_inv).isApprox(cov, 1e-9));
}

}  // namespace
}  // namespace sitepose::optim
