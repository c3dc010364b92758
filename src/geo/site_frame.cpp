#include "sitepose/geo/site_frame.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

namespace sitepose::geo {

namespace {
constexpr double kRadToDeg = 180.0 / std::numbers::pi;
// Below this horizontal fraction the forward axis points (nearly) straight
// up or down and a heading is meaningless.
constexpr double kMinHorizontalFraction = 1e-6;
}  // namespace

const char* to_string(ForwardAxis axis) {
  switch (axis) {
    case ForwardAxis::kPlusX: return "+x";
    case ForwardAxis::kMinusX: return "-x";
    case ForwardAxis::kPlusY: return "+y";
    case ForwardAxis::kMinusY: return "-y";
    case ForwardAxis::kPlusZ: return "+z";
    case ForwardAxis::kMinusZ: return "-z";
  }
  return "?";
}

Expected<ForwardAxis> parse_forward_axis(std::string_view text) {
  if (text == "+x" || text == "x") return ForwardAxis::kPlusX;
  if (text == "-x") return ForwardAxis::kMinusX;
  if (text == "+y" || text == "y") return ForwardAxis::kPlusY;
  if (text == "-y") return ForwardAxis::kMinusY;
  if (text == "+z" || text == "z") return ForwardAxis::kPlusZ;
  if (text == "-z") return ForwardAxis::kMinusZ;
  return make_error(ErrorCode::kInvalidArgument,
                    fmt::format("forward axis '{}': expected one of +x -x +y -y +z -z "
                                "(an axis of the left camera frame)",
                                text));
}

Eigen::Vector3d axis_vector(ForwardAxis axis) {
  switch (axis) {
    case ForwardAxis::kPlusX: return Eigen::Vector3d::UnitX();
    case ForwardAxis::kMinusX: return -Eigen::Vector3d::UnitX();
    case ForwardAxis::kPlusY: return Eigen::Vector3d::UnitY();
    case ForwardAxis::kMinusY: return -Eigen::Vector3d::UnitY();
    case ForwardAxis::kPlusZ: return Eigen::Vector3d::UnitZ();
    case ForwardAxis::kMinusZ: return -Eigen::Vector3d::UnitZ();
  }
  return Eigen::Vector3d::UnitX();
}

double heading_deg_of(const Eigen::Vector3d& direction_site) {
  const double horizontal = std::hypot(direction_site.x(), direction_site.y());
  if (!(horizontal > kMinHorizontalFraction * direction_site.norm())) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  // atan2(East, North): 0 = north, 90 = east (clockwise seen from above).
  double heading = std::atan2(direction_site.x(), direction_site.y()) * kRadToDeg;
  if (heading < 0.0) heading += 360.0;
  if (heading >= 360.0) heading -= 360.0;
  return heading;
}

Matrix6d site_covariance(const SE3& T_site_slam, const SE3& T_slam_cam,
                         const Matrix6d& covariance_slam) {
  // Left twist -> [dp; dtheta]: p' = exp(omega) p + rho ~ p + rho - hat(p) omega.
  Matrix6d J = Matrix6d::Identity();
  J.block<3, 3>(0, 3) = -hat(T_slam_cam.translation());
  Matrix6d B = Matrix6d::Zero();
  const Eigen::Matrix3d R = T_site_slam.rotation_matrix();
  B.block<3, 3>(0, 0) = R;
  B.block<3, 3>(3, 3) = R;
  const Matrix6d A = B * J;
  Matrix6d out = A * covariance_slam * A.transpose();
  return 0.5 * (out + out.transpose());  // keep it exactly symmetric
}

Expected<SiteFrame> SiteFrame::create(const Geodetic& origin, const SE3& T_site_slam,
                                      ForwardAxis forward_axis_cam) {
  SITEPOSE_TRY(LocalEnu enu, LocalEnu::create(origin));
  if (!T_site_slam.translation().allFinite() || !T_site_slam.rotation().coeffs().allFinite()) {
    return make_error(ErrorCode::kInvalidArgument, "T_site_slam: not finite");
  }
  return SiteFrame(std::move(enu), T_site_slam, forward_axis_cam);
}

Expected<SitePose> SiteFrame::to_site(std::int64_t t_ns, const SE3& T_slam_cam,
                                      const Matrix6d& covariance_slam) const {
  if (!T_slam_cam.translation().allFinite() || !T_slam_cam.rotation().coeffs().allFinite()) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("pose at t_ns {}: T_slam_cam is not finite", t_ns));
  }
  SitePose out;
  out.t_ns = t_ns;
  out.T_site_cam = T_site_slam_ * T_slam_cam;
  out.covariance_site = site_covariance(T_site_slam_, T_slam_cam, covariance_slam);
  out.geodetic = enu_.to_geodetic(out.T_site_cam.translation());
  SITEPOSE_TRY(out.utm, to_utm(out.geodetic));

  const Eigen::Vector3d forward_site = out.T_site_cam.rotation() * axis_vector(forward_axis_cam_);
  out.heading_deg = heading_deg_of(forward_site);
  if (std::isnan(out.heading_deg)) {
    out.heading_std_deg = std::numeric_limits<double>::quiet_NaN();
  } else {
    // d(forward) = dtheta x forward = -hat(forward) dtheta;
    // heading = atan2(e, n): d heading / d(e, n, u) = [n, -e, 0] / (e^2 + n^2).
    const double e = forward_site.x();
    const double n = forward_site.y();
    const Eigen::RowVector3d d_heading_d_forward(n / (e * e + n * n), -e / (e * e + n * n), 0.0);
    const Eigen::RowVector3d d_heading_d_theta = d_heading_d_forward * (-hat(forward_site));
    const double variance_rad2 =
        d_heading_d_theta * out.covariance_site.block<3, 3>(3, 3) * d_heading_d_theta.transpose();
    out.heading_std_deg = std::sqrt(std::max(variance_rad2, 0.0)) * kRadToDeg;
  }
  out.position_std_m = std::sqrt(std::max(out.covariance_site.block<3, 3>(0, 0).trace(), 0.0));
  return out;
}

}  // namespace sitepose::geo
