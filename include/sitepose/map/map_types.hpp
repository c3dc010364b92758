#pragma once
// Map entities: keyframes and map points (ORB-SLAM2 class), as plain values.
// They are only ever touched through map::MapData (map_data.hpp), which keeps
// the cross references (observations, covisibility, spanning tree) consistent.

#include <array>
#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
#include <set>
#include <vector>

#include "sitepose/core/se3.hpp"

namespace sitepose::map {

using KeyFrameId = std::int64_t;
using PointId = std::int64_t;
inline constexpr KeyFrameId kNoKeyFrame = -1;
inline constexpr PointId kNoPoint = -1;

// 256-bit ORB descriptor by value (no aliasing between threads).
using Descriptor = std::array<std::uint8_t, 32>;

Descriptor descriptor_from_row(const cv::Mat& descriptors, int row);
int descriptor_distance(const Descriptor& a, const Descriptor& b);

// One left-image keypoint of a keyframe with what stereo matching found.
struct KeyPointData {
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();  // level-0 pixel
  int octave = 0;                                   // pyramid level
  double u_right_px = -1.0;                         // < 0: no stereo match
  double depth_m = -1.0;                            // < 0: no stereo depth
  Descriptor descriptor{};
  std::uint16_t instance = 0;  // detector instance under the keypoint, 0 = background
};

struct KeyFrame {
  KeyFrameId id = kNoKeyFrame;
  std::int64_t frame_seq = 0;
  std::int64_t t_ns = 0;
  SE3 T_world_cam;
  std::vector<KeyPointData> keypoints;
  std::vector<PointId> point_of_keypoint;  // per keypoint, kNoPoint if none

  // Covisibility: other keyframe -> number of shared points (>= threshold).
  std::map<KeyFrameId, int> covisibility;
  // Spanning tree.
  KeyFrameId parent = kNoKeyFrame;
  std::set<KeyFrameId> children;
  // Keyframes a closed loop joined to this one (kept on both); the pose
  // graph of each later loop keeps them, and such a keyframe is never
  // removed (ORB-SLAM2 mspLoopEdges, SetNotErase).
  std::set<KeyFrameId> loop_edges;
  // How far the map had been built out from its first keyframe when this
  // one was made: the map-drift distance of its place (map_travel_at,
  // docs/daemon/pose_quality.md). Not changed by culling or loop closing.
  double map_travel_m = 0.0;
  bool bad = false;

  SE3 T_cam_world() const { return T_world_cam.inverse(); }
  Eigen::Vector3d camera_center() const { return T_world_cam.translation(); }
};

struct MapPoint {
  PointId id = kNoPoint;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Descriptor descriptor{};                            // the observation descriptor closest to all others
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // mean viewing direction (unit)
  double min_distance_m = 0.0;                        // scale invariance range
  double max_distance_m = 0.0;
  std::map<KeyFrameId, int> observations;  // keyframe -> keypoint index
  KeyFrameId reference_keyframe = kNoKeyFrame;
  KeyFrameId first_keyframe = kNoKeyFrame;
  // Tracking statistics: in the frustum (visible) vs matched (found).
  int n_visible = 1;
  int n_found = 1;
  bool bad = false;

  double found_ratio() const { return static_cast<double>(n_found) / n_visible; }
};

// What the searches need of a map point (the tracker's projection search,
// the mapper's fusion), copied out under the map lock.
struct PointAppearance {
  PointId id = kNoPoint;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Descriptor descriptor{};
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // mean viewing direction (unit)
  double min_distance_m = 0.0;                        // scale invariance range
  double max_distance_m = 0.0;
};

inline PointAppearance appearance_of(const MapPoint& point) {
  PointAppearance a;
  a.id = point.id;
  a.p_world = point.p_world;
  a.descriptor = point.descriptor;
  a.normal = point.normal;
  a.min_distance_m = point.min_distance_m;
  a.max_distance_m = point.max_distance_m;
  return a;
}

}  // namespace sitepose::map
