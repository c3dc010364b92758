#pragma once
// Rectified pinhole stereo pair (left camera is the reference frame).
// Camera axes: x right, y down, z forward; the right camera sits at
// x = +baseline_m in the left camera frame. Pixel units: _px.

#include <Eigen/Core>
#include <optional>
#include <string>

#include "sitepose/core/expected.hpp"

namespace sitepose {

struct StereoCamera {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  double baseline_m = 0.0;
  int width = 0;
  int height = 0;

  // Plausible rigs (a focal length far outside these is a broken
  // calibration, not a lens): the field of view across the longer image
  // side between about 1 and 170 degrees, a baseline of 1 cm to 10 m.
  static constexpr double kMinFocalPerSide = 0.05;
  static constexpr double kMaxFocalPerSide = 50.0;
  static constexpr double kMinBaselineM = 0.01;
  static constexpr double kMaxBaselineM = 10.0;

  // Checks positivity, the plausible ranges above and the principal point
  // inside the image; the message names each bad value.
  Status validate() const;

  // fx * baseline: disparity_px = bf / depth_m.
  double bf() const { return fx * baseline_m; }

  // Left image pixel of a point in the left camera frame (z must be > 0).
  Eigen::Vector2d project(const Eigen::Vector3d& p_cam) const {
    return {fx * p_cam.x() / p_cam.z() + cx, fy * p_cam.y() / p_cam.z() + cy};
  }
  // Right image column u_r = fx (X - b) / Z + cx (METHOD.md, stereo residual).
  double project_right_u(const Eigen::Vector3d& p_cam) const {
    return fx * (p_cam.x() - baseline_m) / p_cam.z() + cx;
  }
  // (u_l, v_l, u_r) of a point.
  Eigen::Vector3d project_stereo(const Eigen::Vector3d& p_cam) const {
    const Eigen::Vector2d uv = project(p_cam);
    return {uv.x(), uv.y(), project_right_u(p_cam)};
  }
  // Point in the left camera frame at depth_m along the ray through pixel uv.
  Eigen::Vector3d unproject(const Eigen::Vector2d& uv_px, double depth_m) const {
    return {(uv_px.x() - cx) / fx * depth_m, (uv_px.y() - cy) / fy * depth_m, depth_m};
  }
  double depth_from_disparity(double disparity_px) const { return bf() / disparity_px; }
  double disparity_from_depth(double depth_m) const { return bf() / depth_m; }
  // Triangulate from a left pixel and the right column of its match;
  // nullopt when the disparity is not positive.
  std::optional<Eigen::Vector3d> triangulate(const Eigen::Vector2d& uv_left_px,
                                             double u_right_px) const;

  bool in_image(const Eigen::Vector2d& uv_px, double border_px = 0.0) const {
    return uv_px.x() >= border_px && uv_px.y() >= border_px &&
           uv_px.x() < width - border_px && uv_px.y() < height - border_px;
  }
};

}  // namespace sitepose
