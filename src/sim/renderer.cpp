#include "sitepose/sim/renderer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <vector>

namespace sitepose::sim {
namespace {

// A patch after placing it in front of the camera.
struct Prepared {
  double m[9];         // (s*w, t*w, w) = m * (u, v, 1), w = 1 / z
  int u0, u1, v0, v1;  // inclusive pixel bounds
  Shape shape;
  const Patch* patch;
  std::uint16_t instance;
  std::uint8_t part;
};

bool inside(Shape shape, double s, double t) {
  switch (shape) {
    case Shape::kRectangle: return s >= 0.0 && s <= 1.0 && t >= 0.0 && t <= 1.0;
    case Shape::kTriangle: return s >= 0.0 && t >= 0.0 && s + t <= 1.0;
    case Shape::kEllipse: return s * s + t * t <= 1.0;
  }
  return false;
}

// Pixel bounds of the patch outline clipped to z >= near; false if nothing
// of it is in front of the camera or inside the image.
bool pixel_bounds(const std::vector<Eigen::Vector3d>& corners_cam, const StereoCamera& cam, double near_m,
                  Prepared& p) {
  double umin = std::numeric_limits<double>::infinity(), vmin = umin;
  double umax = -umin, vmax = -umin;
  bool any = false;
  auto add = [&](const Eigen::Vector3d& q) {
    const double u = cam.fx * q.x() / q.z() + cam.cx;
    const double v = cam.fy * q.y() / q.z() + cam.cy;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
    any = true;
  };
  const size_t n = corners_cam.size();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& a = corners_cam[i];
    const Eigen::Vector3d& b = corners_cam[(i + 1) % n];
    const bool a_in = a.z() >= near_m;
    const bool b_in = b.z() >= near_m;
    if (a_in) add(a);
    if (a_in != b_in) add(a + (b - a) * ((near_m - a.z()) / (b.z() - a.z())));
  }
  if (!any) return false;
  p.u0 = static_cast<int>(std::max(0.0, std::floor(umin) - 1.0));
  p.v0 = static_cast<int>(std::max(0.0, std::floor(vmin) - 1.0));
  p.u1 = static_cast<int>(std::min(static_cast<double>(cam.width - 1), std::ceil(umax) + 1.0));
  p.v1 = static_cast<int>(std::min(static_cast<double>(cam.height - 1), std::ceil(vmax) + 1.0));
  return p.u0 <= p.u1 && p.v0 <= p.v1;
}

std::vector<Prepared> prepare(const Scene& scene, const StereoCamera& cam, const SE3& T_world_cam,
                              double near_m) {
  std::vector<Prepared> out;
  const SE3 T_cam_world = T_world_cam.inverse();
  Eigen::Matrix3d K;
  K << cam.fx, 0.0, cam.cx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 1.0;
  std::vector<Eigen::Vector3d> corners;
  for (const SceneInstance& inst : scene.instances) {
    if (!inst.mesh) continue;
    const SE3 T_cam_obj = T_cam_world * inst.T_world_obj;
    const Eigen::Matrix3d R = T_cam_obj.rotation_matrix();
    for (const Patch& patch : inst.mesh->patches) {
      const Eigen::Vector3d o = T_cam_obj * patch.origin;
      const Eigen::Vector3d u = R * patch.axis_u;
      const Eigen::Vector3d v = R * patch.axis_v;
      const Eigen::Vector3d n = u.cross(v);
      const double facing = -n.dot(o);  // > 0: the front side faces the camera
      if (!patch.two_sided && facing <= 0.0) continue;
      if (std::abs(facing) < 1e-12 * n.norm()) continue;  // edge-on
      Eigen::Matrix3d M;
      M.col(0) = K * u;
      M.col(1) = K * v;
      M.col(2) = K * o;
      const double det = M.determinant();
      if (!(std::abs(det) > 1e-12)) continue;
      corners.clear();
      switch (patch.shape) {
        case Shape::kRectangle: corners = {o, o + u, o + u + v, o + v}; break;
        case Shape::kTriangle: corners = {o, o + u, o + v}; break;
        case Shape::kEllipse: corners = {o - u - v, o + u - v, o + u + v, o - u + v}; break;
      }
      Prepared p{};
      if (!pixel_bounds(corners, cam, near_m, p)) continue;
      const Eigen::Matrix3d Minv = M.inverse();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) p.m[r * 3 + c] = Minv(r, c);
      p.shape = patch.shape;
      p.patch = &patch;
      p.instance = inst.instance_id;
      p.part = inst.part_id;
      out.push_back(p);
    }
  }
  return out;
}

// Mip level whose texels are about one pixel wide: the larger of the two
// pixel-step footprints (in level-0 texels) decides, which blurs grazing
// ground a little rather than letting it alias from frame to frame.
int mip_level(double du_x, double du_y, double dv_x, double dv_y) {
  const double fp2 = std::max(du_x * du_x + du_y * du_y, dv_x * dv_x + dv_y * dv_y);
  if (!(fp2 >= 4.0)) return 0;
  return std::ilogb(fp2) / 2;
}

// Visibility for the rows [r0, r1): the nearest patch per pixel (its index
// in prims, -1 for none) by inverse depth w within [w_min, w_max].
void nearest_patches(const std::vector<Prepared>& prims, int r0, int r1, int width, double w_min,
                     double w_max, std::vector<int>& idbuf) {
  std::vector<double> wbuf(idbuf.size(), 0.0);
  for (size_t k = 0; k < prims.size(); ++k) {
    const Prepared& p = prims[k];
    const int va = std::max(p.v0, r0);
    const int vb = std::min(p.v1, r1 - 1);
    for (int v = va; v <= vb; ++v) {
      double* wrow = wbuf.data() + static_cast<size_t>(v - r0) * width;
      int* idrow = idbuf.data() + static_cast<size_t>(v - r0) * width;
      const double bs = p.m[1] * v + p.m[2];
      const double bt = p.m[4] * v + p.m[5];
      const double bw = p.m[7] * v + p.m[8];
      for (int u = p.u0; u <= p.u1; ++u) {
        const double w = p.m[6] * u + bw;
        if (w <= wrow[u] || w < w_min || w > w_max) continue;
        const double inv = 1.0 / w;
        const double s = (p.m[0] * u + bs) * inv;
        const double t = (p.m[3] * u + bt) * inv;
        if (!inside(p.shape, s, t)) continue;
        wrow[u] = w;
        idrow[u] = static_cast<int>(k);
      }
    }
  }
}

// Radiance of pixel (u, v) on patch p (texture at the homography's mip
// level, times the overlay and the shade); `depth_m` is set to its depth.
float shade_pixel(const Prepared& p, int u, int v, float& depth_m) {
  const Patch& patch = *p.patch;
  const double w = p.m[6] * u + p.m[7] * v + p.m[8];
  const double inv = 1.0 / w;
  const double s = (p.m[0] * u + p.m[1] * v + p.m[2]) * inv;
  const double t = (p.m[3] * u + p.m[4] * v + p.m[5]) * inv;
  // d(s,t)/du and d(s,t)/dv of the homography, for the mip level.
  const double ds_du = (p.m[0] - s * p.m[6]) * inv;
  const double dt_du = (p.m[3] - t * p.m[6]) * inv;
  const double ds_dv = (p.m[1] - s * p.m[7]) * inv;
  const double dt_dv = (p.m[4] - t * p.m[7]) * inv;
  const int level =
      mip_level(ds_du * patch.tex_du, dt_du * patch.tex_dv, ds_dv * patch.tex_du, dt_dv * patch.tex_dv);
  float value =
      patch.texture->sample(patch.tex_x0 + s * patch.tex_du, patch.tex_y0 + t * patch.tex_dv, level);
  if (patch.overlay) {
    const int olevel = mip_level(ds_du * patch.overlay_du, dt_du * patch.overlay_dv, ds_dv * patch.overlay_du,
                                 dt_dv * patch.overlay_dv);
    value *= patch.overlay->sample(patch.overlay_x0 + s * patch.overlay_du,
                                   patch.overlay_y0 + t * patch.overlay_dv, olevel) *
             (1.0f / 128.0f);
  }
  depth_m = static_cast<float>(inv);
  return value * patch.shade;
}

}  // namespace

void Renderer::render(const Scene& scene, const StereoCamera& cam, const SE3& T_world_cam,
                      RenderBuffers& out) const {
  out.radiance.create(cam.height, cam.width, CV_32FC1);
  out.depth_m.create(cam.height, cam.width, CV_32FC1);
  out.instance.create(cam.height, cam.width, CV_16UC1);
  out.part.create(cam.height, cam.width, CV_8UC1);
  const std::vector<Prepared> prims = prepare(scene, cam, T_world_cam, options_.near_m);
  const double w_min = 1.0 / options_.far_m;
  const double w_max = 1.0 / options_.near_m;
  const Eigen::Matrix3d R_wc = T_world_cam.rotation_matrix();
  const RenderOptions opt = options_;

  const int bands = std::max(1, std::min(cam.height, 32));
  cv::parallel_for_(
      cv::Range(0, bands),
      [&](const cv::Range& range) {
        const int r0 = range.start * cam.height / bands;
        const int r1 = range.end * cam.height / bands;
        const int n = (r1 - r0) * cam.width;
        std::vector<int> idbuf(static_cast<size_t>(n), -1);
        nearest_patches(prims, r0, r1, cam.width, w_min, w_max, idbuf);
        // Shading: texture only the winners.
        for (int v = r0; v < r1; ++v) {
          float* rad = out.radiance.ptr<float>(v);
          float* dep = out.depth_m.ptr<float>(v);
          std::uint16_t* ins = out.instance.ptr<std::uint16_t>(v);
          std::uint8_t* part = out.part.ptr<std::uint8_t>(v);
          const int* idrow = idbuf.data() + static_cast<size_t>(v - r0) * cam.width;
          for (int u = 0; u < cam.width; ++u) {
            const int id = idrow[u];
            if (id < 0) {
              const Eigen::Vector3d d =
                  R_wc * Eigen::Vector3d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
              const double elevation = std::clamp(d.z() / d.norm() * 2.5, 0.0, 1.0);
              rad[u] = static_cast<float>(opt.sky_horizon + (opt.sky_zenith - opt.sky_horizon) * elevation);
              dep[u] = std::numeric_limits<float>::infinity();
              ins[u] = 0;
              part[u] = 0;
              continue;
            }
            const Prepared& p = prims[static_cast<size_t>(id)];
            rad[u] = shade_pixel(p, u, v, dep[u]);
            ins[u] = p.instance;
            part[u] = p.part;
          }
        }
      },
      bands);
}

}  // namespace sitepose::sim
