#include "sitepose/optim/reprojection_costs.hpp"

#include <cmath>

#include "sitepose/core/se3.hpp"

namespace sitepose::optim {
namespace {

template <int kDim>
using PoseJacobianMap = Eigen::Map<Eigen::Matrix<double, kDim, 7, Eigen::RowMajor>>;
template <int kDim>
using PointJacobianMap = Eigen::Map<Eigen::Matrix<double, kDim, 3, Eigen::RowMajor>>;

// Lifted pose Jacobian: d p_cam / d delta = [I, -hat(p_cam)] for the left
// perturbation exp(delta) * T_cam_world (pose_parameterization.hpp).
template <int kDim>
void write_pose_jacobian(const Eigen::Matrix<double, kDim, 3>& d_r_d_p_cam,
                         const Eigen::Vector3d& p_cam, double* out) {
  PoseJacobianMap<kDim> J(out);
  J.template leftCols<3>() = d_r_d_p_cam;
  J.template middleCols<3>(3) = -d_r_d_p_cam * hat(p_cam);
  J.col(6).setZero();
}

}  // namespace

double level_sigma2_px2(double scale_factor, int level) {
  return std::pow(scale_factor, 2.0 * level);
}

template <int kDim>
bool whitened_reprojection(const StereoCamera& camera, const Eigen::Vector3d& p_cam,
                           const Eigen::Matrix<double, kDim, 1>& observed_px, double sqrt_information,
                           Eigen::Matrix<double, kDim, 1>* residual,
                           Eigen::Matrix<double, kDim, 3>* d_r_d_p_cam) {
  static_assert(kDim == 2 || kDim == 3);
  const double z = p_cam.z();
  if (!(z > kMinDepthM)) return false;
  const double inv_z = 1.0 / z;
  const double x_n = p_cam.x() * inv_z;
  const double y_n = p_cam.y() * inv_z;
  Eigen::Matrix<double, kDim, 1> predicted;
  predicted(0) = camera.fx * x_n + camera.cx;
  predicted(1) = camera.fy * y_n + camera.cy;
  if constexpr (kDim == 3) {
    predicted(2) = predicted(0) - camera.fx * camera.baseline_m * inv_z;
  }
  if (residual != nullptr) *residual = sqrt_information * (observed_px - predicted);
  if (d_r_d_p_cam != nullptr) {
    // r = s (z - pi): d r / d p_cam = -s d pi / d p_cam.
    const double a = -sqrt_information * inv_z;
    Eigen::Matrix<double, kDim, 3>& J = *d_r_d_p_cam;
    J(0, 0) = a * camera.fx;
    J(0, 1) = 0.0;
    J(0, 2) = -a * camera.fx * x_n;
    J(1, 0) = 0.0;
    J(1, 1) = a * camera.fy;
    J(1, 2) = -a * camera.fy * y_n;
    if constexpr (kDim == 3) {
      J(2, 0) = a * camera.fx;
      J(2, 1) = 0.0;
      J(2, 2) = -a * camera.fx * (p_cam.x() - camera.baseline_m) * inv_z;
    }
  }
  return true;
}

template bool whitened_reprojection<2>(const StereoCamera&, const Eigen::Vector3d&,
                                       const Eigen::Matrix<double, 2, 1>&, double,
                                       Eigen::Matrix<double, 2, 1>*, Eigen::Matrix<double, 2, 3>*);
template bool whitened_reprojection<3>(const StereoCamera&, const Eigen::Vector3d&,
                                       const Eigen::Matrix<double, 3, 1>&, double,
                                       Eigen::Matrix<double, 3, 1>*, Eigen::Matrix<double, 3, 3>*);

template <int kDim>
PoseOnlyReprojectionCost<kDim>::PoseOnlyReprojectionCost(const StereoCamera& camera,
                                                         const Eigen::Vector3d& p_world,
                                                         const Eigen::Matrix<double, kDim, 1>& observed_px,
                                                         double sigma2_px2)
    : camera_(camera),
      p_world_(p_world),
      observed_px_(observed_px),
      sqrt_information_(1.0 / std::sqrt(sigma2_px2)) {}

template <int kDim>
bool PoseOnlyReprojectionCost<kDim>::Evaluate(double const* const* parameters, double* residuals,
                                              double** jacobians) const {
  const Eigen::Map<const Eigen::Quaterniond> q(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> t(parameters[0] + 4);
  const Eigen::Vector3d p_cam = q * p_world_ + t;
  Eigen::Matrix<double, kDim, 1> r;
  Eigen::Matrix<double, kDim, 3> d_r_d_p_cam;
  const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
  if (!whitened_reprojection<kDim>(camera_, p_cam, observed_px_, sqrt_information_, &r,
                                   want_jacobian ? &d_r_d_p_cam : nullptr)) {
    return false;
  }
  Eigen::Map<Eigen::Matrix<double, kDim, 1>> residual_out(residuals);
  residual_out = r;
  if (want_jacobian) write_pose_jacobian<kDim>(d_r_d_p_cam, p_cam, jacobians[0]);
  return true;
}

template <int kDim>
ReprojectionCost<kDim>::ReprojectionCost(const StereoCamera& camera,
                                         const Eigen::Matrix<double, kDim, 1>& observed_px,
                                         double sigma2_px2)
    : camera_(camera), observed_px_(observed_px), sqrt_information_(1.0 / std::sqrt(sigma2_px2)) {}

template <int kDim>
bool ReprojectionCost<kDim>::Evaluate(double const* const* parameters, double* residuals,
                                      double** jacobians) const {
  const Eigen::Map<const Eigen::Quaterniond> q(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> t(parameters[0] + 4);
  const Eigen::Map<const Eigen::Vector3d> p_world(parameters[1]);
  const Eigen::Vector3d p_cam = q * p_world + t;
  const bool want_pose = jacobians != nullptr && jacobians[0] != nullptr;
  const bool want_point = jacobians != nullptr && jacobians[1] != nullptr;
  Eigen::Matrix<double, kDim, 1> r;
  Eigen::Matrix<double, kDim, 3> d_r_d_p_cam;
  if (!whitened_reprojection<kDim>(camera_, p_cam, observed_px_, sqrt_information_, &r,
                                   (want_pose || want_point) ? &d_r_d_p_cam : nullptr)) {
    return false;
  }
  Eigen::Map<Eigen::Matrix<double, kDim, 1>> residual_out(residuals);
  residual_out = r;
  if (want_pose) write_pose_jacobian<kDim>(d_r_d_p_cam, p_cam, jacobians[0]);
  if (want_point) {
    // d p_cam / d p_world = R_cam_world.
    PointJacobianMap<kDim> J_point(jacobians[1]);
    J_point = d_r_d_p_cam * q.toRotationMatrix();
  }
  return true;
}

template class PoseOnlyReprojectionCost<2>;
template class PoseOnlyReprojectionCost<3>;
template class ReprojectionCost<2>;
template class ReprojectionCost<3>;

}  // namespace sitepose::optim
