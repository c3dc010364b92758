#include "sitepose/optim/triangulation.hpp"

#include <Eigen/SVD>

#include "sitepose/core/enum_names.hpp"

namespace sitepose::optim {

Eigen::Vector3d normalised_ray(const StereoCamera& camera, const Eigen::Vector2d& uv_px) {
  return {(uv_px.x() - camera.cx) / camera.fx, (uv_px.y() - camera.cy) / camera.fy, 1.0};
}

constexpr auto kTriangulationStatusNames =
    enum_names<TriangulationStatus>({{TriangulationStatus::kOk, "ok"},
                                     {TriangulationStatus::kLowParallax, "low parallax"},
                                     {TriangulationStatus::kNotInFront, "not in front of both cameras"},
                                     {TriangulationStatus::kDegenerate, "degenerate"}},
                                    "unknown");

const char* to_string(TriangulationStatus status) { return kTriangulationStatusNames.name(status); }

TwoViewTriangulation triangulate_two_view(const SE3& T_cam1_world, const Eigen::Vector3d& ray1_cam1,
                                          const SE3& T_cam2_world, const Eigen::Vector3d& ray2_cam2,
                                          double max_cos_parallax) {
  TwoViewTriangulation out;
  if (!(ray1_cam1.z() > 0.0) || !(ray2_cam2.z() > 0.0)) return out;  // kDegenerate
  const Eigen::Matrix3d R1 = T_cam1_world.rotation_matrix();
  const Eigen::Matrix3d R2 = T_cam2_world.rotation_matrix();
  // Rays in the world frame: R_world_cam * ray = R_cam_world^T * ray.
  const Eigen::Vector3d d1 = R1.transpose() * ray1_cam1;
  const Eigen::Vector3d d2 = R2.transpose() * ray2_cam2;
  out.cos_parallax = d1.dot(d2) / (d1.norm() * d2.norm());
  if (out.cos_parallax >= max_cos_parallax) {
    out.status = TriangulationStatus::kLowParallax;
    return out;
  }
  const Eigen::Matrix<double, 3, 4> P1 = T_cam1_world.matrix3x4();
  const Eigen::Matrix<double, 3, 4> P2 = T_cam2_world.matrix3x4();
  const double x1 = ray1_cam1.x() / ray1_cam1.z();
  const double y1 = ray1_cam1.y() / ray1_cam1.z();
  const double x2 = ray2_cam2.x() / ray2_cam2.z();
  const double y2 = ray2_cam2.y() / ray2_cam2.z();
  Eigen::Matrix4d A;
  A.row(0) = x1 * P1.row(2) - P1.row(0);
  A.row(1) = y1 * P1.row(2) - P1.row(1);
  A.row(2) = x2 * P2.row(2) - P2.row(0);
  A.row(3) = y2 * P2.row(2) - P2.row(1);
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  if (std::abs(h(3)) < 1e-12 * h.head<3>().norm() || h(3) == 0.0) {
    out.status = TriangulationStatus::kDegenerate;  // point at infinity
    return out;
  }
  const Eigen::Vector3d p_world = h.head<3>() / h(3);
  if (!((T_cam1_world * p_world).z() > 0.0) || !((T_cam2_world * p_world).z() > 0.0)) {
    out.status = TriangulationStatus::kNotInFront;
    return out;
  }
  out.p_world = p_world;
  out.status = TriangulationStatus::kOk;
  return out;
}

std::optional<PointWithCovariance> stereo_point_in_camera(const StereoCamera& camera,
                                                          const Eigen::Vector2d& uv_left_px,
                                                          double u_right_px,
                                                          const Eigen::Matrix3d& pixel_covariance_px2) {
  const double d = uv_left_px.x() - u_right_px;
  if (!(d > 0.0)) return std::nullopt;
  const double b = camera.baseline_m;
  const double du = uv_left_px.x() - camera.cx;
  const double dv = uv_left_px.y() - camera.cy;
  const double z = camera.bf() / d;
  PointWithCovariance out;
  out.p = {du * z / camera.fx, dv * z / camera.fy, z};
  // X = b du / d, Y = (fx / fy) b dv / d, Z = fx b / d; d(d)/du_l = 1, d(d)/du_r = -1.
  const double inv_d = 1.0 / d;
  const double inv_d2 = inv_d * inv_d;
  const double k_y = camera.fx / camera.fy;
  Eigen::Matrix3d J;
  J << b * inv_d - b * du * inv_d2, 0.0, b * du * inv_d2,              //
      -k_y * b * dv * inv_d2, k_y * b * inv_d, k_y * b * dv * inv_d2,  //
      -camera.bf() * inv_d2, 0.0, camera.bf() * inv_d2;
  out.covariance = J * pixel_covariance_px2 * J.transpose();
  return out;
}

Eigen::Matrix3d stereo_pixel_covariance(double sigma_u_left_px, double sigma_v_left_px,
                                        double sigma_u_right_px) {
  return Eigen::Vector3d(sigma_u_left_px * sigma_u_left_px, sigma_v_left_px * sigma_v_left_px,
                         sigma_u_right_px * sigma_u_right_px)
      .asDiagonal();
}

PointWithCovariance point_to_world(const PointWithCovariance& point_cam, const SE3& T_world_cam,
                                   const Matrix6d* pose_covariance_world_cam) {
  PointWithCovariance out;
  const Eigen::Matrix3d R = T_world_cam.rotation_matrix();
  out.p = T_world_cam * point_cam.p;
  out.covariance = R * point_cam.covariance * R.transpose();
  if (pose_covariance_world_cam != nullptr) {
    // exp(eps) * p_world ~ p_world + eps_t + eps_r x p_world.
    Eigen::Matrix<double, 3, 6> A;
    A.leftCols<3>().setIdentity();
    A.rightCols<3>() = -hat(out.p);
    out.covariance += A * (*pose_covariance_world_cam) * A.transpose();
  }
  return out;
}

}  // namespace sitepose::optim
