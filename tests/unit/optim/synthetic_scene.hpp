#pragma once
// Synthetic stereo scenes for the optim tests: a camera, world points seen
// from a known pose, and noisy observations with ORB-like level sigmas.

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/optim/motion_only_ba.hpp"
#include "sitepose/optim/reprojection_costs.hpp"

namespace sitepose::optim::testing {

inline StereoCamera test_camera() {
  StereoCamera camera;
  camera.fx = 700.0;
  camera.fy = 700.0;
  camera.cx = 640.0;
  camera.cy = 360.0;
  camera.baseline_m = 0.5;
  camera.width = 1280;
  camera.height = 720;
  return camera;
}

inline constexpr double kScaleFactor = 1.2;  // ORB pyramid, as OrbConfig
inline constexpr double kCloseDepthM = 20.0;  // 40 baselines: stereo below, mono beyond

// A world pose T_world_cam that is neither identity nor axis aligned.
inline SE3 test_pose_world_cam() {
  Vector6d xi;
  xi << 3.0, -1.0, 12.0, 0.1, -0.4, 0.05;
  return SE3::exp(xi);
}

// Random point in the camera frustum at depth [min, max] (m), camera frame.
inline Eigen::Vector3d random_point_cam(const StereoCamera& camera, double min_depth_m, double max_depth_m,
                                        std::mt19937& rng) {
  std::uniform_real_distribution<double> u(10.0, camera.width - 10.0);
  std::uniform_real_distribution<double> v(10.0, camera.height - 10.0);
  std::uniform_real_distribution<double> z(min_depth_m, max_depth_m);
  return camera.unproject({u(rng), v(rng)}, z(rng));
}

// Exact (noise-free) observation of p_world from T_cam_world; stereo when
// closer than kCloseDepthM (or always mono when mono_only).
inline PoseObservation exact_observation(const StereoCamera& camera, const SE3& T_cam_world,
                                         const Eigen::Vector3d& p_world, int level, bool mono_only) {
  const Eigen::Vector3d p_cam = T_cam_world * p_world;
  PoseObservation o;
  o.p_world = p_world;
  o.uv_left_px = camera.project(p_cam);
  o.u_right_px = (!mono_only && p_cam.z() < kCloseDepthM) ? camera.project_right_u(p_cam) : -1.0;
  o.sigma2_px2 = level_sigma2_px2(kScaleFactor, level);
  return o;
}

// Gaussian pixel noise of the observation's own sigma on every coordinate.
inline void add_noise(PoseObservation& o, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, std::sqrt(o.sigma2_px2));
  o.uv_left_px.x() += n(rng);
  o.uv_left_px.y() += n(rng);
  if (o.is_stereo()) o.u_right_px += n(rng);
}

// Replace the measurement with a random pixel (and disparity for stereo).
inline void make_gross_outlier(const StereoCamera& camera, PoseObservation& o, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, camera.width);
  std::uniform_real_distribution<double> v(0.0, camera.height);
  std::uniform_real_distribution<double> d(1.0, 80.0);
  o.uv_left_px = {u(rng), v(rng)};
  if (o.is_stereo()) o.u_right_px = std::max(0.0, o.uv_left_px.x() - d(rng));
}

// Left perturbation of T_world_cam by translation_m along a random direction
// and rotation_rad about another.
inline SE3 perturb(const SE3& T, double translation_m, double rotation_rad, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d t_dir = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  const Eigen::Vector3d r_dir = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  Vector6d xi;
  xi << translation_m * t_dir, rotation_rad * r_dir;
  return SE3::exp(xi) * T;
}

inline double translation_error_m(const SE3& a, const SE3& b) {
  return (a.translation() - b.translation()).norm();
}
inline double rotation_error_rad(const SE3& a, const SE3& b) {
  return rotation_angle_rad(a.rotation() * b.rotation().conjugate());
}

}  // namespace sitepose::optim::testing
