#include "sitepose/mapping/keyframe_culling.hpp"

#include <algorithm>

namespace sitepose::mapping {

RedundancyCount count_redundant_points(const map::MapData& map, map::KeyFrameId keyframe,
                                       double close_depth_m) {
  RedundancyCount count;
  const map::KeyFrame* kf = map.keyframe(keyframe);
  if (kf == nullptr) return count;
  for (int i = 0; i < static_cast<int>(kf->point_of_keypoint.size()); ++i) {
    const map::MapPoint* p = map.good_point(kf->point_of_keypoint[i]);
    if (p == nullptr) continue;
    const map::KeyPointData& kp = kf->keypoints[i];
    // Far and monocular points do not decide: the keyframe may be the only
    // one that constrains them well (ORB-SLAM2 stereo rule).
    if (kp.depth_m < 0.0 || kp.depth_m > close_depth_m) continue;
    ++count.close_points;
    if (map.observation_weight(p->id) <= kRedundantObservers) continue;
    int observers = 0;
    for (const auto& [other_id, index] : p->observations) {
      if (other_id == keyframe) continue;
      const map::KeyFrame* other = map.keyframe(other_id);
      if (other == nullptr) continue;
      if (other->keypoints[index].octave <= kp.octave + 1 && ++observers >= kRedundantObservers) break;
    }
    if (observers >= kRedundantObservers) ++count.redundant_points;
  }
  return count;
}

bool is_keyframe_redundant(const map::MapData& map, map::KeyFrameId keyframe, double redundancy,
                           double close_depth_m) {
  const RedundancyCount count = count_redundant_points(map, keyframe, close_depth_m);
  return count.close_points > 0 &&
         static_cast<double>(count.redundant_points) >= redundancy * static_cast<double>(count.close_points);
}

std::vector<map::KeyFrameId> redundant_keyframes(const map::MapData& map, map::KeyFrameId current,
                                                 int n_local, double redundancy, double close_depth_m) {
  std::vector<map::KeyFrameId> result;
  for (map::KeyFrameId other : map.best_covisible(current, n_local)) {
    if (other == map.first_keyframe() || other >= current) continue;
    if (is_keyframe_redundant(map, other, redundancy, close_depth_m)) result.push_back(other);
  }
  std::sort(result.begin(), result.end());
  return result;
}

}  // namespace sitepose::mapping
