#include "sitepose/core/se3.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace sitepose {
namespace {

Vector6d random_twist(std::mt19937& rng, double rot_scale) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  for (int i = 0; i < 3; ++i) xi[i] = 2.0 * n(rng);
  for (int i = 3; i < 6; ++i) xi[i] = rot_scale * n(rng);
  return xi;
}

TEST(SE3, ExpLogRoundTrip) {
  std::mt19937 rng(7);
  for (int i = 0; i < 500; ++i) {
    Vector6d xi = random_twist(rng, 0.8);
    if (xi.tail<3>().norm() > 3.0) continue;  // stay inside the injectivity radius
    const Vector6d back = SE3::exp(xi).log();
    EXPECT_LT((back - xi).norm(), 1e-9) << "twist " << xi.transpose();
  }
}

TEST(SE3, ExpLogRoundTripNearZeroAndPi) {
  Vector6d tiny;
  tiny << 1e-3, -2e-3, 5e-4, 1e-10, -2e-10, 3e-11;
  EXPECT_LT((SE3::exp(tiny).log() - tiny).norm(), 1e-12);
  Vector6d near_pi;
  near_pi << 0.5, 0.1, -0.2, 0.0, 0.0, M_PI - 1e-6;
  EXPECT_LT((SE3::exp(near_pi).log() - near_pi).norm(), 1e-6);
}

TEST(SE3, CompositionMatchesMatrices) {
  std::mt19937 rng(11);
  for (int i = 0; i < 100; ++i) {
    const SE3 a = SE3::exp(random_twist(rng, 1.0));
    const SE3 b = SE3::exp(random_twist(rng, 1.0));
    EXPECT_LT(((a * b).matrix() - a.matrix() * b.matrix()).norm(), 1e-12);
    EXPECT_LT(((a * a.inverse()).matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
    const Eigen::Vector3d p(1.0, -2.0, 3.0);
    EXPECT_LT(((a * b) * p - a * (b * p)).norm(), 1e-12);
  }
}

TEST(SE3, FromMatrixReorthonormalises) {
  const SE3 T = SE3::exp((Vector6d() << 1, 2, 3, 0.1, 0.2, 0.3).finished());
  Eigen::Matrix<double, 3, 4> rounded = T.matrix3x4();
  rounded(0, 0) += 1e-6;  // as if printed with 6 digits
  const SE3 back = SE3::from_matrix3x4(rounded);
  EXPECT_NEAR(back.rotation_matrix().determinant(), 1.0, 1e-12);
  EXPECT_LT((back.matrix() - T.matrix()).norm(), 1e-5);
}

TEST(SE3, AdjointMapsTwists) {
  std::mt19937 rng(3);
  const SE3 T = SE3::exp(random_twist(rng, 0.5));
  Vector6d xi = random_twist(rng, 0.1) * 1e-3;
  const SE3 lhs = T * SE3::exp(xi) * T.inverse();
  const SE3 rhs = SE3::exp(T.adjoint() * xi);
  EXPECT_LT((lhs.matrix() - rhs.matrix()).norm(), 1e-10);
}

TEST(SE3, InterpolateEndpointsAndMidpoint) {
  const SE3 a = SE3::exp((Vector6d() << 0, 0, 0, 0, 0, 0).finished());
  const SE3 b = SE3::exp((Vector6d() << 2, 0, 0, 0, 0, 1.0).finished());
  EXPECT_LT((interpolate(a, b, 0.0).matrix() - a.matrix()).norm(), 1e-12);
  EXPECT_LT((interpolate(a, b, 1.0).matrix() - b.matrix()).norm(), 1e-12);
  const SE3 mid = interpolate(a, b, 0.5);
  EXPECT_NEAR(rotation_angle_rad(mid.rotation()), 0.5, 1e-12);
  EXPECT_LT((mid.translation() - 0.5 * b.translation()).norm(), 1e-12);
}

}  // namespace
}  // namespace sitepose
