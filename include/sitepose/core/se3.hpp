#pragma once
// Rigid transforms on Eigen (Sophus is not available on the target).
// Naming: T_a_b maps points from frame b into frame a, so
// p_world = T_world_cam * p_cam and T_world_cam = T_world_body * T_body_cam.
// Tangent vectors are ordered [translation (3); rotation (3)] like Sophus.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace sitepose {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// so(3) helpers.
Eigen::Matrix3d hat(const Eigen::Vector3d& w);
Eigen::Quaterniond so3_exp(const Eigen::Vector3d& omega_rad);
Eigen::Vector3d so3_log(const Eigen::Quaterniond& q);
// Left Jacobian of SO(3) and its inverse (used by SE(3) exp/log).
Eigen::Matrix3d so3_left_jacobian(const Eigen::Vector3d& omega_rad);
Eigen::Matrix3d so3_left_jacobian_inverse(const Eigen::Vector3d& omega_rad);

class SE3 {
 public:
  SE3() : rotation_(Eigen::Quaterniond::Identity()), translation_(Eigen::Vector3d::Zero()) {}
  SE3(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation);
  SE3(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);
  // From a 4x4 or the top 3x4 of a homogeneous matrix; the rotation block is
  // re-orthonormalised (files store a few digits only).
  static SE3 from_matrix(const Eigen::Matrix4d& T);
  static SE3 from_matrix3x4(const Eigen::Matrix<double, 3, 4>& T);

  static SE3 identity() { return SE3(); }
  // xi = [rho; omega]: exp of the twist.
  static SE3 exp(const Vector6d& xi);
  Vector6d log() const;

  SE3 inverse() const;
  SE3 operator*(const SE3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return rotation_ * p + translation_; }

  const Eigen::Quaterniond& rotation() const { return rotation_; }
  Eigen::Matrix3d rotation_matrix() const { return rotation_.toRotationMatrix(); }
  const Eigen::Vector3d& translation() const { return translation_; }
  Eigen::Matrix4d matrix() const;
  Eigen::Matrix<double, 3, 4> matrix3x4() const;

  // Adjoint, maps tangent vectors: Ad(T) * xi = log(T * exp(xi) * T^-1).
  Matrix6d adjoint() const;

 private:
  Eigen::Quaterniond rotation_;  // always unit norm
  Eigen::Vector3d translation_;
};

// Geodesic interpolation: alpha = 0 gives a, 1 gives b; rotation by slerp and
// translation linearly (the decoupled form a machine's pose stream expects).
SE3 interpolate(const SE3& a, const SE3& b, double alpha);

// Rotation angle of a relative rotation (rad), robust near 0 and pi.
double rotation_angle_rad(const Eigen::Quaterniond& q);

}  // namespace sitepose
