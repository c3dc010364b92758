#pragma once
// Value copies of map entities for the mapper's searches. The local mapper
// copies what a step needs under SharedMap::read(), searches without any
// lock, and applies the result under SharedMap::write() after checking that
// the entities it names are still there (shared_map.hpp lock rules).
// Plain values: no pointer into MapData survives the copy.

#include <vector>

#include "sitepose/core/se3.hpp"
#include "sitepose/map/map_data.hpp"

namespace sitepose::mapping {

struct KeyFrameSnapshot {
  map::KeyFrameId id = map::kNoKeyFrame;
  SE3 T_world_cam;
  SE3 T_cam_world;
  std::vector<map::KeyPointData> keypoints;
  std::vector<map::PointId> point_of_keypoint;  // kNoPoint = unmatched keypoint

  Eigen::Vector3d camera_center() const { return T_world_cam.translation(); }
};

struct PointSnapshot : map::PointAppearance {
  std::vector<map::KeyFrameId> observed_by;  // ascending

  bool is_observed_by(map::KeyFrameId keyframe) const;
};

KeyFrameSnapshot snapshot_keyframe(const map::KeyFrame& keyframe);
PointSnapshot snapshot_point(const map::MapPoint& point);

}  // namespace sitepose::mapping
