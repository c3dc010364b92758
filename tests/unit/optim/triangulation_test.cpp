#include "sitepose/optim/triangulation.hpp"

#include <gtest/gtest.h>

#include <random>

#include "sitepose/testing/pose_scene.hpp"

namespace sitepose::optim {
namespace {

using testing::random_point_cam;
using testing::hd_camera;
using testing::test_pose_world_cam;

Eigen::Vector3d ray_of(const SE3& T_cam_world, const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d p_cam = T_cam_world * p_world;
  return p_cam / p_cam.z();
}

TEST(Triangulation, TwoViewRoundTrip) {
  std::mt19937 rng(1);
  const StereoCamera camera = hd_camera();
  const SE3 T_world_cam1 = test_pose_world_cam();
  Vector6d xi;
  xi << 1.0, 0.1, 0.5, 0.02, -0.1, 0.03;
  const SE3 T_world_cam2 = T_world_cam1 * SE3::exp(xi);
  const SE3 T_cam1_world = T_world_cam1.inverse();
  const SE3 T_cam2_world = T_world_cam2.inverse();
  int triangulated = 0;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d p_world = T_world_cam1 * random_point_cam(camera, 3.0, 30.0, rng);
    if ((T_cam2_world * p_world).z() <= 0.5) continue;
    // Pixel -> normalised ray, as the mapper will call it.
    const Eigen::Vector3d ray1 = normalised_ray(camera, camera.project(T_cam1_world * p_world));
    const Eigen::Vector3d ray2 = ray_of(T_cam2_world, p_world);
    const TwoViewTriangulation t = triangulate_two_view(T_cam1_world, ray1, T_cam2_world, ray2);
    if (t.status == TriangulationStatus::kLowParallax) {
      EXPECT_GE(t.cos_parallax, kOrbSlamMaxCosParallax);
      continue;
    }
    ++triangulated;
    ASSERT_EQ(t.status, TriangulationStatus::kOk) << to_string(t.status);
    EXPECT_LT((t.p_world - p_world).norm(), 1e-8 * p_world.norm());
    EXPECT_LT(t.cos_parallax, kOrbSlamMaxCosParallax);
  }
  EXPECT_GT(triangulated, 35);
}

TEST(Triangulation, LowParallaxIsRejected) {
  const SE3 T_cam1_world = SE3::identity();
  Vector6d xi = Vector6d::Zero();
  xi(0) = -0.01;  // 1 cm baseline
  const SE3 T_cam2_world = SE3::exp(xi);
  const Eigen::Vector3d p_world(0.5, 0.2, 50.0);  // ~0.01 deg of parallax
  const TwoViewTriangulation t = triangulate_two_view(T_cam1_world, ray_of(T_cam1_world, p_world),
                                                      T_cam2_world, ray_of(T_cam2_world, p_world));
  EXPECT_EQ(t.status, TriangulationStatus::kLowParallax);
  EXPECT_GT(t.cos_parallax, kOrbSlamMaxCosParallax);
  // The same geometry passes with a looser threshold.
  const TwoViewTriangulation loose = triangulate_two_view(
      T_cam1_world, ray_of(T_cam1_world, p_world), T_cam2_world, ray_of(T_cam2_world, p_world), 1.0);
  ASSERT_EQ(loose.status, TriangulationStatus::kOk);
  EXPECT_LT((loose.p_world - p_world).norm(), 1e-4);
}

TEST(Triangulation, PointBehindASecondCameraIsRejected) {
  const SE3 T_cam1_world = SE3::identity();
  Vector6d xi = Vector6d::Zero();
  xi(2) = -10.0;  // camera 2 sits 10 m ahead of camera 1, looking the same way
  const SE3 T_cam2_world = SE3::exp(xi);
  const Eigen::Vector3d p_world(1.0, 0.5, 5.0);  // in front of camera 1, behind camera 2
  const Eigen::Vector3d p_cam2 = T_cam2_world * p_world;
  ASSERT_LT(p_cam2.z(), 0.0);
  const Eigen::Vector3d ray2(p_cam2.x() / p_cam2.z(), p_cam2.y() / p_cam2.z(), 1.0);
  const TwoViewTriangulation t =
      triangulate_two_view(T_cam1_world, ray_of(T_cam1_world, p_world), T_cam2_world, ray2, 1.0);
  EXPECT_EQ(t.status, TriangulationStatus::kNotInFront);
}

TEST(StereoPoint, RoundTripMatchesCameraTriangulation) {
  const StereoCamera camera = hd_camera();
  const Eigen::Vector3d p_cam(2.0, -1.0, 12.0);
  const Eigen::Vector3d z = camera.project_stereo(p_cam);
  const auto point = stereo_point_in_camera(camera, z.head<2>(), z.z(), stereo_pixel_covariance(1, 1, 1));
  ASSERT_TRUE(point.has_value());
  EXPECT_LT((point->p - p_cam).norm(), 1e-12);
  const auto reference = camera.triangulate(z.head<2>(), z.z());
  ASSERT_TRUE(reference.has_value());
  EXPECT_LT((point->p - *reference).norm(), 1e-12);
  // sigma_Z = Z^2 sigma_d / (f b) with sigma_d^2 = 2 sigma^2 (METHOD.md).
  EXPECT_NEAR(std::sqrt(point->covariance(2, 2)), 12.0 * 12.0 * std::sqrt(2.0) / camera.bf(), 1e-9);
  EXPECT_FALSE(stereo_point_in_camera(camera, z.head<2>(), z.x(), stereo_pixel_covariance(1, 1, 1)));
}

// Covariance of the stereo point against Monte Carlo, in the camera frame and,
// with pose noise, in the world frame.
TEST(StereoPoint, CovarianceMatchesMonteCarlo) {
  const StereoCamera camera = hd_camera();
  const Eigen::Vector3d p_cam(3.0, -1.5, 10.0);  // disparity 35 px
  const Eigen::Vector3d z = camera.project_stereo(p_cam);
  const Eigen::Matrix3d pixel_cov = stereo_pixel_covariance(1.2, 0.8, 1.0);
  const auto predicted_cam = stereo_point_in_camera(camera, z.head<2>(), z.z(), pixel_cov);
  ASSERT_TRUE(predicted_cam.has_value());

  const SE3 T_world_cam = test_pose_world_cam();
  Matrix6d pose_cov = Matrix6d::Zero();
  pose_cov.diagonal() << 0.04, 0.01, 0.02, 4e-4, 1e-4, 2e-4;  // 10-20 cm, 0.6-1.1 deg
  pose_cov(0, 4) = pose_cov(4, 0) = 1e-3;
  const PointWithCovariance predicted_world = point_to_world(*predicted_cam, T_world_cam, &pose_cov);
  const Eigen::LLT<Matrix6d> pose_llt(pose_cov);

  std::mt19937 rng(9);
  std::normal_distribution<double> n(0.0, 1.0);
  constexpr int kSamples = 20000;
  Eigen::Matrix3d emp_cam = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d emp_world = Eigen::Matrix3d::Zero();
  Eigen::Vector3d mean_cam = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_world = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> cams;
  std::vector<Eigen::Vector3d> worlds;
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector3d noise(1.2 * n(rng), 0.8 * n(rng), 1.0 * n(rng));
    const auto p = stereo_point_in_camera(camera, z.head<2>() + noise.head<2>(), z.z() + noise.z(), pixel_cov);
    ASSERT_TRUE(p.has_value());
    Vector6d eps;
    for (int k = 0; k < 6; ++k) eps(k) = n(rng);
    eps = pose_llt.matrixL() * eps;
    cams.push_back(p->p);
    worlds.push_back(SE3::exp(eps) * T_world_cam * p->p);
    mean_cam += cams.back() / kSamples;
    mean_world += worlds.back() / kSamples;
  }
  for (int i = 0; i < kSamples; ++i) {
    emp_cam += (cams[i] - mean_cam) * (cams[i] - mean_cam).transpose() / (kSamples - 1);
    emp_world += (worlds[i] - mean_world) * (worlds[i] - mean_world).transpose() / (kSamples - 1);
  }
  // 20000 samples: ~1 % sampling error on a variance; first-order
  // propagation adds ~(sigma_d / d)^2 ~ 0.2 % here.
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(emp_cam(i, i) / predicted_cam->covariance(i, i), 1.0, 0.05) << i;
    EXPECT_NEAR(emp_world(i, i) / predicted_world.covariance(i, i), 1.0, 0.05) << i;
  }
  // Correlations (X and Y depend on the disparity too).
  auto corr = [](const Eigen::Matrix3d& c, int i, int j) { return c(i, j) / std::sqrt(c(i, i) * c(j, j)); };
  for (int i = 0; i < 3; ++i) {
    for (int j = i + 1; j < 3; ++j) {
      EXPECT_NEAR(corr(emp_cam, i, j), corr(predicted_cam->covariance, i, j), 0.03) << i << j;
      EXPECT_NEAR(corr(emp_world, i, j), corr(predicted_world.covariance, i, j), 0.03) << i << j;
    }
  }
  // The pose term matters here: without it the world covariance is too small.
  const PointWithCovariance without_pose = point_to_world(*predicted_cam, T_world_cam);
  EXPECT_LT(without_pose.covariance.trace(), 0.7 * emp_world.trace());
  EXPECT_LT((predicted_world.p - T_world_cam * p_cam).norm(), 1e-12);
}

}  // namespace
}  // namespace sitepose::optim
