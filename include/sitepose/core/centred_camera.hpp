#pragma once
// A rectified rig with square pixels and the principal point at the image
// centre, as the simulator makes them: nominal cameras (a daemon check
// without a camera source), synthetic maps, tests.

#include "sitepose/core/stereo_camera.hpp"

namespace sitepose {

inline StereoCamera centred_camera(int width, int height, double f_px, double baseline_m) {
  StereoCamera camera;
  camera.fx = f_px;
  camera.fy = f_px;
  camera.cx = width / 2.0;
  camera.cy = height / 2.0;
  camera.baseline_m = baseline_m;
  camera.width = width;
  camera.height = height;
  return camera;
}

}  // namespace sitepose
