#include "sitepose/core/se3.hpp"

#include <cmath>

namespace sitepose {
namespace {
// Below this angle the series expansions are used (sin/theta loses precision).
constexpr double kSmallAngleRad = 1e-8;
}  // namespace

Eigen::Matrix3d hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return m;
}

Eigen::Quaterniond so3_exp(const Eigen::Vector3d& omega_rad) {
  const double theta = omega_rad.norm();
  const double half = 0.5 * theta;
  double imag_factor;
  double real;
  if (theta < kSmallAngleRad) {
    const double theta_sq = theta * theta;
    imag_factor = 0.5 - theta_sq / 48.0;
    real = 1.0 - theta_sq / 8.0;
  } else {
    imag_factor = std::sin(half) / theta;
    real = std::cos(half);
  }
  Eigen::Quaterniond q(real, imag_factor * omega_rad.x(), imag_factor * omega_rad.y(),
                       imag_factor * omega_rad.z());
  return q.normalized();
}

Eigen::Vector3d so3_log(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  // q and -q are the same rotation; pick w >= 0 so the angle is in [0, pi].
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d v = q.vec();
  const double sin_half = v.norm();
  if (sin_half < kSmallAngleRad) {
    return 2.0 * v / q.w();
  }
  const double theta = 2.0 * std::atan2(sin_half, q.w());
  return theta * v / sin_half;
}

Eigen::Matrix3d so3_left_jacobian(const Eigen::Vector3d& omega_rad) {
  const double theta = omega_rad.norm();
  const Eigen::Matrix3d W = hat(omega_rad);
  if (theta < 1e-5) return Eigen::Matrix3d::Identity() + 0.5 * W + W * W / 6.0;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(theta)) / t2 * W +
         (theta - std::sin(theta)) / (t2 * theta) * W * W;
}

Eigen::Matrix3d so3_left_jacobian_inverse(const Eigen::Vector3d& omega_rad) {
  const double theta = omega_rad.norm();
  const Eigen::Matrix3d W = hat(omega_rad);
  if (theta < 1e-5) return Eigen::Matrix3d::Identity() - 0.5 * W + W * W / 12.0;
  const double t2 = theta * theta;
  const double coeff = 1.0 / t2 - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta));
  return Eigen::Matrix3d::Identity() - 0.5 * W + coeff * W * W;
}

SE3::SE3(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation)
    : rotation_(rotation.normalized()), translation_(translation) {}

SE3::SE3(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation)
    : SE3(Eigen::Quaterniond(rotation), translation) {}

SE3 SE3::from_matrix(const Eigen::Matrix4d& T) {
  return from_matrix3x4(T.topRows<3>());
}

SE3 SE3::from_matrix3x4(const Eigen::Matrix<double, 3, 4>& T) {
  // Project onto SO(3) with an SVD so rounded file values give a rotation.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(T.leftCols<3>(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0.0) {
    Eigen::Matrix3d U = svd.matrixU();
    U.col(2) *= -1.0;
    R = U * svd.matrixV().transpose();
  }
  return SE3(R, T.col(3));
}

SE3 SE3::exp(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d omega = xi.tail<3>();
  return SE3(so3_exp(omega), so3_left_jacobian(omega) * rho);
}

Vector6d SE3::log() const {
  Vector6d xi;
  const Eigen::Vector3d omega = so3_log(rotation_);
  xi.head<3>() = so3_left_jacobian_inverse(omega) * translation_;
  xi.tail<3>() = omega;
  return xi;
}

SE3 SE3::inverse() const {
  const Eigen::Quaterniond r_inv = rotation_.conjugate();
  return SE3(r_inv, -(r_inv * translation_));
}

SE3 SE3::operator*(const SE3& other) const {
  return SE3(rotation_ * other.rotation_, rotation_ * other.translation_ + translation_);
}

Eigen::Matrix4d SE3::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = rotation_matrix();
  m.topRightCorner<3, 1>() = translation_;
  return m;
}

Eigen::Matrix<double, 3, 4> SE3::matrix3x4() const { return matrix().topRows<3>(); }

Matrix6d SE3::adjoint() const {
  Matrix6d ad = Matrix6d::Zero();
  const Eigen::Matrix3d R = rotation_matrix();
  ad.topLeftCorner<3, 3>() = R;
  ad.topRightCorner<3, 3>() = hat(translation_) * R;
  ad.bottomRightCorner<3, 3>() = R;
  return ad;
}

SE3 interpolate(const SE3& a, const SE3& b, double alpha) {
  return SE3(a.rotation().slerp(alpha, b.rotation()),
             (1.0 - alpha) * a.translation() + alpha * b.translation());
}

double rotation_angle_rad(const Eigen::Quaterniond& q) { return so3_log(q).norm(); }

}  // namespace sitepose
