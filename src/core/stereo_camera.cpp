#include "sitepose/core/stereo_camera.hpp"

#include <cmath>
#include <sstream>

namespace sitepose {

Status StereoCamera::validate() const {
  std::ostringstream why;
  if (!(fx > 0.0) || !(fy > 0.0)) why << "focal lengths must be > 0 (fx=" << fx << ", fy=" << fy << "); ";
  if (!(baseline_m > 0.0)) why << "baseline_m must be > 0 (got " << baseline_m << "); ";
  if (width <= 0 || height <= 0) why << "image size must be > 0 (got " << width << "x" << height << "); ";
  if (width > 0 && !(cx >= 0.0 && cx < width)) why << "cx=" << cx << " outside the image width " << width << "; ";
  if (height > 0 && !(cy >= 0.0 && cy < height)) why << "cy=" << cy << " outside the image height " << height << "; ";
  const std::string msg = why.str();
  if (!msg.empty()) return make_error(ErrorCode::kInvalidArgument, "invalid stereo camera: " + msg.substr(0, msg.size() - 2));
  return ok_status();
}

std::optional<Eigen::Vector3d> StereoCamera::triangulate(const Eigen::Vector2d& uv_left_px,
                                                         double u_right_px) const {
  const double disparity_px = uv_left_px.x() - u_right_px;
  if (!(disparity_px > 0.0)) return std::nullopt;
  return unproject(uv_left_px, depth_from_disparity(disparity_px));
}

}  // namespace sitepose
