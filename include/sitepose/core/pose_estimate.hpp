#pragma once
// The tracker's answer for one frame, as consumers (LCM, CAN, files) see it.

#include <cstdint>
#include <string>

#include "sitepose/core/se3.hpp"

namespace sitepose {

enum class TrackingState {
  kOk,          // pose from enough static features
  kRecovering,  // pose predicted or from few features; do not steer on it
  kLost,        // no pose
};

const char* to_string(TrackingState state);

struct PoseCounters {
  int features_extracted = 0;   // left keypoints this frame
  int features_used_pass1 = 0;  // inliers of pass 1 (background only)
  int features_used = 0;        // inliers of the final pose
  int static_objects_unmasked = 0;
  int matches = 0;  // the final pose's matched map points; 0 when LOST
  // Of those, the ones a keyframe made tracking::kOldKeyFrameAge_s (60 s)
  // or more before this frame observes: the tracker meeting the map of an
  // earlier pass (issue 19).
  int matches_from_old_keyframes = 0;
  double masked_area_ratio = 0.0;  // mar of Algorithm 1, [0, 1]
};

struct PoseEstimate {
  std::int64_t t_ns = 0;
  std::int64_t seq = 0;
  SE3 T_world_cam;  // left camera in the SLAM world frame
  // Covariance of the tangent perturbation [translation; rotation] applied on
  // the left of T_world_cam (m^2, rad^2).
  Matrix6d covariance = Matrix6d::Identity();
  // How far the map this pose was tracked against had been built out from
  // its origin, m: the distance its drift grew over (map::map_travel_at;
  // the published covariance's drift term, docs/daemon/pose_quality.md).
  // Bounded where the machine works over a map it has built; LOST: the
  // last tracked pose's.
  double map_travel_m = 0.0;
  TrackingState state = TrackingState::kLost;
  std::string state_reason;  // why RECOVERING / LOST, empty when OK
  // The keyframe the pose was tracked from (its id in the map, -1: none, as
  // when LOST) and the pose relative to it. A map corrected later (loop
  // closing, global BA, a provisional map joined) moves the keyframe, and
  // the frame with it: ORB-SLAM2's relative frame poses, the trajectory
  // re-expressed in the final map (slam::SlamSystem::poses_in_final_map).
  std::int64_t reference_keyframe = -1;
  SE3 T_reference_cam;
  PoseCounters counters;
};

}  // namespace sitepose
