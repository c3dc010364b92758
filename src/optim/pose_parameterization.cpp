#include "sitepose/optim/pose_parameterization.hpp"

#include <Eigen/Core>
#include <algorithm>

namespace sitepose::optim {
namespace {

// Writes the row-major Rows x Cols matrix [I, 0] (or [I; 0]): Eigen's
// identity of a non-square matrix is the square identity padded with zeros.
template <int Rows, int Cols>
void write_padded_identity(double* out) {
  Eigen::Map<Eigen::Matrix<double, Rows, Cols, Eigen::RowMajor>>(out).setIdentity();
}

}  // namespace

PoseBlock to_pose_block(const SE3& T_cam_world) {
  const Eigen::Quaterniond& q = T_cam_world.rotation();
  const Eigen::Vector3d& t = T_cam_world.translation();
  return {q.x(), q.y(), q.z(), q.w(), t.x(), t.y(), t.z()};
}

SE3 from_pose_block(const double* block) {
  const Eigen::Map<const Eigen::Quaterniond> q(block);
  const Eigen::Map<const Eigen::Vector3d> t(block + 4);
  return SE3(Eigen::Quaterniond(q), Eigen::Vector3d(t));
}

bool Se3LeftManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Eigen::Map<const Vector6d> d(delta);
  const SE3 result = SE3::exp(d) * from_pose_block(x);
  const PoseBlock out = to_pose_block(result);
  std::copy(out.begin(), out.end(), x_plus_delta);
  return true;
}

bool Se3LeftManifold::PlusJacobian(const double* /*x*/, double* jacobian) const {
  write_padded_identity<7, 6>(jacobian);  // [I6; 0]
  return true;
}

bool Se3LeftManifold::RightMultiplyByPlusJacobian(const double* /*x*/, int num_rows,
                                                  const double* ambient_matrix,
                                                  double* tangent_matrix) const {
  // [I6; 0] on the right keeps the first 6 columns of each row.
  for (int r = 0; r < num_rows; ++r) {
    std::copy(ambient_matrix + 7 * r, ambient_matrix + 7 * r + 6, tangent_matrix + 6 * r);
  }
  return true;
}

bool Se3LeftManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Vector6d d = (from_pose_block(y) * from_pose_block(x).inverse()).log();
  std::copy(d.data(), d.data() + 6, y_minus_x);
  return true;
}

bool Se3LeftManifold::MinusJacobian(const double* /*x*/, double* jacobian) const {
  write_padded_identity<6, 7>(jacobian);  // [I6, 0]
  return true;
}

Matrix6d left_covariance_of_inverse(const SE3& T_a_b, const Matrix6d& cov_left_T_a_b) {
  const Matrix6d ad = T_a_b.inverse().adjoint();
  return ad * cov_left_T_a_b * ad.transpose();
}

}  // namespace sitepose::optim
