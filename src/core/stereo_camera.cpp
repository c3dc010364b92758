#include "sitepose/core/stereo_camera.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace sitepose {

Status StereoCamera::validate() const {
  std::ostringstream why;
  if (!(fx > 0.0) || !(fy > 0.0)) why << "focal lengths must be > 0 (fx=" << fx << ", fy=" << fy << "); ";
  if (!(baseline_m > 0.0)) {
    why << "baseline_m must be > 0 (got " << baseline_m << "); ";
  } else if (!(baseline_m >= kMinBaselineM && baseline_m <= kMaxBaselineM)) {
    why << "baseline_m=" << baseline_m << " implausible: expected " << kMinBaselineM << ".." << kMaxBaselineM << " m; ";
  }
  if (width <= 0 || height <= 0) why << "image size must be > 0 (got " << width << "x" << height << "); ";
  if (fx > 0.0 && fy > 0.0 && width > 0 && height > 0) {
    const double side_px = std::max(width, height);
    const double lo = kMinFocalPerSide * side_px, hi = kMaxFocalPerSide * side_px;
    if (!(fx >= lo && fx <= hi) || !(fy >= lo && fy <= hi)) {
      why << "fx=" << fx << ", fy=" << fy << " implausible for a " << width << "x" << height << " image: expected "
          << lo << ".." << hi << " px (" << kMinFocalPerSide << ".." << kMaxFocalPerSide << " x the longer side); ";
    }
  }
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
