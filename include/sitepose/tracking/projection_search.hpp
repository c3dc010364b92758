#pragma once
// Matching map points to the keypoints of a frame by projecting them with a
// pose guess (ORB-SLAM2 SearchByProjection, written for sitepose). Pure
// functions over value snapshots of map points; no map access.

#include <optional>
#include <vector>

#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/features/task_pool.hpp"
#include "sitepose/map/map_data.hpp"
#include "sitepose/tracking/prepared_frame.hpp"

namespace sitepose::tracking {

// ORB-SLAM2 ORBmatcher thresholds (Hamming distance of 256 bits).
inline constexpr int kDescriptorDistanceHigh = 100;
inline constexpr int kDescriptorDistanceLow = 50;

// What a tracker needs of a map point, copied out under the map lock.
struct PointView : map::PointAppearance {
  int octave_hint = -1;  // level where it was last seen (motion-model search), -1 unknown
  // Time between the first and the last keyframe observing the point (s);
  // 0 for a point seen by one keyframe (see pose_refinement.hpp).
  double observed_span_s = 0.0;
};

PointView make_point_view(const map::MapPoint& point);
// make_point_view() with observed_span_s from the point's keyframes' times
// (`map`: the map `point` belongs to).
PointView make_point_view_with_span(const map::MapData& map, const map::MapPoint& point);

// How the point is seen from `camera_center` (world frame), when it can be
// matched there by its appearance: the distance within its scale range
// (0.8 x min to 1.2 x max) and the viewing direction within 60 deg of its
// mean one (ORB-SLAM2 isInFrustum); none otherwise.
struct ViewingGeometry {
  double distance_m = 0.0;
  double view_cos = 0.0;  // cosine of the angle to the point's mean viewing direction
};
std::optional<ViewingGeometry> within_viewing_range(const PointView& point,
                                                    const Eigen::Vector3d& camera_center);

struct SearchParams {
  double radius_px = 7.0;  // scaled by the level's scale factor
  double ratio = 1.0;      // best < ratio * second best (1.0 = off)
  int max_distance = kDescriptorDistanceHigh;
  bool check_view_angle = false;  // local-map search: viewing cos >= 0.5, scale range
};

// For every point: project with T_cam_world; among usable, still unmatched
// keypoints near the projection (stereo ones also near the predicted u_r),
// pick the best descriptor. `match_of_keypoint` (size frame.size(), -1 =
// free) receives the point index; returns the number of new matches and
// appends the indices of points that were inside the frustum to `visible`.
// A point takes a keypoint an earlier point took only with a smaller
// distance. pool: lent threads for the points' searches (nullptr = all on
// the caller's thread); the result is the same either way.
int search_by_projection(const PreparedFrame& frame, const StereoCamera& camera,
                         const map::ScalePyramid& pyramid, const SE3& T_cam_world,
                         const std::vector<PointView>& points, const std::vector<std::uint8_t>& usable,
                         const SearchParams& params, std::vector<int>& match_of_keypoint,
                         std::vector<int>* visible, features::TaskPool* pool = nullptr);

}  // namespace sitepose::tracking
