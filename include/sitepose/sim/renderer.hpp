#pragma once
// CPU rasteriser of textured planar patches (scene.hpp) for a pinhole camera.
//
// Geometry matches core's StereoCamera exactly: pixel (u, v) is the sample at
// the ray through image point (u, v) with integer u, v, so a point projecting
// to (u, v) lands in pixel (round(u), round(v)). Each patch maps to the image
// by a homography, so per pixel the renderer inverts it: (s, t) on the patch
// and 1/z come from one 3x3 product; a z-buffer keeps the nearest patch, and
// only the winner is textured (bilinear, mip level from the texel footprint).
//
// Threads: render() splits the image into row bands over OpenCV's thread
// pool; the Renderer itself holds no state, so one may be shared.

#include <opencv2/core.hpp>

#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/sim/scene.hpp"

namespace sitepose::sim {

struct RenderOptions {
  double near_m = 0.05;        // nearer surfaces are not drawn
  double far_m = 5000.0;       // farther surfaces are sky
  float sky_horizon = 215.0f;  // radiance of the sky at the horizon (0..255 scale)
  float sky_zenith = 175.0f;   // ... and straight up
};

struct RenderBuffers {
  cv::Mat radiance;  // CV_32FC1, 0..255 before exposure and noise
  cv::Mat depth_m;   // CV_32FC1, z in the camera frame; +inf where sky
  cv::Mat instance;  // CV_16UC1, SceneInstance::instance_id (0 = background)
  cv::Mat part;      // CV_8UC1, SceneInstance::part_id (0 = background or not a part)
};

class Renderer {
 public:
  explicit Renderer(const RenderOptions& options) : options_(options) {}

  // Renders `scene` seen by a pinhole camera with the intrinsics (fx, fy, cx,
  // cy, width, height) of `camera` (baseline unused) at pose T_world_cam.
  // Buffers are (re)allocated to the camera's size.
  void render(const Scene& scene, const StereoCamera& camera, const SE3& T_world_cam,
              RenderBuffers& out) const;

 private:
  RenderOptions options_;
};

}  // namespace sitepose::sim
