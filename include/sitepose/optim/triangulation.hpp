#pragma once
// Triangulation helpers for the local mapper (new map points from two
// keyframes) and the dynamic layer (stereo points with covariance for the
// Mahalanobis motion test, METHOD.md "Depth-aware threshold").
//
// Frames: T_cam_world maps world points into a camera (left camera of the
// rectified pair); rays are in the camera frame with z > 0 and need not be
// normalised (normalised_ray() gives (x/z, y/z, 1)).
// Units: metres, pixels; covariances in m^2 / px^2. Pure functions.

#include <optional>

#include <Eigen/Core>

#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::optim {

// ORB-SLAM2 LocalMapping::CreateNewMapPoints triangulates two views only when
// the rays' parallax cosine is below 0.9998 (about 1.15 degrees).
inline constexpr double kOrbSlamMaxCosParallax = 0.9998;

// (x/z, y/z, 1) of the left-image pixel: the ray of pixel uv in the camera frame.
Eigen::Vector3d normalised_ray(const StereoCamera& camera, const Eigen::Vector2d& uv_px);

enum class TriangulationStatus {
  kOk,
  kLowParallax,   // cos(parallax) >= max_cos_parallax: depth is unobservable
  kNotInFront,    // the point is not in front of both cameras
  kDegenerate,    // a ray with z <= 0 or a rank-deficient system
};

const char* to_string(TriangulationStatus status);

struct TwoViewTriangulation {
  TriangulationStatus status = TriangulationStatus::kDegenerate;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  // valid when status == kOk
  double cos_parallax = 1.0;  // cosine of the angle between the two rays in the world frame
};

// Linear (DLT) two-view triangulation: the homogeneous point minimising the
// algebraic error of x_i * P_i.row(2) - P_i.row(0) = 0 (and y), with
// P_i = [R | t] of T_cam_i_world and x_i, y_i the normalised ray coordinates.
// The parallax test runs first; p_world is filled only for kOk.
TwoViewTriangulation triangulate_two_view(const SE3& T_cam1_world, const Eigen::Vector3d& ray1_cam1,
                                          const SE3& T_cam2_world, const Eigen::Vector3d& ray2_cam2,
                                          double max_cos_parallax = kOrbSlamMaxCosParallax);

struct PointWithCovariance {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  // m, in the frame the function names
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // m^2, same frame
};

// Stereo back-projection of (u_l, v_l, u_r) into the left camera frame:
//   Z = fx b / d, X = (u_l - cx) Z / fx, Y = (v_l - cy) Z / fy, d = u_l - u_r,
// with covariance J * pixel_covariance * J^T, J = d(X, Y, Z)/d(u_l, v_l, u_r)
// (first-order propagation; the true depth distribution is skewed when d is
// a few sigma). pixel_covariance_px2 is the 3x3 covariance of (u_l, v_l, u_r).
// nullopt when the disparity is not positive.
std::optional<PointWithCovariance> stereo_point_in_camera(const StereoCamera& camera,
                                                          const Eigen::Vector2d& uv_left_px,
                                                          double u_right_px,
                                                          const Eigen::Matrix3d& pixel_covariance_px2);

// Independent pixel noise of one keypoint: diag(sigma_u^2, sigma_v^2, sigma_ur^2).
Eigen::Matrix3d stereo_pixel_covariance(double sigma_u_left_px, double sigma_v_left_px,
                                        double sigma_u_right_px);

// The camera-frame point in the world frame, p_world = T_world_cam * p_cam,
// with covariance R cov R^T, plus, when pose_covariance_world_cam is given
// (left perturbation [translation; rotation] of T_world_cam, as in
// core/pose_estimate.hpp), the pose term A Sigma A^T with
// A = d p_world / d eps = [I, -hat(p_world)]. Pose and pixel noise are
// treated as independent.
PointWithCovariance point_to_world(const PointWithCovariance& point_cam, const SE3& T_world_cam,
                                   const Matrix6d* pose_covariance_world_cam = nullptr);

}  // namespace sitepose::optim
