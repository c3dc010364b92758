#pragma once
// One tracking pass's answer (Tracker::estimate()); keypoint indices refer
// to the PreparedFrame it was estimated on.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/core/se3.hpp"
#include "sitepose/map/map_data.hpp"

namespace sitepose::tracking {

struct AnchorLocalMap;  // tracker.hpp

struct EstimateTimings {
  double motion_model_ms = 0.0;  // incl. relocalisation when it was needed
  double local_map_ms = 0.0;     // projection search of the local map
  double motion_ba_ms = 0.0;     // all motion-only BA solves of this estimate
  double total_ms = 0.0;
};

struct PassResult {
  bool valid = false;                 // a pose was estimated
  bool needs_initialisation = false;  // the map is empty
  SE3 T_cam_world;
  std::optional<Matrix6d> covariance_world_cam;  // Hessian covariance (unit pixel noise model)
  double variance_factor = 1.0;                  // a-posteriori, see optim::MotionBaResult
  std::vector<map::PointId> point_of_keypoint;   // inlier matches, kNoPoint otherwise
  std::vector<map::PointId> visible_points;      // in the frustum of the local map
  int n_inliers = 0;
  int n_usable_keypoints = 0;
  bool relocalised = false;
  // With tracking.trust_established_map, the last solve's established map
  // points (pose_refinement.hpp): matched, and projecting into the image at
  // its starting pose. Both 0 without the option.
  int established_matched = 0;
  int established_in_view = 0;
  std::string failure;  // why valid == false or the state is degraded
  EstimateTimings timings;
  // The local map this pass listed and searched, with its inliers as
  // indices into it: what later steps on the frame that start from this pass
  // search (the map check, pass 2; Tracker::estimate's anchor_local). Empty
  // when the pass searched no local map of its own.
  std::shared_ptr<const AnchorLocalMap> local_map;
};

}  // namespace sitepose::tracking
