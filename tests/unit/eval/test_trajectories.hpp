#pragma once
// Synthetic trajectories shared by the eval tests (and the eval plot test in
// tests/unit/experiments).

#include <cmath>

#include "sitepose/core/se3.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::eval::testing {

// A machine-like path in the x-z plane (camera y down) with curvature and
// speed changes, so a time offset is observable; the camera yaws with the
// heading. n poses at rate_hz starting at t0_s.
inline SE3 curvy_pose(double t) {
  const Eigen::Vector3d p(8.0 * std::sin(0.21 * t) + 1.5 * std::sin(0.9 * t),
                          0.3 * std::sin(0.5 * t), 0.8 * t + 4.0 * std::sin(0.33 * t));
  const double yaw = 0.6 * std::sin(0.27 * t);
  const double pitch = 0.05 * std::sin(0.7 * t);
  return SE3(so3_exp(Eigen::Vector3d(pitch, yaw, 0.0)), p);
}

inline io::Trajectory curvy_trajectory(int n, double rate_hz, double t0_s = 100.0) {
  io::Trajectory traj;
  traj.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double t = i / rate_hz;
    traj.push_back({t0_s + t, curvy_pose(t)});
  }
  return traj;
}

// Every pose mapped into another world frame: T_other_world * T_world_cam.
inline io::Trajectory transformed(const io::Trajectory& traj, const SE3& T_other_world) {
  io::Trajectory out = traj;
  for (auto& p : out) p.T_world_cam = T_other_world * p.T_world_cam;
  return out;
}

inline SE3 some_rigid_transform() {
  return SE3(so3_exp(Eigen::Vector3d(0.4, -1.1, 2.3)), Eigen::Vector3d(120.0, -35.0, 7.5));
}

// `gt` with every other pose missing in its first half (coverage known) and
// 0.1 m error along the camera x axis on odd-tenth frames, in another world
// frame (some_rigid_transform()).
inline io::Trajectory sparse_estimate(const io::Trajectory& gt) {
  io::Trajectory est;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    if (i < gt.size() / 2 && i % 2 == 1) continue;
    io::StampedPose p = gt[i];
    const double bump = (i / 10) % 2 == 1 ? 0.1 : 0.0;
    p.T_world_cam = p.T_world_cam * SE3(Eigen::Quaterniond::Identity(), {bump, 0.0, 0.0});
    est.push_back(p);
  }
  return transformed(est, some_rigid_transform());
}

}  // namespace sitepose::eval::testing
