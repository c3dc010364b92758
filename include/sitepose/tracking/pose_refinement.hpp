#pragma once
// Motion-only BA over a pass's matches, shared by the tracker's passes and
// relocalisation. A pure function over value snapshots; no map access.

#include <vector>

#include "sitepose/map/map_data.hpp"
#include "sitepose/optim/motion_only_ba.hpp"
#include "sitepose/tracking/pass_result.hpp"
#include "sitepose/tracking/prepared_frame.hpp"
#include "sitepose/tracking/projection_search.hpp"

namespace sitepose::tracking {

// Optimises result.T_cam_world against points[match_of_keypoint[k]] (-1 =
// unmatched) with the keypoints' level sigmas; fills the pose, covariance,
// variance factor, inlier matches (point_of_keypoint, n_inliers) and adds the
// solve's time to timings.motion_ba_ms. On a solver error the pose stays,
// no keypoint is matched and result.failure says why.
void optimise_pose(const optim::MotionOnlyBa& motion_ba, const map::ScalePyramid& pyramid,
                   const PreparedFrame& frame, const std::vector<PointView>& points,
                   const std::vector<int>& match_of_keypoint, PassResult& result);

}  // namespace sitepose::tracking
