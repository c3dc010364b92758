#pragma once
// What the renderer draws: planar textured patches grouped into meshes,
// placed in the world. Frames: a mesh's patches live in its own frame
// ("obj"); a SceneInstance places it with T_world_obj. World frame of the
// simulator: the ground-fixed site frame, x along the ego roller's lane,
// y to its left, z up, ground plane z = 0 (metres).

#include <cstdint>
#include <memory>
#include <vector>

#include "sitepose/core/se3.hpp"
#include "sitepose/sim/texture.hpp"

namespace sitepose::sim {

// Domain of the patch parameters (s, t): p = origin + s * axis_u + t * axis_v.
enum class Shape {
  kRectangle,  // 0 <= s, t <= 1
  kTriangle,   // s, t >= 0, s + t <= 1
  kEllipse,    // s^2 + t^2 <= 1 (origin is the centre)
};

struct Patch {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // m, mesh frame
  Eigen::Vector3d axis_u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d axis_v = Eigen::Vector3d::UnitY();
  Shape shape = Shape::kRectangle;
  // One-sided patches are seen only from the side of axis_u x axis_v
  // (outward faces of closed boxes); two-sided ones from both.
  bool two_sided = false;
  TexturePtr texture;  // required
  // Level-0 texture coordinates: x = tex_x0 + s * tex_du, y = tex_y0 + t * tex_dv.
  double tex_x0 = 0.0;
  double tex_y0 = 0.0;
  double tex_du = 1.0;
  double tex_dv = 1.0;
  // Optional multiplicative overlay (value / 128), e.g. large-scale ground
  // variation that breaks the repetition of detail tiles.
  TexturePtr overlay;
  double overlay_x0 = 0.0;
  double overlay_y0 = 0.0;
  double overlay_du = 1.0;
  double overlay_dv = 1.0;
  float shade = 1.0f;  // lighting factor of the face (constant per patch)
};

struct Mesh {
  std::vector<Patch> patches;
};

using MeshPtr = std::shared_ptr<const Mesh>;

struct SceneInstance {
  MeshPtr mesh;
  SE3 T_world_obj;
  std::uint16_t instance_id = 0;  // 0 = background (not an object)
  std::uint8_t part_id = 0;       // articulated machines: 1 + part index; 0 = not a part
};

struct Scene {
  std::vector<SceneInstance> instances;
};

}  // namespace sitepose::sim
