#include "sitepose/mapping/map_snapshot.hpp"

#include <algorithm>

namespace sitepose::mapping {

bool PointSnapshot::is_observed_by(map::KeyFrameId keyframe) const {
  return std::binary_search(observed_by.begin(), observed_by.end(), keyframe);
}

KeyFrameSnapshot snapshot_keyframe(const map::KeyFrame& keyframe) {
  KeyFrameSnapshot s;
  s.id = keyframe.id;
  s.T_world_cam = keyframe.T_world_cam;
  s.T_cam_world = keyframe.T_world_cam.inverse();
  s.keypoints = keyframe.keypoints;
  s.point_of_keypoint = keyframe.point_of_keypoint;
  return s;
}

PointSnapshot snapshot_point(const map::MapPoint& point) {
  PointSnapshot s;
  static_cast<map::PointAppearance&>(s) = map::appearance_of(point);
  s.observed_by.reserve(point.observations.size());
  // std::map keys come out ascending.
  for (const auto& [kf_id, index] : point.observations) s.observed_by.push_back(kf_id);
  return s;
}

}  // namespace sitepose::mapping
