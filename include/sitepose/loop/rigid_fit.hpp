#pragma once
// The rigid transform between two sets of corresponding 3D points, closed
// form (Horn 1987 / Umeyama 1991 without scale: stereo depth fixes the
// scale, so a loop is SE(3), not Sim(3)), and its RANSAC over 3-point
// samples (ORB-SLAM2 Sim3Solver, written for sitepose).
//
// Fit: T_a_b minimising sum_i |p_a_i - T_a_b * p_b_i|^2, by
// eval::umeyama_se3 (a proper rotation, never a reflection), after a guard
// on the centred cross-covariance H = sum_i (p_b_i - c_b)(p_a_i - c_a)^T:
// its second singular value below 1e-9 of the first means collinear points.
// Units are the points' (metres here).
//
// Thread-safety: pure functions.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"

namespace sitepose::loop {

// kInvalidArgument for fewer than 3 pairs, sizes that differ, or points
// (nearly) on a line, where the rotation about that line is not fixed.
Expected<SE3> fit_rigid(const std::vector<Eigen::Vector3d>& p_a, const std::vector<Eigen::Vector3d>& p_b);

struct RigidRansacParams {
  int max_iterations = 300;   // ORB-SLAM2 Sim3Solver
  int min_inliers = 20;       // ORB-SLAM2 Sim3Solver
  double probability = 0.99;  // stop once an all-inlier sample is this likely to have been drawn
  std::uint64_t seed = 1;     // the same inputs and seed give the same result
};

struct RigidRansacResult {
  SE3 T_a_b;
  std::vector<int> inliers;  // ascending indices into the pairs
  int iterations = 0;
};

// is_inlier(T_a_b, i): whether pair i agrees with a hypothesis (the caller
// decides how: reprojection in both views for a loop). The best sample's
// hypothesis is refitted on its inliers and the inliers counted again.
// kNotFound when no hypothesis reaches min_inliers.
Expected<RigidRansacResult> ransac_rigid(const std::vector<Eigen::Vector3d>& p_a,
                                         const std::vector<Eigen::Vector3d>& p_b,
                                         const std::function<bool(const SE3&, int)>& is_inlier,
                                         const RigidRansacParams& params = {});

}  // namespace sitepose::loop
