#pragma once
// How the optimisers store a pose for Ceres, and how its uncertainty is
// expressed.
//
// Parameter block: 7 doubles [qx, qy, qz, qw, tx, ty, tz] of T_cam_world
// (Eigen quaternion coefficient order, then translation in metres).
//
// Perturbation: LEFT, on T_cam_world, with the SE(3) exponential of the core
// (tangent [rho (translation, m); phi (rotation, rad)]):
//   x (+) delta = exp(delta) * T_cam_world.
// At delta = 0 this moves a camera-frame point p_cam = T_cam_world * p_world
// by d p_cam / d delta = [I, -hat(p_cam)], which the cost functions use.
//
// Jacobian "lifting": the cost functions in reprojection_costs.hpp write the
// tangent Jacobian (d r / d delta) into the first 6 columns of their 7-column
// pose Jacobian and 0 into the last; this manifold's PlusJacobian is [I6; 0].
// Ceres only ever uses the product J_ambient * PlusJacobian, which then equals
// the true tangent Jacobian, and we skip the d R(q) / d q algebra per
// residual. Consequence: these cost functions are only valid with
// Se3LeftManifold, and ceres::GradientChecker (which differentiates in the
// ambient space) does not apply to them; the unit tests check the tangent
// Jacobian against central differences through Plus instead.
//
// Thread-safety: all types here are immutable after construction.

#include <ceres/manifold.h>

#include <array>

#include "sitepose/core/se3.hpp"

namespace sitepose::optim {

using PoseBlock = std::array<double, 7>;

PoseBlock to_pose_block(const SE3& T_cam_world);
SE3 from_pose_block(const double* block);

class Se3LeftManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  // Row-major 7x6 [I6; 0] (see the lifting note above).
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool RightMultiplyByPlusJacobian(const double* x, int num_rows, const double* ambient_matrix,
                                   double* tangent_matrix) const override;
  // y (-) x = log(y * x^-1), so that x (+) (y (-) x) = y.
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  // Row-major 6x7 [I6, 0], the left inverse of PlusJacobian.
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// Covariance of a left perturbation carried over to the inverse transform.
// If T_a_b' = exp(d) * T_a_b with d ~ N(0, cov_left_T_a_b), then
// T_b_a' = T_b_a * exp(-d) = exp(-Ad(T_b_a) d) * T_b_a, so the left
// covariance of T_b_a is Ad(T_b_a) * cov * Ad(T_b_a)^T.
// Tangent order [translation; rotation] (m^2, rad^2) on both sides.
Matrix6d left_covariance_of_inverse(const SE3& T_a_b, const Matrix6d& cov_left_T_a_b);

}  // namespace sitepose::optim
