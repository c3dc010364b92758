#pragma once
// Reprojection residuals of the paper's Eq. 2-4 with analytic Jacobians.
//
// Monocular (kDim = 2):  r = (z - pi_m(p_cam)) / sigma, z = (u_l, v_l)
// Stereo    (kDim = 3):  r = (z - pi_s(p_cam)) / sigma, z = (u_l, v_l, u_r),
//   pi_s = (fx X/Z + cx, fy Y/Z + cy, fx (X - b)/Z + cx)
// with p_cam = T_cam_world * p_world and sigma^2 the variance of the
// keypoint's pyramid level (scale_factor^(2 level), px^2), so ||r||^2 is the
// chi^2 value ORB-SLAM2 gates with 5.991 (2 dof) and 7.815 (3 dof).
//
// Pose block: 7 doubles of T_cam_world; its Jacobian is "lifted" (tangent
// Jacobian for a left perturbation in columns 0-5, zero in column 6), valid
// only with Se3LeftManifold (pose_parameterization.hpp).
// Point block (ReprojectionCost only): 3 doubles, p_world in metres.
//
// Evaluate returns false when the point is not in front of the camera
// (Z <= kMinDepthM), which makes Ceres reject that step.
// Thread-safety: immutable; Evaluate may run concurrently.

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::optim {

// Depth below which a point counts as behind the camera (m).
inline constexpr double kMinDepthM = 1e-6;

// Variance of a keypoint at pyramid level `level` (px^2): ORB-SLAM2's
// mvLevelSigma2 = scale_factor^(2 level).
double level_sigma2_px2(double scale_factor, int level);

// Whitened residual of a camera-frame point and, when d_r_d_p_cam is not null,
// its Jacobian with respect to p_cam. Returns false when Z <= kMinDepthM.
template <int kDim>
bool whitened_reprojection(const StereoCamera& camera, const Eigen::Vector3d& p_cam,
                           const Eigen::Matrix<double, kDim, 1>& observed_px, double sqrt_information,
                           Eigen::Matrix<double, kDim, 1>* residual,
                           Eigen::Matrix<double, kDim, 3>* d_r_d_p_cam);

// Motion-only BA: the world point is a constant of the residual.
template <int kDim>
class PoseOnlyReprojectionCost final : public ceres::SizedCostFunction<kDim, 7> {
 public:
  PoseOnlyReprojectionCost(const StereoCamera& camera, const Eigen::Vector3d& p_world,
                           const Eigen::Matrix<double, kDim, 1>& observed_px, double sigma2_px2);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  StereoCamera camera_;
  Eigen::Vector3d p_world_;
  Eigen::Matrix<double, kDim, 1> observed_px_;
  double sqrt_information_;
};

// Bundle adjustment: pose block and point block.
template <int kDim>
class ReprojectionCost final : public ceres::SizedCostFunction<kDim, 7, 3> {
 public:
  ReprojectionCost(const StereoCamera& camera, const Eigen::Matrix<double, kDim, 1>& observed_px,
                   double sigma2_px2);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  StereoCamera camera_;
  Eigen::Matrix<double, kDim, 1> observed_px_;
  double sqrt_information_;
};

using MonoPoseCost = PoseOnlyReprojectionCost<2>;
using StereoPoseCost = PoseOnlyReprojectionCost<3>;
using MonoReprojectionCost = ReprojectionCost<2>;
using StereoReprojectionCost = ReprojectionCost<3>;

}  // namespace sitepose::optim
