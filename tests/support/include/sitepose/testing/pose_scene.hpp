#pragma once
// Synthetic stereo scenes for pose and bundle-adjustment tests: world points
// seen from a known pose through hd_camera(), and noisy observations with
// ORB-like level sigmas. Needs sitepose::optim.

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/optim/local_ba.hpp"
#include "sitepose/optim/motion_only_ba.hpp"
#include "sitepose/optim/reprojection_costs.hpp"
#include "sitepose/testing/cameras.hpp"

namespace sitepose::testing {

inline constexpr double kDegToRad = std::numbers::pi / 180.0;
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
inline optim::PoseObservation exact_observation(const StereoCamera& camera, const SE3& T_cam_world,
                                         const Eigen::Vector3d& p_world, int level, bool mono_only) {
  const Eigen::Vector3d p_cam = T_cam_world * p_world;
  optim::PoseObservation o;
  o.p_world = p_world;
  o.uv_left_px = camera.project(p_cam);
  o.u_right_px = (!mono_only && p_cam.z() < kCloseDepthM) ? camera.project_right_u(p_cam) : -1.0;
  o.sigma2_px2 = optim::level_sigma2_px2(kScaleFactor, level);
  return o;
}

// Gaussian pixel noise of the observation's own sigma on every coordinate.
inline void add_noise(optim::PoseObservation& o, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, std::sqrt(o.sigma2_px2));
  o.uv_left_px.x() += n(rng);
  o.uv_left_px.y() += n(rng);
  if (o.is_stereo()) o.u_right_px += n(rng);
}

// Replace the measurement with a random pixel (and disparity for stereo).
inline void make_gross_outlier(const StereoCamera& camera, optim::PoseObservation& o, std::mt19937& rng) {
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

struct MapScene {
  std::vector<SE3> T_cam_world_true;
  std::vector<Eigen::Vector3d> p_world_true;
  optim::LocalBaInput input;  // perturbed poses / points, noisy observations
  std::vector<std::uint8_t> gross_outlier;  // per observation
};

// Eight keyframes 1 m apart along a slightly turning path, points 4-30 m in
// front (stereo below 20 m, mono beyond); keyframes 0 and 1 are the fixed
// outer ring. Free poses are perturbed by 5 cm / 0.5 deg, points by 0.3 m per
// axis (about the depth noise of a single stereo match at 10-15 m).
inline MapScene make_map_scene(double outlier_fraction, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const StereoCamera camera = hd_camera();
  MapScene s;
  constexpr int kKeyframes = 8;
  const SE3 T_world_start = test_pose_world_cam();
  for (int k = 0; k < kKeyframes; ++k) {
    Vector6d xi;
    xi << 0.1 * k, 0.02 * k, 1.0 * k, 0.0, 0.02 * k, 0.0;
    s.T_cam_world_true.push_back((T_world_start * SE3::exp(xi)).inverse());
  }
  const SE3 T_world_mid = s.T_cam_world_true[kKeyframes / 2].inverse();
  for (int i = 0; i < 300; ++i) {
    s.p_world_true.push_back(T_world_mid * random_point_cam(camera, 4.0, 30.0, rng));
  }
  std::uniform_int_distribution<int> level(0, 2);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < kKeyframes; ++k) {
    for (int p = 0; p < static_cast<int>(s.p_world_true.size()); ++p) {
      const Eigen::Vector3d p_cam = s.T_cam_world_true[k] * s.p_world_true[p];
      if (p_cam.z() < 1.0 || !camera.in_image(camera.project(p_cam), 5.0)) continue;
      optim::PoseObservation o = exact_observation(camera, s.T_cam_world_true[k], s.p_world_true[p], level(rng),
                                            /*mono_only=*/false);
      const bool outlier = unit(rng) < outlier_fraction;
      if (outlier) {
        make_gross_outlier(camera, o, rng);
      } else {
        add_noise(o, rng);
      }
      s.input.observations.push_back({k, p, o.uv_left_px, o.u_right_px, o.sigma2_px2});
      s.gross_outlier.push_back(outlier ? 1 : 0);
    }
  }
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < kKeyframes; ++k) {
    const bool fixed = k < 2;
    s.input.keyframe_fixed.push_back(fixed ? 1 : 0);
    const SE3 T_world_cam = s.T_cam_world_true[k].inverse();
    s.input.T_cam_world.push_back(fixed ? s.T_cam_world_true[k]
                                        : perturb(T_world_cam, 0.05, 0.5 * kDegToRad, rng).inverse());
  }
  for (const Eigen::Vector3d& p : s.p_world_true) {
    s.input.p_world.push_back(p + 0.3 * Eigen::Vector3d(n(rng), n(rng), n(rng)));
  }
  return s;
}

}  // namespace sitepose::testing
