#include "sitepose/output/published_pose.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <numbers>

namespace sitepose::output {
namespace {
constexpr double kDegToRad = std::numbers::pi / 180.0;
}  // namespace

Expected<Eigen::Matrix3d> rotation_cam_machine(geo::ForwardAxis forward) {
  const Eigen::Vector3d x = geo::axis_vector(forward);
  const Eigen::Vector3d z = -Eigen::Vector3d::UnitY();  // machine up: the upright camera's -y
  if (std::abs(x.dot(z)) > 0.5) {
    return make_error(
        ErrorCode::kInvalidArgument,
        std::string("outputs.reference_point: geo.forward_axis ") + geo::to_string(forward) +
            " is the camera's vertical axis; the machine frame needs a horizontal forward axis");
  }
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);  // left
  R.col(2) = z;
  return R;
}

PoseEstimate reference_pose(const PoseEstimate& camera, const Eigen::Vector3d& lever_arm_cam_m) {
  PoseEstimate out = camera;
  out.T_world_cam = camera.T_world_cam * SE3(Eigen::Quaterniond::Identity(), lever_arm_cam_m);
  return out;
}

Matrix6d isotropic_point_covariance(const Eigen::Vector3d& p_world, double position_std_m,
                                    double attitude_std_rad) {
  Matrix6d D = Matrix6d::Zero();
  D.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * (position_std_m * position_std_m);
  D.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * (attitude_std_rad * attitude_std_rad);
  Matrix6d J_inverse = Matrix6d::Identity();  // [dp; dtheta] -> twist: rho = dp + hat(p) dtheta
  J_inverse.topRightCorner<3, 3>() = hat(p_world);
  const Matrix6d out = J_inverse * D * J_inverse.transpose();
  return 0.5 * (out + out.transpose());
}

DriftStd drift_std(const CovarianceOptions& covariance, double map_travel_m) {
  const double root_m = std::isfinite(map_travel_m) ? std::sqrt(std::max(map_travel_m, 0.0)) : 0.0;
  return {covariance.drift_m_per_sqrt_m * root_m, covariance.drift_deg_per_sqrt_m * kDegToRad * root_m};
}

PoseEstimate published_pose(const PoseEstimate& camera, const Eigen::Vector3d& lever_arm_cam_m,
                            const CovarianceOptions& covariance, double extra_position_std_m,
                            double extra_attitude_std_rad) {
  PoseEstimate out = reference_pose(camera, lever_arm_cam_m);
  const DriftStd drift = drift_std(covariance, camera.map_travel_m);
  const double position_std_m =
      std::hypot(covariance.floor_position_m, extra_position_std_m, drift.position_m);
  const double attitude_std_rad =
      std::hypot(covariance.floor_attitude_deg * kDegToRad, extra_attitude_std_rad, drift.attitude_rad);
  Matrix6d tracker = camera.covariance;
  if (!tracker.allFinite()) tracker.setZero();
  out.covariance = covariance.scale * tracker + isotropic_point_covariance(out.T_world_cam.translation(),
                                                                           position_std_m, attitude_std_rad);
  return out;
}

double protection_level_m(const Eigen::Matrix3d& position_covariance, double sigmas) {
  if (!position_covariance.allFinite()) return std::numeric_limits<double>::infinity();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(
      0.5 * (position_covariance + position_covariance.transpose()), Eigen::EigenvaluesOnly);
  return sigmas * std::sqrt(std::max(eig.eigenvalues().maxCoeff(), 0.0));
}

Velocity finite_difference_velocity(const Eigen::Vector3d& p0, const Eigen::Matrix3d& covariance0,
                                    std::int64_t t0_ns, const Eigen::Vector3d& p1,
                                    const Eigen::Matrix3d& covariance1, std::int64_t t1_ns) {
  Velocity v;
  if (t1_ns <= t0_ns || !p0.allFinite() || !p1.allFinite()) return v;
  const double dt_s = static_cast<double>(t1_ns - t0_ns) * 1e-9;
  v.mps = (p1 - p0) / dt_s;
  v.covariance = (covariance0 + covariance1) / (dt_s * dt_s);
  return v;
}

}  // namespace sitepose::output
